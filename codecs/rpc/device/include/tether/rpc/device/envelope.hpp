/// @file envelope.hpp
/// The device's decoder of the rpc envelope, `tether.rpc.wire.HostMessage` (tether_rpc.proto), written by
/// hand: its bodies are a few uint32 fields and one bytes field, so one loop serves the message and every
/// body (the field-list codec of message_codec.hpp took ~0.9 KB of AVR flash for it, one inlined loop per
/// body). The outcomes and the struct are nanopb's (0.4.x), as message_codec.hpp's: unknown fields
/// skipped, a known field of another wire type, a uint32 over 32 bits or a request over its 64 bytes
/// refused, a body of the oneof's other member zeroed first, one of the same member merged.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether_rpc.pb.h"

namespace tether {
namespace rpc {
namespace device {

/// Decodes `size` bytes at `data` into `message` (zeroed first); false when nanopb would refuse them.
bool decode_host_message(const uint8_t* data, size_t size, tether_rpc_wire_HostMessage& message);

}  // namespace device
}  // namespace rpc
}  // namespace tether
