// Shared pieces of the binding: the io thread every client runs on, Python callables called from that
// thread, the error translation, and the registration functions of each part (one .cpp each).
#pragma once

#include <pybind11/pybind11.h>

#include <boost/asio/any_io_executor.hpp>
#include <boost/system/error_code.hpp>

#include <chrono>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <tuple>
#include <utility>
#include <vector>

#include "tether/client/client_skeleton.hpp"
#include "tether/devices/config.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::python {

namespace py = pybind11;
using namespace pybind11::literals;  // "name"_a keyword arguments

/// The io_context thread of the package: one for every client, started with the first and stopped when
/// the last object using it is gone (every wrapper keeps a reference).
std::shared_ptr<transports::IoThread> io_thread();

/// Fork safety. A child made by fork() gets the parent's objects but none of its threads: the io thread,
/// the virtual boards' simulation threads. `after_fork_in_child` (registered with `os.register_at_fork`)
/// forgets the parent's io thread, so the child's new clients get their own, and starts a new process
/// generation: objects made before it (`ProcessGeneration::inherited`) raise ClosedError when used and are
/// never torn down in the child (their threads are the parent's; joining them would hang).
void after_fork_in_child();

/// The generation an object was made in (see `after_fork_in_child`).
class ProcessGeneration {
 public:
  ProcessGeneration();
  /// True in a child forked after the object was made.
  bool inherited() const;

 private:
  unsigned generation_;
};

/// Keeps `object` alive for good: what an inherited object holds in a forked child.
template <typename T>
void leak(std::shared_ptr<T>& object) {
  if (object) (void)new std::shared_ptr<T>(std::move(object));
}

/// Raises ClosedError for `what`, made before this process forked from its parent.
[[noreturn]] void raise_inherited(const char* what);

/// True once the interpreter is finalizing: callbacks from the io thread are then dropped (taking the GIL
/// would hang or crash).
bool interpreter_exiting();
/// Set by the package's atexit hook.
void set_interpreter_exiting();

/// A Python callable that the io thread may call and drop: calls take the GIL, and the last reference is
/// released under the GIL too. An exception raised by the callable is reported through
/// `sys.unraisablehook` (like an exception in a `__del__`) and never reaches the C++ client.
class PyCallback {
 public:
  PyCallback() = default;
  explicit PyCallback(py::object callable);
  /// Calls it with `args` (converted under the GIL); nothing when empty or the interpreter is exiting.
  template <typename... Args>
  void operator()(Args&&... args) const {
    if (!holder_ || interpreter_exiting()) return;
    py::gil_scoped_acquire gil;
    try {
      (*holder_)(std::forward<Args>(args)...);
    } catch (py::error_already_set& failure) {
      failure.discard_as_unraisable("tether callback");
    }
  }
  explicit operator bool() const { return static_cast<bool>(holder_); }

 private:
  std::shared_ptr<py::object> holder_;
};

/// One exception class a codec defines: its name and docstring.
struct ExceptionClass {
  const char* name = nullptr;  ///< e.g. "RomiError"; null: no such class
  const char* doc = "";        ///< its docstring: what `code` means
};

/// The exception classes of a codec's errors (`register_errors`).
struct ErrorFamily {
  /// The codec's `error_category::name()`: errors of it (and of `<category>.<sub>`) raise these classes.
  const char* category = nullptr;
  ExceptionClass base;      ///< a `tether.TetherError` (`code`, `message`): every other error of the category
  ExceptionClass timeout;   ///< `base` and a builtin `TimeoutError`: errors equal to `errc::timed_out`
  ExceptionClass rejected;  ///< optional, `base` and a `ValueError`: the codes in `rejected_codes`
  std::vector<int> rejected_codes;  ///< what was refused before anything was written
  std::vector<ExceptionClass> more;  ///< further subclasses of `base`, which the codec's binding raises itself
};

/// Makes a codec's exception classes in its submodule (`tether.romi.RomiError`, ...; the package exports them
/// too) and has `raise_error` raise them for its error category. A codec plugin's `register_python` calls
/// it once, after making its submodule.
void register_errors(py::module_& submodule, const ErrorFamily& family);

/// Raises the Python exception for a failed operation: a codec's classes for its error category
/// (`register_errors`: `tether.RomiError`, ...), `TransportError`, `ConfigError` with the code and message
/// (their `...TimeoutError` subclass, also a builtin `TimeoutError`, for timeouts); `ClosedError` for an
/// aborted operation (closed client);
/// OS errors as `OSError` subclasses (`FileNotFoundError` for a missing port). `message` overrides the
/// error_code's text (a Romi response's message); `path` names the file of an OS error.
[[noreturn]] void raise_error(const boost::system::error_code& error, const std::string& message = {},
                              const std::string& path = {});
/// The exception object `raise_error` would raise (for futures). Needs the GIL.
py::object error_object(const boost::system::error_code& error, const std::string& message = {},
                        const std::string& path = {});
/// Raises `tether.ClosedError` for an operation on a closed client or rover.
[[noreturn]] void raise_closed(const char* what);

struct VirtualBoard;

/// A byte stream as Python sees it (`tether.transports.Transport`): what a client is opened on.
struct Transport {
  std::shared_ptr<transports::IoThread> io;  ///< Runs the stream.
  std::shared_ptr<transports::ByteStream> stream;  ///< Null once a client took it.
  std::string path;  ///< A pty's slave path, a serial port's path; empty otherwise.
  std::shared_ptr<void> keep_alive;  ///< A virtual board the stream belongs to.
  /// The virtual board a client was opened on (`Client(board)`): its clock is the client's by default.
  std::shared_ptr<VirtualBoard> board;
  /// A serial port's stream (kept after a client took it): its link events and outage counters.
  std::shared_ptr<transports::SerialPortStream> port;
};

