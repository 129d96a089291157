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

/// What a Python client object holds: its client, the io thread running it and whatever owns the stream (a
/// rover, a virtual board). Destroyed with the GIL released (closing a client drops its Python callbacks,
/// which take the GIL themselves); in a forked child kept as it is (the parent's threads run it).
template <typename Client>
struct ClientHolder {
  std::shared_ptr<transports::IoThread> io;  ///< The io thread.
  std::shared_ptr<Client> client;            ///< The client.
  std::shared_ptr<void> owner;               ///< What owns the client's stream.
  ProcessGeneration generation;              ///< Where it was made.

  ClientHolder() = default;
  ClientHolder(const ClientHolder&) = delete;
  ClientHolder& operator=(const ClientHolder&) = delete;
  ~ClientHolder() {
    if (generation.inherited()) {
      leak(client);
      leak(owner);
      leak(io);
      return;
    }
    py::gil_scoped_release release;
    client.reset();
    owner.reset();
    io.reset();
  }
  /// The client; raises ClosedError naming `what` after close() or in a forked child.
  Client& get(const char* what) {
    if (generation.inherited()) raise_inherited(what);
    if (!client || !client->is_open()) raise_closed(what);
    return *client;
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
