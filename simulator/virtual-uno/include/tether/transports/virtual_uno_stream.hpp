/// @file virtual_uno_stream.hpp
/// A virtual Uno's UART0 as a ByteStream, so every codec client drives simulated firmware exactly as it
/// drives a real port.
///
/// The stream takes the board's output handler: bytes the simulated MCU transmits arrive on the simulation
/// thread and wait in a bounded inbox (64 KiB; when nobody reads for that long, the oldest bytes go and
/// `discarded()` counts them) until a read takes them. Writes are queued to the board at once, as a tty
/// driver accepts bytes before they are on the wire; the board feeds them to the UART at the line rate.
/// Faults and resets are configured on the board (`board()`); the stream itself adds none.
///
/// A ring of boards (a `VirtualUnoGroup` wired first -> ... -> last) is one stream too (`attach_ring`):
/// the host's writes enter the first board's RX, its reads take what the last board transmits, so a
/// host-side codec sits in the ring exactly as a host on a real Elcano ring does.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>

#include "tether/transports/byte_stream.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::transports {

/// ByteStream over a VirtualUno's UART0.
class VirtualUnoStream final : public ByteStream {
 public:
  struct Inbox;

  /// Longest wait in `open` for the firmware to enable its UART receiver (wall time).
  static constexpr std::chrono::milliseconds kBootLimit{5000};

  /// Creates a board from `options`, starts it on its own thread and returns a stream that owns it (the
  /// board stops when the stream closes), once the firmware has enabled its UART receiver: bytes written
  /// before that would be lost, as on a real board booting. Errors: those of `VirtualUno::create`;
  /// `TransportError::boot_timeout` when the receiver is not enabled within `kBootLimit`.
  static std::shared_ptr<VirtualUnoStream> open(executor_type executor, VirtualUnoOptions options,
                                                error_code& error);
  /// Throwing variant of `open` (std::system_error).
  static std::shared_ptr<VirtualUnoStream> open(executor_type executor, VirtualUnoOptions options);
  /// Stream over a board the caller owns and keeps alive while the stream exists (e.g. a member of a
  /// lockstep group). Starting and stopping the board stays the caller's business.
  static std::shared_ptr<VirtualUnoStream> attach(executor_type executor, VirtualUno& board);
  /// Stream over a ring the caller owns: writes go to `first`'s RX, reads come from `last`'s TX (which
  /// must not be wired to another board: `VirtualUnoGroup::connect`). The boards stay the caller's, as
  /// with `attach`; `first == last` is `attach`.
  static std::shared_ptr<VirtualUnoStream> attach_ring(executor_type executor, VirtualUno& first, VirtualUno& last);

  /// The simulated board the stream writes to (faults, resets, pins, time); the first board of a ring.
  VirtualUno& board() { return *board_; }
  /// The board whose transmissions the stream reads: `board()`, or the last board of a ring.
  VirtualUno& reading_board() { return *source_; }
  /// Received bytes dropped because nobody read them (inbox overflow).
  std::uint64_t discarded() const;

  std::string description() const override;

  /// Constructed by `open`/`attach` (public for std::make_shared).
  VirtualUnoStream(executor_type executor, std::shared_ptr<VirtualUno> board, bool owns_board);
  /// Constructed by `attach_ring`: writes to `board`, reads from `source` (public for std::make_shared).
  VirtualUnoStream(executor_type executor, std::shared_ptr<VirtualUno> board, std::shared_ptr<VirtualUno> source,
                   bool owns_board);
  ~VirtualUnoStream() override;

 protected:
  void do_read(asio::mutable_buffer buffer, IoHandler handler) override;
  void do_write(asio::const_buffer buffer, IoHandler handler) override;
  void do_close(error_code& error) override;

 private:
  std::shared_ptr<VirtualUno> board_;
  std::shared_ptr<VirtualUno> source_;  // whose output handler feeds the inbox
  bool owns_board_;
  std::shared_ptr<Inbox> inbox_;
};

}  // namespace tether::transports
