/// @file virtual_boards.hpp
/// Turns on a configuration's virtual boards (`virtual`, `virtual_ring` transports) for this program.
///
/// @code
///   #include <tether/devices/virtual_boards.hpp>   // Tether::virtual_uno (CMake), tether-virtual-uno (pkg-config)
///   int main() {
///     tether::devices::enable_virtual_boards();     // before opening a rover with virtual devices
///     ...
///   }
/// @endcode
///
/// Opening virtual boards runs the simulator (libsimavr), which lives in its own library so that a service
/// driving only hardware neither links nor installs it. The call is what ties the two together: a program
/// that does not make it (or does not link the library) gets a `ConfigError` (`DevicesError::not_supported`)
/// for each virtual device, naming this function and the library.
#pragma once

namespace tether::devices {

/// Lets `open_rover`, `async_open_rover` and `open_transport` open virtual boards and rings from now on.
/// Idempotent and thread-safe; call it before opening (typically first thing in `main`).
void enable_virtual_boards() noexcept;

}  // namespace tether::devices
