/// @file IInputStream.h
/// RomiSerial compatibility header: `romiserial::IInputStream`, implemented by Tether
/// (tether/romi/device/streams.hpp).
#pragma once

#include "tether/romi/device/streams.hpp"

namespace romiserial {
/// See tether::romi::device::IInputStream.
using tether::romi::device::IInputStream;
}  // namespace romiserial
