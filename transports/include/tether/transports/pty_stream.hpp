/// @file pty_stream.hpp
/// A pseudo-terminal as a ByteStream: the program holds the master side, an outside program (picocom, a
/// reference RomiSerial host, socat) opens `slave_path()` like a serial port.
///
/// The slave is put in raw mode before anybody can open it (otherwise the line discipline echoes and
/// translates CR/LF), and the harness keeps its own slave fd open so the master does not see a hang-up
/// (EIO) while no outside program has the port open.
#pragma once

#include <boost/asio/posix/stream_descriptor.hpp>

#include <memory>
#include <string>

#include "tether/transports/asio_object_stream.hpp"

namespace tether::transports {

/// Master side of a new pty; create with `open`.
class PtyStream final : public AsioObjectStream<asio::posix::stream_descriptor> {
 public:
  /// Creates a pty pair in raw mode. Errors: OS errors of posix_openpt/grantpt/unlockpt.
  static std::shared_ptr<PtyStream> open(executor_type executor, error_code& error);
  /// Throwing variant of `open`.
  static std::shared_ptr<PtyStream> open(executor_type executor);

  /// Path of the slave side (e.g. /dev/pts/7), for an outside program.
  const std::string& slave_path() const { return slave_path_; }
  std::string description() const override { return "pty " + slave_path_; }

  /// Constructed by `open` (public for std::make_shared).
  PtyStream(executor_type executor, int master_fd, int slave_fd, std::string slave_path);
  ~PtyStream() override;

 protected:
  void do_close(error_code& error) override;

 private:
  int slave_fd_;
  std::string slave_path_;
};

}  // namespace tether::transports
