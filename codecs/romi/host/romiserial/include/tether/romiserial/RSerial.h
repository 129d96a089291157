/// @file RSerial.h
/// RomiSerial compatibility (`romiserial::RSerial`): a serial port opened the way RomiSerial's host opens
/// it, on Tether's serial transport (`tether::transports::SerialPortStream`, raw 8N1, exclusive).
///
/// @code
///   auto log = std::make_shared<Console>();
///   auto serial = std::make_shared<RSerial>("/dev/ttyACM0", 115200, true, log);
///   RomiSerialClient client(serial, serial, log, 0, "blink");
/// @endcode
///
/// Differences from RomiSerial's RSerial, all on purpose:
///   - After opening, it waits 2 s for an Uno's bootloader (Tether's `SerialOptions::arduino_uno()`, the
///     bytes of the boot discarded) where RomiSerial sleeps 3 s.
///   - A port that cannot be opened throws `std::runtime_error` naming the port and the OS error (RomiSerial:
///     "Failed to open the serial device"); so does a baud rate the port refuses (RomiSerial tries anyway).
///   - A `RomiSerialClient` built on it takes the port over (Tether's client reads it continuously); from
///     then on `available`, `read` and `write` of this object return false: talk through the client.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "IInputStream.h"
#include "ILog.h"
#include "IOutputStream.h"

namespace romiserial {

/// `reset` argument of `RSerial`: keep the Uno running when the port closes.
static const bool kDontReset = false;
/// `reset` argument of `RSerial`: drop DTR when the port closes (HUPCL), so the next open resets an Uno.
static const bool kReset = true;

class RomiSerialClient;

/// A serial port for `RomiSerialClient` (see the file overview).
class RSerial : public IInputStream, public IOutputStream {
 public:
  /// Opens `device` at `baudrate` (8N1) and waits for the board's boot; `reset`: see `kReset`. Errors are
  /// reported to `log` and thrown as `std::runtime_error`.
  RSerial(const std::string& device, uint32_t baudrate, bool reset, std::shared_ptr<ILog> log);
  ~RSerial() override;
  RSerial(const RSerial&) = delete;
  RSerial& operator=(const RSerial&) = delete;

  /// How long `available()` and `read()` wait for a byte (RomiSerial's default: 0.1 s).
  void set_timeout(double seconds) override;
  /// True when a byte arrived within the timeout (kept for the next `read`).
  bool available() override;
  /// One byte within the timeout; false on timeout, a failed port, or once a client took the port.
  bool read(char& c) override;
  /// Writes one byte; false on a failed port or once a client took the port.
  bool write(char c) override;

  /// The port's path, as given.
  const std::string& device() const;

  /// Tether's state of the port (the stream and its I/O thread); defined in the library.
  struct Link;

 private:
  friend class RomiSerialClient;
  std::shared_ptr<Link> link_;
  std::shared_ptr<ILog> log_;
};

}  // namespace romiserial
