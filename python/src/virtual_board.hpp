// tether.VirtualUno and its clock (tether.VirtualUnoClock): what a client opened on a board, or given
// `clock=board.clock`, runs its deadlines on. Registered in transports.cpp; used by every client.
#pragma once

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "binding.hpp"
#include "tether/transports/virtual_uno.hpp"
#include "tether/transports/virtual_uno_clock.hpp"

namespace tether::python {

/// The clients whose deadlines run on a board's clock. Closing the board closes them: a stopped board's
/// time no longer moves, so their waits would never end.
class BoardClients {
 public:
  /// Registers `close` for as long as `alive` lives; false (nothing registered) once the board is closed.
  bool add(std::weak_ptr<void> alive, std::function<void()> close);
  /// Marks the board closed and closes every live client. Call without the GIL (closing drops callbacks,
  /// which take it).
  void close_all();

 private:
  std::mutex mutex_;
  bool closed_ = false;
  std::vector<std::pair<std::weak_ptr<void>, std::function<void()>>> entries_;
};

/// `tether.VirtualUno`: a simulated Uno, either on its own thread (its UART on a pty, `port`) or, with
/// `start=False`, advanced only by `run_for` (no pty: clients open on the board itself).
struct VirtualBoard {
  std::shared_ptr<transports::VirtualUno> board;
  std::shared_ptr<transports::VirtualUnoClock> clock;  ///< The board's simulated time as a LinkClock.
  std::string port;                                    ///< The pty's path; empty with `start=False`.
  bool started = true;                                 ///< Runs on its own thread (else `run_for`).
  std::atomic<bool> closed{false};
  std::shared_ptr<BoardClients> clients = std::make_shared<BoardClients>();
  std::weak_ptr<transports::ByteStream> attached;  ///< The client stream of a `start=False` board.
  ProcessGeneration generation;                    ///< Made before a fork: inert in the child.

  /// Stops the board (may run without the GIL: the last client on the board's clock can drop it).
  ~VirtualBoard();
  /// The board; raises ClosedError after `close()`.
  transports::VirtualUno& get();
  /// Closes the clients on its clock (ClosedError, before the pty hangs up), then stops the board and its
  /// pty. Idempotent; call with the GIL.
  void close();
};

/// `tether.VirtualUnoClock`: a board's simulated time, for a client's `clock=` argument.
struct BoardClock {
  std::shared_ptr<VirtualBoard> board;
};

/// The stream of a client opened on `board` (`take_stream`): its pty as a serial port at `baud` without a
/// boot wait, or the UART of a `start=False` board (one client at a time: ValueError for a second).
Transport board_transport(const std::shared_ptr<VirtualBoard>& board, unsigned baud);

/// Remembers a started board's pty (`port`) for `board_at_port`, for as long as the board lives.
void register_board_port(const std::shared_ptr<VirtualBoard>& board);

/// The live, open board of this process whose pty is `path` (compared as given and resolved), else null:
/// a client that opens a board's `port` by its path (a program written for serial ports, run in-process)
/// runs on that board's clock and is closed with it, as if opened on the board.
std::shared_ptr<VirtualBoard> board_at_port(const std::string& path);

/// The board of a client's `clock=` argument (a `tether.VirtualUnoClock`), null for None. Raises TypeError
/// for another type, ClosedError for a closed board (before the client opens its port).
std::shared_ptr<VirtualBoard> board_of_clock(py::handle clock);

/// The board a client's deadlines run on: `chosen` (its `clock=`), else the board it was opened on
/// (`Client(board)`, or its pty by path: `board_at_port`), else null (the steady clock).
inline std::shared_ptr<VirtualBoard> deadline_board(std::shared_ptr<VirtualBoard> chosen, const Transport& transport) {
  return chosen ? chosen : transport.board;
}

/// The LinkClock for a client's options: the board's, or null (the steady clock).
inline std::shared_ptr<client::LinkClock> link_clock(const std::shared_ptr<VirtualBoard>& board) {
  return board ? board->clock : nullptr;
}

/// Finishes opening a client on `board`'s clock (nothing when null): the board's `close()` will close it
/// (raises ClosedError, the client closed, when the board closed meanwhile). Returns what the client's
/// wrapper keeps alive: `owner` (the transport's) and the board.
template <typename Client>
std::shared_ptr<void> join_board(const std::shared_ptr<VirtualBoard>& board, const std::shared_ptr<Client>& client,
                                 std::shared_ptr<void> owner) {
  if (!board) return owner;
  const bool joined = board->clients->add(client, [weak = std::weak_ptr<Client>(client)] {
    if (const auto held = weak.lock()) held->close();
  });
  if (!joined) {
    {
      py::gil_scoped_release release;
      client->close();
    }
    raise_closed("the virtual board");
  }
  return std::make_shared<std::pair<std::shared_ptr<void>, std::shared_ptr<VirtualBoard>>>(std::move(owner), board);
}

}  // namespace tether::python
