// `tether replay FILE --against-virtual IMAGE`: the capture's host->device bytes of one link sent to a virtual
// Uno running IMAGE with the recorded timing, and where its answers differ from the recorded ones.
#pragma once

#include <cstdint>
#include <optional>
#include <string>

#include "cli_support.hpp"
#include "tether/devices/config.hpp"
#include "tether/transports/pcapng.hpp"

namespace tether::cli {

/// What `replay --against-virtual` runs.
struct AgainstVirtual {
  std::string file;                         ///< The capture's file name, for messages.
  const transports::Capture* capture = nullptr;  ///< The capture, read.
  std::size_t link = 0;                     ///< The capture's interface of the device (`--device`, or its only one).
  devices::DeviceConfig device;             ///< That link's device: its codec and the options its words give.
  std::string image;                        ///< `--against-virtual IMAGE`, as given.
  bool json = false;                        ///< `--json`.
  std::uint32_t settle_ms = 500;            ///< Board time run past the link's last recorded packet.
};

/// The usage lines of the codecs' comparison rules (`    proxy: ...`), and what the others do.
std::string against_virtual_rules_usage();

/// Runs it: exit status 0 (the board answered as recorded), 1 (differences, printed), 2 (an error, said
/// through `text`).
int replay_against_virtual(const AgainstVirtual& run, const CommandText& text);

}  // namespace tether::cli
