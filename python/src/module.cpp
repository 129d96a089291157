// The native module tether._tether; the package (tether/__init__.py) re-exports it.
#include "binding.hpp"
#include "tether/devices/virtual_boards.hpp"

PYBIND11_MODULE(_tether, module) {
  namespace python = tether::python;
  module.doc() = "Tether's C++ clients, transports, devices and virtual boards (use the package `tether`).";
  module.attr("__version__") = TETHER_VERSION;
  module.attr("_build_firmware_dir") = TETHER_FIRMWARE_DIR;
  module.def("_interpreter_exiting", &python::set_interpreter_exiting,
             "Called at exit: callbacks from the io thread stop reaching Python.");
  module.def("_after_fork_in_child", &python::after_fork_in_child,
             "Called in a child after os.fork(): its new clients get their own io thread.");
  python::register_transports(module);
  tether::devices::enable_virtual_boards();  // tether.open_rover opens virtual devices too
  python::register_devices(module);
  python::register_plugins(module);
}
