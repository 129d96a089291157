// Shared pieces of the binding: the io thread every client runs on, Python callables called from that
// thread, the error translation, and the registration functions of each part (one .cpp each).
#pragma once

#include <pybind11/pybind11.h>

#include <boost/asio/any_io_executor.hpp>
#include <boost/system/error_code.hpp>

#include <memory>
#include <optional>
#include <string>
#include <utility>

#include "tether/transports/byte_stream.hpp"
#include "tether/transports/client_skeleton.hpp"
#include "tether/transports/io_thread.hpp"

namespace tether::python {

namespace py = pybind11;
using namespace pybind11::literals;  // "name"_a keyword arguments

/// The io_context thread of the package: one for every client, started with the first and stopped when
/// the last object using it is gone (every wrapper keeps a reference).
std::shared_ptr<transports::IoThread> io_thread();

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

/// Raises the Python exception for a failed operation: `tether.RomiError`, `ProxyError`, `ElcanoError`,
/// `TransportError`, `ConfigError` with the codec's code and message (their `...TimeoutError` subclass,
/// also a builtin `TimeoutError`, for timeouts); `ClosedError` for an aborted operation (closed client);
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
};

/// Serial port options from keyword arguments (`baud`, `boot_wait` seconds, `ready_banner`).
struct SerialArguments {
  unsigned baud = 115200;
  double boot_wait = 2.0;
  std::string ready_banner;
};
/// The stream a client opens on: a `Transport` (taken: one client per stream), a port path (opened as a
/// serial port with `serial`; `Transport::board` set when it is an in-process board's pty, `board_at_port`)
/// or a `tether.VirtualUno` (its pty without a boot wait, or, for a board made with `start=False`, its UART
/// directly; `Transport::board` set). Raises TypeError for anything else.
Transport take_stream(py::handle port_or_transport, const SerialArguments& serial);
/// Opens a serial port (GIL released while opening and waiting for the boot).
Transport open_serial(const std::string& path, const SerialArguments& serial);

/// Resolves a firmware image: a path (contains '/') as is, a name in the package's firmware folder.
std::string firmware_path(const std::string& name);

/// Runs an asynchronous operation for asyncio: returns a future of the running loop that `start` completes
/// (from the io thread, through `loop.call_soon_threadsafe`). `start` gets a callable taking
/// (exception or None, result) and the signal its handler is bound to (`transports::bind_cancellation`):
/// cancelling the future (`task.cancel()`) emits it, so the wire operation is cancelled too (a queued call
/// never starts, the one in flight stops waiting) instead of holding the device until its timeout.
py::object asyncio_future(const std::function<void(PyCallback settle, transports::CancellationSignal cancel)>& start);

void register_transports(py::module_& module);
void register_romi(py::module_& module);
void register_proxy(py::module_& module);
void register_elcano(py::module_& module);
void register_devices(py::module_& module);

}  // namespace tether::python
