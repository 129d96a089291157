// The Python `Rover` (devices.cpp) as the codecs' bindings see it: each adds its typed getter to the class
// (`rover_class(module).def("romi", ...)`) and hands out its client wrapper with `client_of`.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>

#include "binding.hpp"
#include "tether/devices/rover.hpp"

namespace tether::python {

/// A rover and the io thread running it; clients handed out keep it alive.
struct RoverHolder {
  std::shared_ptr<transports::IoThread> io;
  std::shared_ptr<devices::Rover> rover;
  ProcessGeneration generation;
  ~RoverHolder() {
    if (generation.inherited()) {  // the parent's threads run it: keep it as it is
      leak(rover);
      leak(io);
      return;
    }
    py::gil_scoped_release release;
    rover.reset();
    io.reset();
  }
  devices::Rover& get() {
    if (generation.inherited()) raise_inherited("the rover");
    if (!rover || !rover->is_open()) raise_closed("the rover");
    return *rover;
  }
};

/// `tether.Rover`, registered by `register_devices` (before the codecs' bindings), to add methods to.
inline py::class_<RoverHolder, std::shared_ptr<RoverHolder>> rover_class(py::module_& module) {
  return py::reinterpret_borrow<py::class_<RoverHolder, std::shared_ptr<RoverHolder>>>(module.attr("Rover"));
}

/// The client wrapper `Wrapper` of the device `name`, its client from `get(rover, name)` (a
/// `std::out_of_range` from it becomes a KeyError); it keeps the rover and its io thread alive.
template <typename Wrapper, typename Get>
std::shared_ptr<Wrapper> client_of(const std::shared_ptr<RoverHolder>& holder, const std::string& name, Get get) {
  auto wrapper = std::make_shared<Wrapper>();
  try {
    wrapper->client = get(holder->get(), name);
  } catch (const std::out_of_range& failure) {
    throw py::key_error(failure.what());
  }
  wrapper->io = holder->io;
  wrapper->owner = holder;
  return wrapper;
}

}  // namespace tether::python