/// Serial port options from keyword arguments (`baud`, `boot_wait` seconds, `ready_banner`, `reconnect`,
/// `max_attempts`, `boot`), and the codec's boot signature (a client's; none for `tether.transports.serial`).
struct SerialArguments {
  unsigned baud = 115200;
  double boot_wait = 2.0;
  std::string ready_banner;
  bool reconnect = true;
  unsigned max_attempts = 0;
  /// `"detect"`, `"fixed"`, `"none"`; unset: detect where `signature` is usable, else fixed.
  std::optional<std::string> boot = std::nullopt;
  transports::BootSignature signature = {};
};

/// A link event as a Python dict: `{"kind": "down"|"up"|"gave_up", "reason", "path", "down_ms", "attempts"}`.
py::dict link_event_dict(const transports::LinkEvent& event);
/// Link counters as a Python dict: `{"disconnects", "reconnects", "time_down_ms", "up", "gave_up"}`.
py::dict link_counters_dict(const transports::LinkCounters& counters);
/// The stream a client opens on: a `Transport` (taken: one client per stream), a port path (opened as a
/// serial port with `serial`; `Transport::board` set when it is an in-process board's pty, `board_at_port`)
/// or a `tether.VirtualUno` (its pty without a boot wait, or, for a board made with `start=False`, its UART
/// directly; `Transport::board` set). Raises TypeError for anything else.
Transport take_stream(py::handle port_or_transport, const SerialArguments& serial);
/// Opens a serial port (GIL released while opening and waiting for the boot). Raises ValueError for a
/// baud of 0 or a path with a NUL.
Transport open_serial(const std::string& path, const SerialArguments& serial);

/// A client's `record=` (None: nothing): a capture file (str or os.PathLike) or a dict like a configuration's
/// `record` (`file`, `max_bytes`, `max_seconds`, `files`, `overwrite`). Wraps `transport`'s stream so its link
/// is recorded as a device of codec `codec` (its capture framing) named after the port; the file closes
/// with the client. Raises FileExistsError (an existing file without `overwrite`), OSError, ValueError or
/// TypeError.
/// `codec_options`: the device's options as a configuration gives them (what the interface's description says of
/// the codec: an Elcano ring's generation), or none.
void record_transport(Transport& transport, const py::object& record, std::string_view codec,
                      devices::CodecOptions codec_options = {});

/// Resolves a firmware image: a path (contains '/') as is, a name in the package's firmware folder.
/// Raises ValueError for a name with a NUL in it.
std::string firmware_path(const std::string& name);
/// Raises ValueError when `path` (a file or port the caller named as `what`) holds a NUL: the OS would read it
/// cut short there, and open another file than the one named (Python's own open() refuses it too).
void check_path(const std::string& path, const char* what);

/// Runs an asynchronous operation for asyncio: returns a future of the running loop that `start` completes
/// (from the io thread, through `loop.call_soon_threadsafe`). `start` gets a callable taking
/// (exception or None, result) and the signal its handler is bound to (`client::bind_cancellation`):
/// cancelling the future (`task.cancel()`) emits it, so the wire operation is cancelled too (a queued call
/// never starts, the one in flight stops waiting) instead of holding the device until its timeout.
py::object asyncio_future(const std::function<void(PyCallback settle, client::CancellationSignal cancel)>& start);

/// True on a thread running `executor`'s io_context (false when that cannot be told).
bool runs_in_this_thread(const boost::asio::any_io_executor& executor);

/// Runs an asynchronous operation to its completion for a blocking call, interruptibly: the GIL is released
/// while it waits, and every 100 ms the wait runs Python's signal handlers (as `log_lines()` does), so
/// Ctrl-C is acted on at once. Then the operation is cancelled (`cancel.emit()`: queued, it never starts;
/// in flight, the client stops waiting for it) and the handler's exception (KeyboardInterrupt) raised; its
/// completion, when it comes, lands in state this call no longer looks at. `start(cancel, handler)` starts
/// the operation with `handler` bound to `cancel` (`client::bind_cancellation`); returns the
/// completion's arguments.
/// Called on a thread that runs `executor` (an event handler calling a blocking method), it raises
/// `TransportError::would_deadlock` instead: the completion could never run.
template <typename... Results, typename Start>
std::tuple<Results...> wait_interruptibly(const boost::asio::any_io_executor& executor, Start&& start) {
  if (runs_in_this_thread(executor)) raise_error(make_error_code(transports::TransportError::would_deadlock));
  struct Slot {
    std::mutex mutex;
    std::condition_variable completed;
    std::optional<std::tuple<Results...>> results;
  };
  const auto slot = std::make_shared<Slot>();
  client::CancellationSignal cancel;
  {
    py::gil_scoped_release release;
    start(cancel, [slot](Results... results) {
      {
        const std::lock_guard lock(slot->mutex);
        slot->results.emplace(std::move(results)...);
      }
      slot->completed.notify_all();
    });
  }
  for (;;) {
    {
      py::gil_scoped_release release;
      std::unique_lock lock(slot->mutex);
      if (slot->completed.wait_for(lock, std::chrono::milliseconds(100), [&] { return slot->results.has_value(); })) {
        return std::move(*slot->results);
      }
    }
    if (PyErr_CheckSignals() != 0) {
      cancel.emit();
      throw py::error_already_set();
    }
  }
}

void register_transports(py::module_& module);
void register_devices(py::module_& module);
/// Every codec plugin's part of the module (generated from plugin_python.cpp.in), after the two above.
void register_plugins(py::module_& module);

}  // namespace tether::python
