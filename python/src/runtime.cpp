// The io thread, GIL-safe callables, opening streams for clients, firmware lookup, asyncio futures.
#include <atomic>
#include <chrono>
#include <mutex>
#include <new>

#include <cerrno>
#include <filesystem>

#include "binding.hpp"
#include "tether/devices/codecs.hpp"
#include "tether/devices/rover.hpp"
#include "tether/transports/recording.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "virtual_board.hpp"

namespace tether::python {

namespace {
std::atomic<bool> exiting{false};
std::mutex io_mutex;
std::weak_ptr<transports::IoThread> shared_io;
std::string firmware_folder;  // set by tether/__init__.py (_set_firmware_dir)
std::mutex firmware_mutex;
}  // namespace

std::shared_ptr<transports::IoThread> io_thread() {
  std::lock_guard lock(io_mutex);
  auto io = shared_io.lock();
  if (!io) {
    io = std::make_shared<transports::IoThread>();
    shared_io = io;
  }
  return io;
}

bool runs_in_this_thread(const boost::asio::any_io_executor& executor) {
  const auto* context = executor.target<boost::asio::io_context::executor_type>();
  return context != nullptr && context->running_in_this_thread();
}

namespace {
std::atomic<unsigned> process_generation{0};
}  // namespace

void after_fork_in_child() {
  process_generation.fetch_add(1, std::memory_order_acq_rel);
  // Another thread may have held these at the fork; nobody holds them in the child.
  new (&io_mutex) std::mutex;
  new (&firmware_mutex) std::mutex;
  // The parent's io thread did not come along: never stop or join it here. The wrappers holding it leak it
  // (inherited); this reference goes too, so the next client starts a thread of its own.
  std::shared_ptr<transports::IoThread> parents = shared_io.lock();
  leak(parents);
  shared_io.reset();
}

ProcessGeneration::ProcessGeneration() : generation_(process_generation.load(std::memory_order_acquire)) {}

bool ProcessGeneration::inherited() const {
  return generation_ != process_generation.load(std::memory_order_acquire);
}

bool interpreter_exiting() { return exiting.load(std::memory_order_acquire); }
void set_interpreter_exiting() { exiting.store(true, std::memory_order_release); }

PyCallback::PyCallback(py::object callable) {
  if (callable.is_none()) return;
  if (!PyCallable_Check(callable.ptr())) throw py::type_error("expected a callable or None");
  holder_ = std::shared_ptr<py::object>(new py::object(std::move(callable)), [](py::object* object) {
    if (interpreter_exiting() || !Py_IsInitialized()) {
      (void)object->release();  // the interpreter is going away: leaking is the only safe option
      delete object;
      return;
    }
    py::gil_scoped_acquire gil;
    delete object;
  });
}

void set_firmware_dir(const std::string& dir) {
  std::lock_guard lock(firmware_mutex);
  firmware_folder = dir;
}

void check_path(const std::string& path, const char* what) {
  if (path.find('\0') != std::string::npos) throw py::value_error(std::string(what) + ": embedded null character");
}

std::string firmware_path(const std::string& name) {
  check_path(name, "image");
  if (name.find('/') != std::string::npos) return name;
  std::lock_guard lock(firmware_mutex);
  const bool has_suffix = name.size() > 4 && name.ends_with(".elf");
  return firmware_folder + "/" + (has_suffix ? name : name + ".elf");
}

Transport open_serial(const std::string& path, const SerialArguments& serial) {
  check_path(path, "port");
  if (serial.baud == 0) throw py::value_error("baud must be a positive number of bits per second");
  if (!(serial.boot_wait >= 0.0) || serial.boot_wait > 60.0) throw py::value_error("boot_wait must be 0..60 s");
  transports::SerialOptions options;
  options.baud = serial.baud;
  options.boot_wait = std::chrono::milliseconds(static_cast<long>(serial.boot_wait * 1000.0));
  options.boot_signature = serial.signature;
  options.boot = serial.signature.usable() ? transports::BootMode::detect : transports::BootMode::fixed;
  if (serial.boot) {
    const auto mode = transports::parse_boot_mode(*serial.boot);
    if (!mode) throw py::value_error("boot must be 'detect', 'fixed' or 'none', got '" + *serial.boot + "'");
    if (*mode == transports::BootMode::detect && !serial.signature.usable()) {
      throw py::value_error("boot='detect' needs a codec that knows its firmware's boot (a romi, proxy or rpc client)");
    }
    options.boot = *mode;
  }
  options.ready_banner = serial.ready_banner;
  options.reconnect.enabled = serial.reconnect;
  options.reconnect.max_attempts = serial.max_attempts;
  Transport transport;
  transport.io = io_thread();
  transport.path = path;
  // Interruptible: Ctrl-C during the boot wait raises at once; the port, once opened, is closed again.
  auto [error, stream] = wait_interruptibly<boost::system::error_code, std::shared_ptr<transports::SerialPortStream>>(
      transport.io->executor(), [&](client::CancellationSignal, auto handler) {
        transports::SerialPortStream::async_open(transport.io->executor(), path, options, std::move(handler));
      });
  if (error) raise_error(error, {}, path);
  transport.port = stream;
  transport.stream = std::move(stream);
  return transport;
}

namespace {

std::string path_of(const py::handle& value, const char* what) {
  if (py::isinstance<py::str>(value) || py::isinstance(value, py::module_::import("os").attr("PathLike"))) {
    const std::string path = py::str(py::module_::import("os").attr("fspath")(value)).cast<std::string>();
    check_path(path, what);
    if (path.empty()) throw py::value_error(std::string(what) + ": an empty file name");
    return path;
  }
  throw py::type_error(std::string(what) + ": expected a file name (str or os.PathLike), got " +
                       py::str(py::type::of(value).attr("__name__")).cast<std::string>());
}

std::uint64_t whole_number(const py::handle& value, const char* what, std::uint64_t min, std::uint64_t max) {
  if (!py::isinstance<py::int_>(value) || py::isinstance<py::bool_>(value)) {
    throw py::type_error(std::string("record: ") + what + " must be an int");
  }
  const long long number = value.cast<long long>();
  if (number < 0 || static_cast<std::uint64_t>(number) < min || static_cast<std::uint64_t>(number) > max) {
    throw py::value_error(std::string("record: ") + what + " must be " + std::to_string(min) + ".." + std::to_string(max));
  }
  return static_cast<std::uint64_t>(number);
}

transports::RecordOptions record_options(const py::object& record) {
  transports::RecordOptions options;
  if (!py::isinstance<py::dict>(record)) {
    options.file = path_of(record, "record");
    return options;
  }
  const py::dict given = record.cast<py::dict>();
  for (const auto& [key, value] : given) {
    const std::string name = py::str(key).cast<std::string>();
    if (name == "file") {
      options.file = path_of(value, "record file");
    } else if (name == "overwrite") {
      if (!py::isinstance<py::bool_>(value)) throw py::type_error("record: overwrite must be a bool");
      options.overwrite = value.cast<bool>();
    } else if (name == "max_bytes") {
      options.max_file_bytes = whole_number(value, "max_bytes", 4096, std::uint64_t{1} << 50);
    } else if (name == "max_seconds") {
      options.max_file_duration = std::chrono::seconds(whole_number(value, "max_seconds", 1, 366u * 24 * 3600));
    } else if (name == "files") {
      options.ring_files = static_cast<unsigned>(whole_number(value, "files", 2, 1000));
    } else {
      throw py::value_error("record: unknown key '" + name + "' (file, max_bytes, max_seconds, files, overwrite)");
    }
  }
  if (options.file.empty()) throw py::value_error("record: missing key 'file'");
  return options;
}

}  // namespace

void record_transport(Transport& transport, const py::object& record, std::string_view codec,
                      devices::CodecOptions codec_options) {
  if (record.is_none()) return;
  const transports::RecordOptions options = record_options(record);
  const devices::CodecRow* row = devices::find_codec(codec);
  if (row == nullptr) throw py::value_error("record: unknown codec " + std::string(codec));
  boost::system::error_code error;
  std::string message;
  auto recorder = transports::CaptureRecorder::open(options, error, message);
  if (!recorder) {
    if (transport.stream) transport.stream->close();
    if (error == boost::system::errc::file_exists) {
      PyErr_SetString(PyExc_FileExistsError, message.c_str());
      throw py::error_already_set();
    }
    if (error.category() == boost::system::system_category()) {
      PyErr_SetObject(PyExc_OSError, py::make_tuple(error.value(), message).ptr());
      throw py::error_already_set();
    }
    throw py::value_error(message);
  }
  devices::DeviceConfig device;
  device.name = transport.path.empty() ? std::string(row->name) : transport.path;
  device.codec = row->codec;
  device.options = std::move(codec_options);
  if (transport.board && transport.path.empty()) {
    device.transport = devices::VirtualTransport{};
  } else {
    devices::SerialTransport serial;
    serial.path = transport.path;
    if (transport.port) serial.options.baud = transport.port->options().baud;
    device.transport = serial;
  }
  auto recording = devices::record_stream(device, transport.stream, std::move(recorder));
  recording->close_recorder_on_close(true);
  transport.stream = std::move(recording);
}

py::dict link_event_dict(const transports::LinkEvent& event) {
  const char* kind = event.kind == transports::LinkEvent::Kind::down ? "down"
                     : event.kind == transports::LinkEvent::Kind::up ? "up"
                                                                      : "gave_up";
  return py::dict("kind"_a = kind, "reason"_a = event.reason, "path"_a = event.path,
                  "down_ms"_a = event.down_for.count(), "attempts"_a = event.attempts,
                  "ready_after_ms"_a = event.boot.ready_after.count());
}

py::dict link_counters_dict(const transports::LinkCounters& counters) {
  return py::dict("disconnects"_a = counters.disconnects, "reconnects"_a = counters.reconnects,
                  "time_down_ms"_a = counters.time_down.count(), "up"_a = counters.up, "gave_up"_a = counters.gave_up,
                  "ready_after_ms"_a = counters.last_boot.ready_after.count(),
                  "boot"_a = transports::to_string(counters.last_boot.outcome));
}

namespace {

// A port opened by its path; when the path is an in-process board's pty, the client is that board's.
Transport open_port(const std::string& path, const SerialArguments& serial) {
  std::shared_ptr<VirtualBoard> board = board_at_port(path);
  Transport transport = open_serial(path, serial);
  if (board) {
    transport.keep_alive = board;
    transport.board = std::move(board);
  }
  return transport;
}

}  // namespace

Transport take_stream(py::handle port_or_transport, const SerialArguments& serial) {
  if (py::isinstance<py::str>(port_or_transport)) return open_port(port_or_transport.cast<std::string>(), serial);
  if (py::isinstance(port_or_transport, py::module_::import("os").attr("PathLike"))) {
    return open_port(py::str(py::module_::import("os").attr("fspath")(port_or_transport)).cast<std::string>(),
                     serial);
  }
  if (py::isinstance<Transport>(port_or_transport)) {
    auto& given = port_or_transport.cast<Transport&>();
    if (!given.stream) throw py::value_error("this transport is already used by a client (one client per stream)");
    Transport taken = given;
    given.stream.reset();
    return taken;
  }
  if (py::isinstance<VirtualBoard>(port_or_transport)) {
    return board_transport(port_or_transport.cast<std::shared_ptr<VirtualBoard>>(), serial.baud);
  }
  throw py::type_error("expected a port path (str), a tether.transports.Transport or a tether.VirtualUno, got " +
                       py::str(py::type::of(port_or_transport).attr("__name__")).cast<std::string>());
}

py::object asyncio_future(const std::function<void(PyCallback settle, client::CancellationSignal cancel)>& start) {
  py::object loop = py::module_::import("asyncio").attr("get_running_loop")();  // RuntimeError outside a loop
  py::object future = loop.attr("create_future")();
  py::object settle = py::module_::import("tether._asyncio").attr("settle");
  py::object deliver = py::cpp_function([loop, future, settle](py::object failure, py::object value) {
    // A loop closed meanwhile (the future was cancelled and asyncio.run returned) has nobody to tell.
    if (loop.attr("is_closed")().cast<bool>()) return;
    try {
      loop.attr("call_soon_threadsafe")(settle, future, failure, value);
    } catch (py::error_already_set&) {
      if (!loop.attr("is_closed")().cast<bool>()) throw;  // closed between the check and the call
    }
  });
  client::CancellationSignal cancel;
  start(PyCallback(deliver), cancel);
  // Only a cancelled future cancels: a completed one has nothing pending (emit would then do nothing anyway).
  future.attr("add_done_callback")(py::cpp_function([cancel](py::object done) {
    if (done.attr("cancelled")().cast<bool>()) cancel.emit();
  }));
  return future;
}

}  // namespace tether::python
