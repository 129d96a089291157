/// @file IOutputStream.h
/// RomiSerial compatibility header: `romiserial::IOutputStream`, implemented by Tether
/// (tether/romi/device/streams.hpp).
#pragma once

#include "tether/romi/device/streams.hpp"

namespace romiserial {
/// See tether::romi::device::IOutputStream.
using tether::romi::device::IOutputStream;
}  // namespace romiserial
