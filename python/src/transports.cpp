// tether.transports (serial, TCP, pty streams) and tether.VirtualUno (a simulated Uno behind a pty).
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <system_error>
#include <thread>

#include "binding.hpp"
#include "tether/core/counters.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether/transports/tcp_stream.hpp"
#include "tether/transports/virtual_uno.hpp"
#include "tether/transports/virtual_uno_stream.hpp"
#include "virtual_board.hpp"

namespace tether::python {

void set_firmware_dir(const std::string& dir);

bool BoardClients::add(std::weak_ptr<void> alive, std::function<void()> close) {
  std::lock_guard lock(mutex_);
  if (closed_) return false;
  std::erase_if(entries_, [](const auto& entry) { return entry.first.expired(); });
  entries_.emplace_back(std::move(alive), std::move(close));
  return true;
}

void BoardClients::close_all() {
  std::vector<std::pair<std::weak_ptr<void>, std::function<void()>>> entries;
  {
    std::lock_guard lock(mutex_);
    closed_ = true;
    entries.swap(entries_);
  }
  for (const auto& entry : entries) entry.second();
}

VirtualBoard::~VirtualBoard() {
  if (generation.inherited()) {  // its simulation thread is the parent's: keep it as it is
    leak(clients);
    leak(clock);
    leak(board);
    return;
  }
  const auto shut_down = [this] {
    clients->close_all();
    clock.reset();
    board.reset();
  };
  if (PyGILState_Check() != 0) {
    py::gil_scoped_release release;
    shut_down();
  } else {
    shut_down();
  }
}

transports::VirtualUno& VirtualBoard::get() {
  if (generation.inherited()) raise_inherited("the virtual board");
  if (closed.load() || !board) raise_closed("the virtual board");
  return *board;
}

void VirtualBoard::close() {
  if (generation.inherited()) return;  // nothing of it runs in this process
  if (closed.exchange(true) || !board) return;
  py::gil_scoped_release release;
  // Clients on its clock first, so a client opened on its pty by path gets ClosedError like one opened
  // on the board, not the pty's hang-up (which raced the close_all, ConnectionError under load).
  clients->close_all();
  board->stop();  // the pty too: other clients on it see the hang-up
}

namespace {

// The started boards of this process, for `board_at_port`; expired entries are dropped as new ones come.
struct BoardPorts {
  std::mutex mutex;
  std::vector<std::weak_ptr<VirtualBoard>> boards;
};

BoardPorts& board_ports() {
  static BoardPorts ports;
  return ports;
}

// `path` resolved (symlinks, `..`), or as given when it cannot be.
std::string resolved(const std::string& path) {
  std::error_code error;
  const std::filesystem::path canonical = std::filesystem::weakly_canonical(path, error);
  return error ? path : canonical.string();
}

}  // namespace

void register_board_port(const std::shared_ptr<VirtualBoard>& board) {
  BoardPorts& ports = board_ports();
  std::lock_guard lock(ports.mutex);
  std::erase_if(ports.boards, [](const auto& entry) { return entry.expired(); });
  ports.boards.push_back(board);
}

std::shared_ptr<VirtualBoard> board_at_port(const std::string& path) {
  const std::string wanted = resolved(path);
  BoardPorts& ports = board_ports();
  std::lock_guard lock(ports.mutex);
  for (const auto& entry : ports.boards) {
    std::shared_ptr<VirtualBoard> board = entry.lock();
    if (!board || board->closed.load() || board->port.empty()) continue;
    if (board->port == path || resolved(board->port) == wanted) return board;
  }
  return nullptr;
}

std::shared_ptr<VirtualBoard> board_of_clock(py::handle clock) {
  if (clock.is_none()) return nullptr;
  if (!py::isinstance<BoardClock>(clock)) {
    throw py::type_error("clock must be a tether.VirtualUnoClock (board.clock) or None, got " +
                         py::str(py::type::of(clock).attr("__name__")).cast<std::string>());
  }
  std::shared_ptr<VirtualBoard> board = clock.cast<const BoardClock&>().board;
  board->get();  // ClosedError for a closed board
  return board;
}

Transport board_transport(const std::shared_ptr<VirtualBoard>& board, unsigned baud) {
  board->get();  // ClosedError for a closed board
  if (baud == 0) throw py::value_error("baud must be a positive number of bits per second");
  Transport transport;
  if (board->started) {
    transport = open_serial(board->port, SerialArguments{baud, 0.0, {}});
  } else {
    if (const auto attached = board->attached.lock(); attached && attached->is_open()) {
      throw py::value_error("a board made with start=False serves one client at a time (close the other first)");
    }
    transport.io = io_thread();
    // Holding the board (not owning its running: it never runs on its own): the stream may outlive the
    // VirtualBoard by a handler on the io thread, and its destructor still clears the board's output handler.
    auto stream = std::make_shared<transports::VirtualUnoStream>(transport.io->executor(), board->board, false);
    board->attached = stream;
    transport.stream = std::move(stream);
  }
  transport.keep_alive = board;
  transport.board = board;
  return transport;
}

namespace {

[[noreturn]] void raise_std_error(const std::error_code& error, const std::string& message) {
  if (error.category() == std::generic_category() || error.category() == std::system_category()) {
    py::object exception = py::module_::import("builtins").attr("OSError")(error.value(), message);
    PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(exception.ptr())), exception.ptr());
    throw py::error_already_set();
  }
  throw py::value_error(message);
}

}  // namespace

