/// @file arduino_serial.hpp
/// Adapter from an Arduino `Stream` (`Serial`, `Serial1`, a `SoftwareSerial`, a USB CDC port) to the
/// device's byte streams. Arduino builds only (`ARDUINO` defined by the Arduino toolchain); elsewhere
/// this header declares nothing.
///
/// Bytes go in runs, as over Tether's own UART (`UartStream`): `read_some` takes what the port holds with
/// one look at the port and `write_all` a reply's bytes in one loop. On the core's `HardwareSerial`
/// (`Serial`, which is what the constructor below sees for `ArduinoSerial serial(Serial)`, and a port
/// passed as a plain `Stream&`) both work on the core's rings directly; on any other `Stream` they make the `Stream`'s virtual calls, one available()
/// per run (TetherArduinoStream.h).
///
///     ArduinoSerial serial(Serial);            // at global scope: only stores the reference
///     RomiSerial romi(serial, serial, handlers, count);
///     void setup() { Serial.begin(115200); }   // open the port in setup(), as usual
///     void loop() { romi.handle_input(); }
#pragma once

#ifdef ARDUINO

#include <Arduino.h>
#include <stdint.h>

#include "TetherArduinoStream.h"
#include "tether/romi/device/streams.hpp"

namespace tether {
namespace romi {
namespace device {

/// Input and output stream over an Arduino `Stream`.
class ArduinoSerial final : public IInputStream, public IOutputStream {
 public:
  /// Wraps `serial`, which must outlive this object. Safe before `serial.begin()`. One of the core's
  /// hardware ports passed as a `Stream&` takes the fast path below (`core_serial`).
  explicit ArduinoSerial(Stream& serial) : serial_(&serial), hardware_(tether::arduino::core_serial(&serial)) {}
  /// Wraps the core's hardware port `serial` (the fast path). Safe before `serial.begin()`.
  explicit ArduinoSerial(HardwareSerial& serial) : serial_(&serial), hardware_(&serial) {}
  /// True when the port has a received byte.
  bool available() override { return serial_->available() > 0; }
  /// Takes the next received byte.
  bool read(char& c) override {
    const int byte = serial_->read();
    if (byte < 0) return false;
    c = static_cast<char>(byte);
    return true;
  }
  /// Sends `c` (HardwareSerial waits while its TX buffer is full).
  bool write(char c) override {
    const uint8_t byte = static_cast<uint8_t>(c);
    if (hardware_ == nullptr) return serial_->write(byte) == 1;
    tether::arduino::write_byte(*hardware_, byte);  // a reply's '#': straight into the idle UART
    return true;
  }
  /// Takes up to `capacity` waiting bytes: one available(), then the bytes it counted.
  uint8_t read_some(uint8_t* bytes, uint8_t capacity) override {
    return tether::arduino::read_run_inline(hardware_, *serial_, bytes, capacity);
  }
  /// Queues a reply's `size` bytes (HardwareSerial waits while its TX buffer is full).
  void write_all(const uint8_t* bytes, uint8_t size) override {
    if (hardware_ == nullptr) {
      tether::arduino::write_all(*serial_, bytes, size);
    } else {
      tether::arduino::write_all_inline(*hardware_, bytes, size);
    }
  }

 private:
  Stream* serial_;
  HardwareSerial* hardware_;  // serial_ when it is the core's HardwareSerial, else null
};

}  // namespace device
}  // namespace romi
}  // namespace tether

#endif  // ARDUINO
