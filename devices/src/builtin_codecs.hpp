// The rows of the codec plugins built into the devices library (codec_table.cpp).
#pragma once

#include <vector>

#include "tether/devices/codecs.hpp"

namespace tether::devices::detail {

/// The rows of every codec plugin registered with `tether_codec_plugin` (generated: plugin_rows.cpp.in).
std::vector<CodecRow> plugin_rows();

}  // namespace tether::devices::detail
