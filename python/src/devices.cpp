// tether.open_rover: a rover's JSON configuration opened into typed clients (devices::Rover).
#include <pybind11/stl.h>

#include <boost/asio/bind_executor.hpp>
#include <boost/asio/system_executor.hpp>

#include <exception>
#include <stdexcept>

#include "binding.hpp"
#include "rover_holder.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"

namespace tether::python {

namespace {

[[noreturn]] void raise_config(const devices::ConfigError& failure) {
  py::object exception =
      py::module_::import("tether._errors").attr("ConfigError")(failure.code().value(), std::string(failure.what()));
  exception.attr("path") = failure.path();
  PyErr_SetObject(reinterpret_cast<PyObject*>(Py_TYPE(exception.ptr())), exception.ptr());
  throw py::error_already_set();
}

}  // namespace

void register_devices(py::module_& parent) {
  py::class_<RoverHolder, std::shared_ptr<RoverHolder>>(parent, "Rover", R"doc(The opened devices of a rover (devices::Rover).

Each codec adds its getter: ``romi(name)``, ``proxy(name)``, ``elcano(name)`` return the device's client
(KeyError for an unknown name or another codec); clients stay usable until the rover is closed, then raise
ClosedError.)doc")
      .def_property_readonly("devices", [](RoverHolder& h) {
             py::list names;
             for (const auto& device : h.get().devices()) {
               names.append(py::module_::import("types").attr("SimpleNamespace")(
                   "name"_a = device.name, "codec"_a = std::string(devices::to_string(device.codec)),
                   "transport"_a = device.transport));
             }
             return names;
           }, "Every device (name, codec, transport), in the configuration's order.")
      .def(
          "link_counters",
          [](RoverHolder& h, const std::string& name) -> py::object {
            const devices::RoverDevice* device = h.get().find(name);
            if (device == nullptr) throw py::key_error("no device " + name);
            if (!device->port) return py::none();
            return link_counters_dict(device->port->link_counters());
          },
          py::arg("name"),
          "Device ``name``'s serial port outage counters: {'disconnects', 'reconnects', 'time_down_ms', 'up', "
          "'gave_up'}; None for a device that is not on a serial port. KeyError for an unknown name.")
      .def(
          "on_link_event",
          [](RoverHolder& h, const std::string& name, py::object callback) {
            const devices::RoverDevice* device = h.get().find(name);
            if (device == nullptr) throw py::key_error("no device " + name);
            if (!device->port) throw py::value_error("device " + name + " is not on a serial port");
            PyCallback call(std::move(callback));
            device->port->add_link_handler([call](const transports::LinkEvent& event) {
              if (!call || interpreter_exiting()) return;
              py::gil_scoped_acquire gil;
              call(link_event_dict(event));
            });
          },
          py::arg("name"), py::arg("callback"),
          "Calls ``callback(event)`` on the I/O thread for each change of device ``name``'s serial link "
          "(see tether.transports.Transport.on_link_event). ValueError for a device not on a serial port.")
      .def("close", [](RoverHolder& h) {
        if (!h.rover || h.generation.inherited()) return;
        py::gil_scoped_release release;
        h.rover->close();
      }, "Closes every client and stops the virtual boards. Idempotent.")
      .def_property_readonly("is_open", [](const RoverHolder& h) { return h.rover && !h.generation.inherited() && h.rover->is_open(); })
      .def("__enter__", [](py::object self) { return self; })
      .def("__exit__", [](RoverHolder& h, py::args) {
        if (!h.rover || h.generation.inherited()) return;
        py::gil_scoped_release release;
        h.rover->close();
      });

  parent.def(
      "_open_rover",
      [](const std::string& path, const std::string& firmware_dir) {
        check_path(path, "configuration");
        check_path(firmware_dir, "firmware_dir");
        devices::ParseOptions where;
        where.firmware_dir = firmware_dir;
        auto holder = std::make_shared<RoverHolder>();
        holder->io = io_thread();
        try {
          devices::RoverConfig config = devices::load_config(path, where);
          // Interruptible: Ctrl-C raises at once. The opening cannot be stopped half-way: it goes on on its
          // own thread, where the outcome also completes (the system executor), so a rover nobody waits
          // for any more is closed there, never on the I/O thread its clients need.
          auto [failure, rover] = wait_interruptibly<std::exception_ptr, devices::Rover>(
              holder->io->executor(), [&](client::CancellationSignal, auto handler) {
                devices::async_open_rover(config, holder->io->executor(), devices::OpenOptions(),
                                          boost::asio::bind_executor(boost::asio::system_executor(), std::move(handler)));
              });
          if (failure) std::rethrow_exception(failure);
          holder->rover = std::make_shared<devices::Rover>(std::move(rover));
        } catch (const devices::ConfigError& failure) {
          raise_config(failure);
        }
        return holder;
      },
      py::arg("path"), py::arg("firmware_dir"));
}

}  // namespace tether::python
