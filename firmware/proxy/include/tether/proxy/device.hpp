/// @file device.hpp
/// The proxy protocol's device library (`tether_proxy_device`), in one include. See firmware/proxy/README.md.
///
/// - `device/pins.hpp`: the Uno's pins, servo arithmetic (degrees -> pulse -> OCR1x).
/// - `device/hardware.hpp`: the pin drivers (port registers, Timer1 PWM), chosen at link time.
/// - `device/outputs.hpp`: `OutputTable`, the initialised outputs and their safe values.
/// - `device/io.hpp`: `FrameSink`, `RestartFunction`, `send_message` (nanopb -> frame).
/// - `device/flash_descriptors.hpp`: nanopb descriptors kept in flash, copied for each encode/decode
///   (`nanopb_descriptors_in_flash.h`, included by a schema's generated header, puts them there).
/// - `device/proxy_device.hpp`: `ProxyDevice`, primary mode (CRC, acks, failsafe, sessionId).
/// - `device/compat_device.hpp`: `CompatDevice`, the deployed variant (RocketryProto, no CRC).
/// - `device/session_id.hpp`: the boot's sessionId (EEPROM counter, SRAM and ADC noise).
/// - `device/text.hpp`: `TextBuilder` for Error texts.
#pragma once

#include "tether/proxy/device/compat_device.hpp"
#include "tether/proxy/device/flash_descriptors.hpp"
#include "tether/proxy/device/hardware.hpp"
#include "tether/proxy/device/io.hpp"
#include "tether/proxy/device/outputs.hpp"
#include "tether/proxy/device/pins.hpp"
#include "tether/proxy/device/proxy_device.hpp"
#include "tether/proxy/device/session_id.hpp"
#include "tether/proxy/device/text.hpp"
