// `tether replay FILE --as-device` (replay_as_device.cpp): the recorded device of one link on a pty.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "tether/devices/config.hpp"
#include "tether/transports/pcapng.hpp"

namespace tether::cli {

/// What `tether replay --as-device` was given (replay.cpp parses it).
struct AsDeviceOptions {
  std::string file;                           ///< The capture, for messages.
  std::optional<std::filesystem::path> link;  ///< --link PATH: a symlink to the pty.
  bool loop = false;                          ///< --loop: start again at the end of the recording.
  bool json = false;                          ///< --json: the pty line as JSON.
};

/// Plays the recorded device of `capture`'s link `interface` (of `device`, its codec and options) on a new
/// pty until the recording ends or a stop signal; the exit status.
int replay_as_device(const transports::Capture& capture, std::uint32_t interface, const devices::DeviceConfig& device,
                     const AsDeviceOptions& options);

}  // namespace tether::cli
