/// @file TetherArduinoStream.h
/// Runs of bytes from and to an Arduino `Stream`, for the libraries' glue: the device code takes its input
/// in runs (a decoder's tight loop over a span) and writes a frame at a time, as the bare-metal images do
/// with Tether's UART. The library assembly copies this file into each library's src/
/// (firmware/arduino/assemble-library.cmake).
///
/// Two kinds of port:
///   - the core's `HardwareSerial` (`Serial`, `Serial1`..): its own member functions, called without
///     virtual dispatch (`serial.HardwareSerial::read()`, the documented API with a qualified name), so
///     the link-time optimiser the Arduino IDE runs (-flto) inlines them into the run's loop: one
///     available() per run, then the ring's bytes at a few cycles each;
///   - any other `Stream` (SoftwareSerial, a USB CDC port, a sketch's own class): one virtual available()
///     per run, then a virtual read() per byte (all a `Stream` offers).
#pragma once

#include <Arduino.h>
#include <stdint.h>

namespace tether {
namespace arduino {

/// Takes up to `capacity` bytes waiting in `serial`'s receive ring into `bytes`; returns how many.
inline uint8_t read_run(HardwareSerial& serial, uint8_t* bytes, uint8_t capacity) {
  const int waiting = serial.HardwareSerial::available();
  const uint8_t count = waiting < static_cast<int>(capacity) ? static_cast<uint8_t>(waiting) : capacity;
  // available() counted them and nothing else reads this ring (its interrupt only adds): each read()
  // delivers one.
  for (uint8_t i = 0; i != count; ++i) bytes[i] = static_cast<uint8_t>(serial.HardwareSerial::read());
  return count;
}

/// Takes up to `capacity` bytes waiting in `stream` into `bytes`; returns how many (a read() that finds
/// nothing ends the run early).
inline uint8_t read_run(Stream& stream, uint8_t* bytes, uint8_t capacity) {
  const int waiting = stream.available();
  const uint8_t count = waiting < static_cast<int>(capacity) ? static_cast<uint8_t>(waiting) : capacity;
  for (uint8_t i = 0; i != count; ++i) {
    const int byte = stream.read();
    if (byte < 0) return i;
    bytes[i] = static_cast<uint8_t>(byte);
  }
  return count;
}

/// Reads a run from `hardware` when it is set (the fast path), else from `stream`.
inline uint8_t read_run(HardwareSerial* hardware, Stream& stream, uint8_t* bytes, uint8_t capacity) {
  return hardware != nullptr ? read_run(*hardware, bytes, capacity) : read_run(stream, bytes, capacity);
}

/// Queues `size` bytes on `serial` (waiting while its TX ring is full), each through the core's own
/// write(uint8_t) without virtual dispatch.
inline void write_all(HardwareSerial& serial, const uint8_t* bytes, size_t size) {
  for (size_t i = 0; i != size; ++i) serial.HardwareSerial::write(bytes[i]);
}

/// Writes `size` bytes to `hardware` when it is set, else to `stream` (Print's write(buffer, size)).
inline void write_all(HardwareSerial* hardware, Print& stream, const uint8_t* bytes, size_t size) {
  if (hardware != nullptr) {
    write_all(*hardware, bytes, size);
  } else {
    stream.write(bytes, size);
  }
}

}  // namespace arduino
}  // namespace tether
