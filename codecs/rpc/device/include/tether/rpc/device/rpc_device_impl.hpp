// Implementation of rpc_device.hpp's template part (the sizes are the schema's).
#pragma once

#include "tether_rpc.pb.h"

namespace tether {
namespace rpc {
namespace device {

template <class Limits>
void Device<Limits>::handle_payload(ByteView payload, uint16_t fingerprint, Millis now) {
  frame_handled();
  Buffers buffers;
  UseScratch use(*this, buffers);
  tether_rpc_wire_HostMessage in;  // zeroed by the decoder
  if (!decode(payload, &in)) return;
  const auto lookup = executed_.check(in.id, fingerprint);
  if (lookup.duplicate) {  // a re-send: its first answer again, then the ack; nothing runs
    if (!lookup.cached_reply.empty()) send_again(in.id, lookup.cached_reply);
    send_ack(in.id, false);
    return;
  }
  const Outcome outcome = run(&in, now);
  // Only what ran is remembered: a refused message is looked at again when re-sent.
  if (!outcome.refused) executed_.remember(in.id, fingerprint, outcome.answer);
  send_ack(in.id, outcome.refused);
  finish(&in);
}

}  // namespace device
}  // namespace rpc
}  // namespace tether
