// The envelope's decoder by hand (tether/rpc/device/envelope.hpp), on message_codec.hpp's reader.
#include "tether/rpc/device/envelope.hpp"

#include <string.h>

#include "tether/rpc/device/message_codec.hpp"

namespace tether {
namespace rpc {
namespace device {

namespace {

using wire::Reader;

// The fields of a body (`tag`: HostMessage's field number of the oneof member `body` is).
bool decode_body(Reader& r, pb_size_t tag, tether_rpc_wire_HostMessage& m) {
  while (r.more()) {
    uint32_t key;
    if (!r.key(key)) return false;
    const uint8_t wire = static_cast<uint8_t>(key & 7);
    const uint32_t field = key >> 3;
    uint32_t* number = nullptr;
    pb_size_t* size = nullptr;
    uint8_t* bytes = nullptr;
    if (tag == tether_rpc_wire_HostMessage_call_tag) {
      if (field == 1) number = &m.body.call.method;
      if (field == 2) {
        size = &m.body.call.request.size;
        bytes = m.body.call.request.bytes;
      }
    } else if (tag == tether_rpc_wire_HostMessage_open_tag) {
      if (field == 1) number = &m.body.open.method;
      if (field == 3) number = &m.body.open.period_ms;
      if (field == 2) {
        size = &m.body.open.request.size;
        bytes = m.body.open.request.bytes;
      }
    } else if (tag == tether_rpc_wire_HostMessage_close_tag) {
      if (field == 1) number = &m.body.close.stream;
    }
    bool ok;
    if (number != nullptr) {
      ok = wire::get_value(r, wire, wire::Uvarint(), *number);
    } else if (size != nullptr) {
      static_assert(sizeof m.body.call.request.bytes == sizeof m.body.open.request.bytes, "one bound");
      ok = wire == 2 && wire::get_bytes(r, size, bytes, sizeof m.body.call.request.bytes);
    } else {
      ok = r.skip(wire);
    }
    if (!ok) return false;
  }
  return true;
}

// The oneof member of `tag` (2..7) and its size.
void* body_of(pb_size_t tag, tether_rpc_wire_HostMessage& m, size_t& size) {
  switch (tag) {
    case tether_rpc_wire_HostMessage_hello_tag:
      size = sizeof m.body.hello;
      return &m.body.hello;
    case tether_rpc_wire_HostMessage_call_tag:
      size = sizeof m.body.call;
      return &m.body.call;
    case tether_rpc_wire_HostMessage_open_tag:
      size = sizeof m.body.open;
      return &m.body.open;
    case tether_rpc_wire_HostMessage_close_tag:
      size = sizeof m.body.close;
      return &m.body.close;
    case tether_rpc_wire_HostMessage_ping_tag:
      size = sizeof m.body.ping;
      return &m.body.ping;
    default:
      size = sizeof m.body.reset;
      return &m.body.reset;
  }
}

}  // namespace

bool decode_host_message(const uint8_t* data, size_t size, tether_rpc_wire_HostMessage& m) {
  static_assert(tether_rpc_wire_HostMessage_hello_tag == 2 && tether_rpc_wire_HostMessage_reset_tag == 7,
                "the body's members are fields 2..7 (tether_rpc.proto)");
  memset(&m, 0, sizeof m);
  Reader r(data, size);
  while (r.more()) {
    uint32_t key;
    if (!r.key(key)) return false;
    const uint8_t wire = static_cast<uint8_t>(key & 7);
    const uint32_t field = key >> 3;
    bool ok;
    if (field == 1) {
      ok = wire::get_value(r, wire, wire::Uvarint(), m.id);
    } else if (field >= tether_rpc_wire_HostMessage_hello_tag && field <= tether_rpc_wire_HostMessage_reset_tag) {
      const pb_size_t tag = static_cast<pb_size_t>(field);
      if (m.which_body != tag) {  // another member: it starts from zero (nanopb zeroes the new member)
        size_t body_size;
        void* const body = body_of(tag, m, body_size);
        memset(body, 0, body_size);
      }
      m.which_body = tag;
      Reader inner(nullptr, 0);
      ok = wire == 2 && r.sub(inner) && decode_body(inner, tag, m);
    } else {
      ok = r.skip(wire);
    }
    if (!ok) return false;
  }
  return true;
}

}  // namespace device
}  // namespace rpc
}  // namespace tether
