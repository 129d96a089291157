// The steps of one MoveJoint call as tether::rpc::Client takes them (codecs/rpc/host/src/client.cpp), without
// I/O: the device's answer frames, the call's frame as the strand writes it, and the answer read through the
// client's frame reader. Shared by the typed call's allocation test and the host benchmark, so that both
// measure the same call. Include after the arm schema's classes (arm.tether.hpp).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

#include "tether/core/status.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/rpc/client.hpp"
#include "tether/rpc/envelope.hpp"
#include "tether/rpc/schema.hpp"
#include "tether_rpc.pb.h"

namespace tether::rpc::testing {

/// `payload` framed as the device frames it (CRC-16, COBS, leading delimiter); empty if it does not fit.
inline std::string frame_of(const std::string& payload) {
  std::string out(proxy::max_frame_size(payload.size()), '\0');
  const Result<std::size_t> size =
      proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()), proxy::Integrity::crc16, true,
                          MutableByteView(reinterpret_cast<std::uint8_t*>(out.data()), out.size()));
  out.resize(size.ok() ? size.value() : 0);
  return out;
}

/// What the device sends for call `id`: its Reply (a JointReply with `reached_cdeg`) and its Ack.
struct DeviceFrames {
  std::string reply;  ///< The Reply frame.
  std::string ack;    ///< The Ack frame.
};

/// The device's frames answering call `id` with `reached_cdeg`.
inline DeviceFrames device_frames(std::uint32_t id, std::int32_t reached_cdeg) {
  arm::JointReply joint;
  joint.set_reached_cdeg(reached_cdeg);
  wire::DeviceMessage reply;
  reply.mutable_reply()->set_call(id);
  reply.mutable_reply()->set_reply(joint.SerializeAsString());
  wire::DeviceMessage ack;
  ack.mutable_ack()->set_id(id);
  return DeviceFrames{frame_of(reply.SerializeAsString()), frame_of(ack.SerializeAsString())};
}

/// Encode: the HostMessage frame of `call` (the initiation's encoding) as the strand writes it, into the
/// client's recycled `frame`.
inline void call_frame(const detail::CallRequest& call, const Method& method, std::uint32_t id, std::string& frame) {
  envelope::HostMessage message;
  message.id = id;
  message.body = envelope::HostBody::call;
  message.method = method.index;
  message.request = ByteView::from_chars(call.request.data(), call.request.size());
  envelope::write_frame(message, frame);
}

/// Decode: the device's Reply (and, `with_ack`, its Ack) through the client's frame reader; the Reply's
/// payload for call `id` into `reply_bytes` (the call's state until the Ack). False when a frame does not
/// decode, the Reply is not `id`'s, or the Ack (when read) is missing.
template <std::size_t Capacity>
bool read_answer(envelope::FrameReader<Capacity>& reader, const DeviceFrames& answer, bool with_ack,
                 std::uint32_t id, std::string& reply_bytes) {
  bool replied = false;
  bool acked = false;
  for (const std::string* incoming : {&answer.reply, &answer.ack}) {
    if (incoming == &answer.ack && !with_ack) break;
    ByteView input = ByteView::from_chars(incoming->data(), incoming->size());
    while (!input.empty()) {
      const FeedResult fed = reader.feed(input);
      input = ByteView(input.data() + fed.consumed, input.size() - fed.consumed);
      if (fed.status != DecodeStatus::frame) continue;
      envelope::DeviceMessage out;
      if (envelope::decode(reader.frame(), out) != envelope::DecodeError::none) return false;
      if (out.body == envelope::DeviceBody::reply && out.reply.call == id) {
        reply_bytes.assign(reinterpret_cast<const char*>(out.reply.reply.data()), out.reply.reply.size());
        replied = true;
      }
      if (out.body == envelope::DeviceBody::ack && out.ack.id == id) acked = true;
    }
  }
  return replied && (acked || !with_ack);
}

}  // namespace tether::rpc::testing