void register_transports(py::module_& parent) {
  py::class_<LinkCounters>(parent, "LinkCounters", "Counters of a link's decoder and session engine (they only grow).")
      .def_readonly("frames_ok", &LinkCounters::frames_ok, "Frames that passed every check.")
      .def_readonly("crc_errors", &LinkCounters::crc_errors, "Frames dropped for a checksum mismatch.")
      .def_readonly("framing_errors", &LinkCounters::framing_errors, "Frames dropped as malformed.")
      .def_readonly("oversize_frames", &LinkCounters::oversize_frames, "Frames dropped for their size.")
      .def_readonly("resyncs", &LinkCounters::resyncs, "Times the decoder skipped garbage.")
      .def_readonly("partial_timeouts", &LinkCounters::partial_timeouts, "Partial frames dropped at their deadline.")
      .def_readonly("stale", &LinkCounters::stale, "Replies whose id was not in flight (dropped).")
      .def_readonly("retries", &LinkCounters::retries, "Re-sends of a request with the same id.")
      .def_readonly("timeouts", &LinkCounters::timeouts, "Calls that ran out of time.")
      .def_readonly("resets", &LinkCounters::resets, "Device resets detected.")
      .def("__repr__", [](const LinkCounters& c) {
        return "LinkCounters(frames_ok=" + std::to_string(c.frames_ok) + ", crc_errors=" + std::to_string(c.crc_errors) +
               ", framing_errors=" + std::to_string(c.framing_errors) + ", stale=" + std::to_string(c.stale) +
               ", retries=" + std::to_string(c.retries) + ", timeouts=" + std::to_string(c.timeouts) + ")";
      });

  py::module_ module = parent.def_submodule("transports", "Byte streams a client opens on: serial, TCP, pty.");

  py::class_<Transport>(module, "Transport", "A byte stream for one client (``Client(transport)`` takes it).")
      .def_property_readonly("path", [](const Transport& t) { return t.path; },
                             "A serial port's path or a pty's slave path (open it with another program); else ''.")
      .def_property_readonly("description",
                             [](const Transport& t) { return t.stream ? t.stream->description() : std::string("(taken)"); },
                             "What the stream is, for messages.")
      .def_property_readonly("taken", [](const Transport& t) { return !t.stream; }, "True once a client uses it.")
      .def(
          "link_counters",
          [](const Transport& t) -> py::object {
            if (!t.port) return py::none();
            return link_counters_dict(t.port->link_counters());
          },
          "A serial port's outage counters: {'disconnects', 'reconnects', 'time_down_ms', 'up', 'gave_up'}; "
          "None for other transports.")
      .def(
          "on_link_event",
          [](const Transport& t, py::object callback) {
            if (!t.port) throw py::value_error("link events are a serial port's (this transport is not one)");
            PyCallback call(std::move(callback));
            t.port->add_link_handler([call](const transports::LinkEvent& event) {
              if (!call || interpreter_exiting()) return;
              py::gil_scoped_acquire gil;
              call(link_event_dict(event));
            });
          },
          py::arg("callback"),
          "Calls ``callback(event)`` on the I/O thread for each change of a serial port's link: a dict "
          "{'kind': 'down'|'up'|'gave_up', 'reason', 'path', 'down_ms', 'attempts'}. It must not block.");

  module.def(
      "serial",
      [](const std::string& path, unsigned baud, double boot_wait, const std::string& ready_banner, bool reconnect,
         unsigned max_attempts, std::optional<std::string> boot) {
        return open_serial(path, SerialArguments{baud, boot_wait, ready_banner, reconnect, max_attempts, boot});
      },
      py::arg("path"), py::kw_only(), py::arg("baud") = 115200u, py::arg("boot_wait") = 2.0,
      py::arg("ready_banner") = "", py::arg("reconnect") = true, py::arg("max_attempts") = 0u,
      py::arg("boot") = py::none(),
      "Opens a serial port (raw 8N1, exclusive). An Uno resets when its port opens: ``boot_wait`` seconds are "
      "waited and what it printed meanwhile is dropped, or, with ``ready_banner``, the port is ready once the "
      "firmware printed it. ``boot``: 'fixed' (the default here: a bare port knows no codec) or 'none' (no wait; "
      "a client's ``boot='detect'`` waits for its firmware's boot instead). A port that vanishes (unplugged) is re-opened when it is back (``reconnect``, "
      "at most ``max_attempts`` attempts per outage, 0: forever); meanwhile calls raise DisconnectedError. "
      "Raises FileNotFoundError/PermissionError/OSError, TransportError (bad baud, banner not seen: "
      "TransportTimeoutError).");
  module.def(
      "tcp",
      [](const std::string& host, int port, double timeout) {
        if (port < 1 || port > 65535) throw py::value_error("port must be 1..65535");
        if (!(timeout > 0.0) || timeout > 3600.0) throw py::value_error("timeout must be 0 < t <= 3600 s");
        Transport transport;
        transport.io = io_thread();
        transport.path = host + ":" + std::to_string(port);
        boost::system::error_code error;
        {
          py::gil_scoped_release release;
          transport.stream = transports::TcpStream::connect(
              transport.io->executor(), host, static_cast<unsigned short>(port),
              std::chrono::milliseconds(std::lround(timeout * 1000.0)), error);
        }
        if (error) raise_error(error, transport.path + ": " + error.message());
        return transport;
      },
      py::arg("host"), py::arg("port"), py::kw_only(), py::arg("timeout") = 5.0,
      "Connects to a TCP-serial bridge (ser2net) within ``timeout`` seconds.");
  module.def(
      "pty",
      []() {
        Transport transport;
        transport.io = io_thread();
        boost::system::error_code error;
        auto pty = transports::PtyStream::open(transport.io->executor(), error);
        if (error) raise_error(error);
        transport.path = pty->slave_path();
        transport.stream = pty;
        return transport;
      },
      "A new pseudo-terminal: the client holds the master, another program opens ``path`` like a serial port.");

  parent.def("_set_firmware_dir", &set_firmware_dir, py::arg("path"));

  py::class_<BoardClock>(parent, "VirtualUnoClock", R"doc(A virtual board's simulated time, for a client's ``clock=`` argument (``board.clock``).

A client on it measures its deadlines (attempt windows, call budgets, pings) in the board's seconds, the
clock the firmware's own timeouts run on: a board paced in real time falls behind the wall clock on a
loaded machine, and a host window on the wall clock can then end before the device has had its time.
Closing the board closes the clients on its clock (its time stops with it).)doc")
      .def_property_readonly("board", [](const BoardClock& c) { return c.board; }, "The board whose time it is.")
      .def("__repr__", [](const BoardClock& c) {
        return "<tether.VirtualUnoClock of " + (c.board->board ? c.board->board->options().name : std::string("?")) +
               (c.board->closed.load() ? " (closed)>" : ">");
      });

  py::class_<VirtualBoard, std::shared_ptr<VirtualBoard>>(parent, "VirtualUno", R"doc(A simulated Arduino Uno (libsimavr) running a firmware image.

``VirtualUno('romi-test')`` looks the image up in the firmware folder ($TETHER_FIRMWARE_DIR, the installed
images, or the build's); a path is used as is. The board runs on its own thread from construction until
``close()`` (or the end of a ``with`` block), its UART on a pty: ``port`` is ready once the firmware listens.
``fast=True`` runs as fast as the host can instead of in real time. ``start=False`` makes a board that runs
only when ``run_for`` advances it (slower than real time, frozen, in steps: the caller paces it); it has no
pty, clients open on the board itself.

Open clients on the board itself, ``tether.romi.Client(board)``: the client uses the board's UART (no boot
wait) and runs its deadlines on the board's simulated time (``board.clock``), so a loaded machine that slows
the simulation cannot time a call out while the device has not had its time.)doc")
      .def(py::init([](const std::string& image, bool fast, std::optional<std::uint64_t> seed, bool start) {
             transports::VirtualUnoOptions options;
             options.firmware = firmware_path(image);
             options.pacing = fast ? transports::Pacing::fast : transports::Pacing::real_time;
             if (seed) options.seed = *seed;
             std::error_code error;
             std::string message;
             auto wrapper = std::make_shared<VirtualBoard>();
             wrapper->started = start;
             {
               py::gil_scoped_release release;
               std::shared_ptr<transports::VirtualUno> board = transports::VirtualUno::create(options, error, &message);
               wrapper->board = board;
               // Ready means the firmware listens: bytes written before it enables its receiver are lost.
               if (board && start) {
                 wrapper->port = board->open_pty(error);
                 if (!error) {
                   board->start();
                   const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(5);
                   while (!board->uart().rx_enabled && std::chrono::steady_clock::now() < limit) {
                     std::this_thread::sleep_for(std::chrono::milliseconds(1));
                   }
                   if (!board->uart().rx_enabled) message = "the firmware did not enable its UART within 5 s";
                 }
               } else if (board) {
                 while (!board->uart().rx_enabled && board->simulated_time() < std::chrono::seconds(5)) {
                   board->run_for(std::chrono::milliseconds(1));
                 }
                 if (!board->uart().rx_enabled) {
                   message = "the firmware did not enable its UART within 5 s of simulated time";
                 }
               }
               if (board) wrapper->clock = transports::VirtualUnoClock::create(board);
             }
             if (!wrapper->board || error) raise_std_error(error, message.empty() ? error.message() : message);
             if (!message.empty()) throw py::value_error(options.firmware.string() + ": " + message);
             if (start) register_board_port(wrapper);
             return wrapper;
           }),
           py::arg("image"), py::kw_only(), py::arg("fast") = false, py::arg("seed") = py::none(),
           py::arg("start") = true)
      .def_property_readonly("port", [](const VirtualBoard& b) {
             if (!b.started) {
               throw py::value_error("a board made with start=False has no pty: open clients on the board itself "
                                     "(tether.romi.Client(board))");
             }
             return b.port;
           },
           "The pty's path: open it like a serial port (``boot_wait=0``), or from another program.")
      .def_property_readonly("clock", [](const std::shared_ptr<VirtualBoard>& b) {
             b->get();
             return BoardClock{b};
           },
           "The board's simulated time as a client's clock: ``tether.romi.Client(board.port, boot_wait=0, "
           "clock=board.clock)`` (what ``Client(board)`` does).")
      .def_property_readonly("simulated_time", [](VirtualBoard& b) {
             return std::chrono::duration<double>(b.get().simulated_time()).count();
           },
           "Seconds the board has run since its creation (its clock; at most 1 ms old while it runs).")
      .def(
          "run_for",
          [](VirtualBoard& b, double seconds) {
            if (b.started) throw py::value_error("run_for advances a board made with start=False; this one runs on its own");
            if (!(seconds >= 0.0) || seconds > 3600.0) throw py::value_error("seconds must be 0..3600");
            const std::shared_ptr<transports::VirtualUno> board = b.board;  // close() may come meanwhile
            b.get();
            py::gil_scoped_release release;
            board->run_for(std::chrono::duration_cast<transports::SimDuration>(std::chrono::duration<double>(seconds)));
          },
          py::arg("seconds"),
          "Advances a ``start=False`` board by ``seconds`` of simulated time on the calling thread, as fast as it "
          "can (the GIL released); its clients' deadlines move with it. One caller at a time.")
      .def(
          "stats",
          [](VirtualBoard& b) {
            const transports::VirtualUnoStats stats = b.get().stats();
            return py::module_::import("types").attr("SimpleNamespace")(
                "boots"_a = stats.boots, "rx_bytes"_a = stats.rx_bytes, "rx_bytes_lost"_a = stats.rx_bytes_lost,
                "tx_bytes"_a = stats.tx_bytes, "host_bytes_discarded"_a = stats.host_bytes_discarded,
                "awake_cycles"_a = stats.awake_cycles);
          },
          "The board's counters: ``boots``, ``rx_bytes`` (entered its UART), ``rx_bytes_lost``, ``tx_bytes`` (the "
          "firmware wrote), ``host_bytes_discarded``, ``awake_cycles`` (CPU cycles not asleep).")
      .def(
          "pin",
          [](VirtualBoard& b, int pin) {
            if (pin < 0 || pin > 19) throw py::value_error("Arduino pins are 0..19 (A0..A5 = 14..19)");
            const transports::PinState state = b.get().pin(pin);
            return py::module_::import("types").attr("SimpleNamespace")("level"_a = state.level, "output"_a = state.output);
          },
          py::arg("pin"), "A pin's level and direction, as a voltmeter sees it (``level``, ``output``).")
      .def(
          "set_analog_input",
          [](VirtualBoard& b, int channel, double volts) {
            if (channel < 0 || channel > 7) throw py::value_error("ADC channels are 0..7");
            if (!(volts >= 0.0 && volts <= 5.0)) throw py::value_error("volts must be 0..5");
            b.get().set_analog_input(channel, volts);
          },
          py::arg("channel"), py::arg("volts"), "Drives an analog input (A0 = channel 0) with ``volts``.")
      .def("close", &VirtualBoard::close,
           "Stops the board and closes its pty and the clients on its clock (their calls raise ClosedError). "
           "Idempotent.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](VirtualBoard& b, py::args) { b.close(); });
}

}  // namespace tether::python
