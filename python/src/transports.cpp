// tether.transports (serial, TCP, pty streams) and tether.VirtualUno (a simulated Uno behind a pty).
#include <pybind11/stl.h>

#include <chrono>
#include <cmath>
#include <system_error>
#include <thread>

#include "binding.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether/transports/tcp_stream.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::python {

void set_firmware_dir(const std::string& dir);

namespace {

// A simulated board running on its own thread, its UART on a pty (`port`).
struct VirtualBoard {
  std::shared_ptr<transports::VirtualUno> board;
  std::string port;
  ~VirtualBoard() {
    py::gil_scoped_release release;
    board.reset();
  }
  transports::VirtualUno& get() {
    if (!board) raise_closed("the virtual board");
    return *board;
  }
};

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
  py::module_ module = parent.def_submodule("transports", "Byte streams a client opens on: serial, TCP, pty.");

  py::class_<Transport>(module, "Transport", "A byte stream for one client (``Client(transport)`` takes it).")
      .def_property_readonly("path", [](const Transport& t) { return t.path; },
                             "A serial port's path or a pty's slave path (open it with another program); else ''.")
      .def_property_readonly("description",
                             [](const Transport& t) { return t.stream ? t.stream->description() : std::string("(taken)"); },
                             "What the stream is, for messages.")
      .def_property_readonly("taken", [](const Transport& t) { return !t.stream; }, "True once a client uses it.");

  module.def(
      "serial",
      [](const std::string& path, unsigned baud, double boot_wait, const std::string& ready_banner) {
        return open_serial(path, SerialArguments{baud, boot_wait, ready_banner});
      },
      py::arg("path"), py::kw_only(), py::arg("baud") = 115200u, py::arg("boot_wait") = 2.0,
      py::arg("ready_banner") = "",
      "Opens a serial port (raw 8N1, exclusive). An Uno resets when its port opens: ``boot_wait`` seconds are "
      "waited and what it printed meanwhile is dropped, or, with ``ready_banner``, the port is ready once the "
      "firmware printed it. Raises FileNotFoundError/PermissionError/OSError, TransportError (bad baud, banner "
      "not seen: TransportTimeoutError).");
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

  py::class_<VirtualBoard, std::shared_ptr<VirtualBoard>>(parent, "VirtualUno", R"doc(A simulated Arduino Uno (libsimavr) running a firmware image, its UART on a pty.

``VirtualUno('romi-test')`` looks the image up in the firmware folder ($TETHER_FIRMWARE_DIR, the installed
images, or the build's); a path is used as is. The board runs on its own thread from construction until
``close()`` (or the end of a ``with`` block); ``port`` is ready once the firmware listens.
``fast=True`` runs as fast as the host can instead of in real time.)doc")
      .def(py::init([](const std::string& image, bool fast, std::optional<std::uint64_t> seed) {
             transports::VirtualUnoOptions options;
             options.firmware = firmware_path(image);
             options.pacing = fast ? transports::Pacing::fast : transports::Pacing::real_time;
             if (seed) options.seed = *seed;
             std::error_code error;
             std::string message;
             auto wrapper = std::make_shared<VirtualBoard>();
             {
               py::gil_scoped_release release;
               wrapper->board = transports::VirtualUno::create(options, error, &message);
               if (wrapper->board) {
                 wrapper->port = wrapper->board->open_pty(error);
                 if (!error) {
                   wrapper->board->start();
                   // Ready means the firmware listens: bytes written before it enables its receiver are lost.
                   const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(5);
                   while (!wrapper->board->uart().rx_enabled && std::chrono::steady_clock::now() < limit) {
                     std::this_thread::sleep_for(std::chrono::milliseconds(1));
                   }
                   if (!wrapper->board->uart().rx_enabled) message = "the firmware did not enable its UART within 5 s";
                 }
               }
             }
             if (!wrapper->board || error) raise_std_error(error, message.empty() ? error.message() : message);
             if (!message.empty()) throw py::value_error(options.firmware.string() + ": " + message);
             return wrapper;
           }),
           py::arg("image"), py::kw_only(), py::arg("fast") = false, py::arg("seed") = py::none())
      .def_property_readonly("port", [](const VirtualBoard& b) { return b.port; },
                             "The pty's path: open it like a serial port (``boot_wait=0``).")
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
      .def("close", [](VirtualBoard& b) {
        py::gil_scoped_release release;
        b.board.reset();
      }, "Stops the board and closes its pty. Idempotent.")
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](VirtualBoard& b, py::args) {
        py::gil_scoped_release release;
        b.board.reset();
      });
}

}  // namespace tether::python
