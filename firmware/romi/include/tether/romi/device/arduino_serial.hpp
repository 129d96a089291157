/// @file arduino_serial.hpp
/// Adapter from an Arduino `Stream` (`Serial`, `Serial1`, a `SoftwareSerial`, a USB CDC port) to the
/// device's byte streams. Arduino builds only (`ARDUINO` defined by the Arduino toolchain); elsewhere
/// this header declares nothing.
///
///     ArduinoSerial serial(Serial);            // at global scope: only stores the reference
///     RomiSerial romi(serial, serial, handlers, count);
///     void setup() { Serial.begin(115200); }   // open the port in setup(), as usual
///     void loop() { romi.handle_input(); }
#pragma once

#ifdef ARDUINO

#include <Arduino.h>
#include <stdint.h>

#include "tether/romi/device/streams.hpp"

namespace tether {
namespace romi {
namespace device {

/// Input and output stream over an Arduino `Stream`.
class ArduinoSerial final : public IInputStream, public IOutputStream {
 public:
  /// Wraps `serial`, which must outlive this object. Safe before `serial.begin()`.
  explicit ArduinoSerial(Stream& serial) : serial_(&serial) {}
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
  bool write(char c) override { return serial_->write(static_cast<uint8_t>(c)) == 1; }

 private:
  Stream* serial_;
};

}  // namespace device
}  // namespace romi
}  // namespace tether

#endif  // ARDUINO
