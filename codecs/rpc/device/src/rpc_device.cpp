// The rpc device's size-independent part: see tether/rpc/device/rpc_device.hpp for the wire behaviour.
#include "tether/rpc/device/rpc_device.hpp"

#include <string.h>

#include <pb_decode.h>
#include <pb_encode.h>

#include "tether/proxy/device/text.hpp"
#include "tether_rpc.pb.h"

namespace tether {
namespace rpc {
namespace device {

using proxy::device::FlashText;
using proxy::device::TextBuilder;

static_assert(tether_rpc_wire_HostMessage_size <= DefaultLimits::kMaxPayload, "a HostMessage must fit the decoder");
#if defined(__AVR__) && !defined(TETHER_PB_DESCRIPTORS_IN_FLASH)
#error "tether_rpc.pb.h without nanopb_descriptors_in_flash.h: the device reads the envelope's descriptors from flash"
#endif
static_assert(tether_rpc_wire_DeviceError_size + 2 <= 64 && tether_rpc_wire_DeviceHello_size + 2 <= 64,
              "a DeviceError and a DeviceHello fit every device's answer buffer (kMaxOutPayload >= 64)");

namespace {

// Tether's own error texts, in flash on the AVR.
const char kNotAHostMessage[] TETHER_IN_FLASH = "not a HostMessage";
const char kUnknownMethod[] TETHER_IN_FLASH = "unknown method";
const char kBadRequest[] TETHER_IN_FLASH = "request does not decode";
const char kNotUnary[] TETHER_IN_FLASH = "method streams: open a stream";
const char kNotStreaming[] TETHER_IN_FLASH = "method does not stream: call it";
const char kPeriodTooShort[] TETHER_IN_FLASH = "period too short";
const char kRequestTooLarge[] TETHER_IN_FLASH = "stream request too large";
const char kReplyTooLarge[] TETHER_IN_FLASH = "reply too large";
const char kUnknownMessage[] TETHER_IN_FLASH = "unknown message";
const char kStreamsFull[] TETHER_IN_FLASH = "too many streams";

const char* error_text(DeviceErrorCode code) {
  switch (code) {
    case DeviceErrorCode::unknown_method: return kUnknownMethod;
    case DeviceErrorCode::bad_request: return kBadRequest;
    case DeviceErrorCode::not_unary: return kNotUnary;
    case DeviceErrorCode::not_streaming: return kNotStreaming;
    case DeviceErrorCode::period_too_short: return kPeriodTooShort;
    case DeviceErrorCode::request_too_large: return kRequestTooLarge;
    case DeviceErrorCode::reply_too_large: return kReplyTooLarge;
    case DeviceErrorCode::bad_envelope: return kNotAHostMessage;
    case DeviceErrorCode::unknown_message: return kUnknownMessage;
    case DeviceErrorCode::streams_full: return kStreamsFull;
  }
  return kUnknownMessage;
}

// A handler's struct, encoded as a bytes field (a Reply's reply, a StreamMessage's message): the same
// bytes as the struct's own encoding, length-delimited, with no second buffer. Its size is computed once:
// nanopb sizes the enclosing body before writing it, and pb_encode_submessage would encode the struct
// twice at each of those two passes (four encodings of it per message instead of two).
struct StructField {
  const pb_msgdesc_t* fields;
  const void* message;
  size_t size;
  bool sized;
};

bool is_sizing(const pb_ostream_t* stream) {
#ifdef PB_BUFFER_ONLY
  return stream->state == NULL;
#else
  return stream->callback == NULL;
#endif
}

bool encode_struct(pb_ostream_t* stream, const pb_field_t* field, void* const* arg) {
  StructField& payload = *static_cast<StructField*>(*arg);
  if (!payload.sized) {
    if (!pb_get_encoded_size(&payload.size, payload.fields, payload.message)) return false;
    payload.sized = true;
  }
  if (!pb_encode_tag_for_field(stream, field) || !pb_encode_varint(stream, payload.size)) return false;
  if (is_sizing(stream)) return pb_write(stream, NULL, payload.size);
  const size_t before = stream->bytes_written;
  return pb_encode(stream, payload.fields, payload.message) && stream->bytes_written - before == payload.size;
}

tether_rpc_wire_DeviceMessage out_message(pb_size_t which) {
  tether_rpc_wire_DeviceMessage out = tether_rpc_wire_DeviceMessage_init_zero;
  out.which_body = which;
  return out;
}

}  // namespace

void DeviceCore::start(uint32_t session_id, Millis now) {
  session_id_ = session_id;
  watchdog_.start(now);
  next_info_.arm(now, kInfoPeriodMs);
  tether_rpc_wire_DeviceMessage out = out_message(tether_rpc_wire_DeviceMessage_reset_tag);
  out.body.reset.session = session_id;
  send_message(&out, true);
}

void DeviceCore::track_frame(bool was_in_frame, bool in_frame, Millis now) {
  if (!was_in_frame && in_frame) {
    partial_.on_frame_start(now);
  } else if (was_in_frame && !in_frame) {
    partial_.on_frame_end();
  }
}

void DeviceCore::poll_time(Millis now) {
  watchdog_.poll(now);
  if (next_info_.expired(now)) {
    send_hello();
    next_info_.arm(next_info_.at(), kInfoPeriodMs);
    if (next_info_.expired(now)) next_info_.arm(now, kInfoPeriodMs);  // fell behind: no burst
  }
  for (uint8_t i = 0; i < slot_count_; ++i) {
    if (slots_[i].request_size != kFree && slots_[i].next.expired(now)) run_stream(i, now);
  }
}

bool DeviceCore::decode(ByteView payload, void* host_message) {
  static_assert(TETHER_PB_SUBMESSAGE_FIELDS(tether_rpc_wire_HostMessage) <= kEnvelopeSubmessages &&
                    TETHER_PB_SUBMESSAGE_FIELDS(tether_rpc_wire_DeviceMessage) <= kEnvelopeSubmessages,
                "the envelope's descriptor copy has room for every body");
  const pb_msgdesc_t* const fields =
      proxy::device::copy_descriptors(proxy::device::FlashDescriptor{tether_rpc_wire_HostMessage_fields},
                                      envelope_descriptors_, envelope_list_, kEnvelopeSubmessages);
  pb_istream_t stream = pb_istream_from_buffer(payload.data(), payload.size());
  if (pb_decode(&stream, fields, host_message)) return true;
  add_one(counters_.decode_errors);
  send_error(0, static_cast<uint16_t>(DeviceErrorCode::bad_envelope), kNotAHostMessage, true);
  return false;
}

DeviceCore::Outcome DeviceCore::run(const void* host_message, Millis now) {
  const tether_rpc_wire_HostMessage& in = *static_cast<const tether_rpc_wire_HostMessage*>(host_message);
  switch (in.which_body) {
    case tether_rpc_wire_HostMessage_hello_tag:
      send_hello();
      return Outcome{false, 0};
    case tether_rpc_wire_HostMessage_call_tag: {
      const tether_rpc_wire_Call& c = in.body.call;
      return call(in.id, c.method, ByteView(c.request.bytes, c.request.size));
    }
    case tether_rpc_wire_HostMessage_open_tag: {
      const tether_rpc_wire_OpenStream& o = in.body.open;
      return open(in.id, o.method, ByteView(o.request.bytes, o.request.size), o.period_ms, now);
    }
    case tether_rpc_wire_HostMessage_close_tag:
      for (uint8_t i = 0; i < slot_count_; ++i) {
        if (slots_[i].request_size != kFree && slots_[i].id == in.body.close.stream) slots_[i].request_size = kFree;
      }
      return Outcome{false, 0};
    case tether_rpc_wire_HostMessage_ping_tag:
      watchdog_.on_heartbeat(now);
      return Outcome{false, 0};
    case tether_rpc_wire_HostMessage_reset_tag:
      return Outcome{false, 0};  // finish() restarts, after the ack
    default:
      return refuse(in.id, DeviceErrorCode::unknown_message);
  }
}

bool DeviceCore::decode_request(const Method& method, ByteView request) {
  pb_istream_t stream = pb_istream_from_buffer(request.data(), request.size());
  return pb_decode(&stream, method.request, service_->request);
}

DeviceCore::Outcome DeviceCore::call(uint32_t id, uint32_t method, ByteView request) {
  if (method >= service_->method_count) return refuse(id, DeviceErrorCode::unknown_method);
  const Method& m = service_->methods[method];
  if (m.streaming) return refuse(id, DeviceErrorCode::not_unary);
  if (!decode_request(m, request)) return refuse(id, DeviceErrorCode::bad_request);
  memset(service_->reply, 0, service_->reply_size);
  add_one(counters_.calls);
  const Status status = m.handler(service_->request, service_->reply);
  if (!status.is_ok()) {
    add_one(counters_.handler_errors);
    return Outcome{false, send_error(id, status.code(), status.text(), false)};
  }
  tether_rpc_wire_DeviceMessage out = out_message(tether_rpc_wire_DeviceMessage_reply_tag);
  out.body.reply.call = id;
  StructField reply{m.reply, service_->reply, 0, false};
  out.body.reply.reply.funcs.encode = &encode_struct;
  out.body.reply.reply.arg = &reply;
  size_t size = send_message(&out);
  if (size == 0) {  // it ran: the answer is the error, remembered like a reply
    size = send_error(id, static_cast<uint16_t>(DeviceErrorCode::reply_too_large), kReplyTooLarge, true);
  }
  return Outcome{false, size};
}

DeviceCore::Outcome DeviceCore::open(uint32_t id, uint32_t method, ByteView request, uint32_t period, Millis now) {
  if (method >= service_->method_count) return refuse(id, DeviceErrorCode::unknown_method);
  const Method& m = service_->methods[method];
  if (!m.streaming) return refuse(id, DeviceErrorCode::not_streaming);
  if (period < min_period_ms_ || period > 0xFFFFu) return refuse(id, DeviceErrorCode::period_too_short);
  if (request.size() > request_bytes_) return refuse(id, DeviceErrorCode::request_too_large);
  if (!decode_request(m, request)) return refuse(id, DeviceErrorCode::bad_request);
  // The method's own slot (a re-open replaces its stream), else a free one.
  uint8_t chosen = kFree;
  for (uint8_t i = 0; i < slot_count_; ++i) {
    if (slots_[i].request_size == kFree) {
      if (chosen == kFree) chosen = i;
    } else if (slots_[i].method == method) {
      chosen = i;
      break;
    }
  }
  if (chosen == kFree) return refuse(id, DeviceErrorCode::streams_full);
  StreamSlot& slot = slots_[chosen];
  slot.id = id;
  slot.method = static_cast<uint8_t>(method);
  slot.period = static_cast<uint16_t>(period);
  slot.seq = 0;
  slot.request_size = static_cast<uint8_t>(request.size());
  memcpy(requests_ + chosen * request_bytes_, request.data(), request.size());
  slot.next.arm_at(now);  // the first message at the next poll
  return Outcome{false, 0};
}

void DeviceCore::run_stream(uint8_t index, Millis now) {
  StreamSlot& slot = slots_[index];
  const Method& m = service_->methods[slot.method];
  if (!decode_request(m, ByteView(requests_ + index * request_bytes_, slot.request_size))) {
    slot.request_size = kFree;  // it decoded when the stream opened: only a bug gets here
    send_error(slot.id, static_cast<uint16_t>(DeviceErrorCode::bad_request), kBadRequest, true);
    return;
  }
  memset(service_->reply, 0, service_->reply_size);
  const Status status = m.handler(service_->request, service_->reply);
  if (!status.is_ok()) {
    add_one(counters_.handler_errors);
    slot.request_size = kFree;
    send_error(slot.id, status.code(), status.text(), false);
    return;
  }
  tether_rpc_wire_DeviceMessage out = out_message(tether_rpc_wire_DeviceMessage_stream_tag);
  out.body.stream.stream = slot.id;
  out.body.stream.seq = slot.seq;
  StructField message{m.reply, service_->reply, 0, false};
  out.body.stream.message.funcs.encode = &encode_struct;
  out.body.stream.message.arg = &message;
  if (send_message(&out) == 0) {
    slot.request_size = kFree;
    send_error(slot.id, static_cast<uint16_t>(DeviceErrorCode::reply_too_large), kReplyTooLarge, true);
    return;
  }
  add_one(counters_.stream_messages);
  ++slot.seq;
  slot.next.arm(slot.next.at(), slot.period);
  if (slot.next.expired(now)) slot.next.arm(now, slot.period);  // fell behind: no burst
}

bool DeviceCore::slot_open(uint32_t id) const {
  for (uint8_t i = 0; i < slot_count_; ++i) {
    if (slots_[i].request_size != kFree && slots_[i].id == id) return true;
  }
  return false;
}

uint8_t DeviceCore::open_streams() const {
  uint8_t open = 0;
  for (uint8_t i = 0; i < slot_count_; ++i) {
    if (slots_[i].request_size != kFree) ++open;
  }
  return open;
}

void DeviceCore::close_streams() {
  for (uint8_t i = 0; i < slot_count_; ++i) slots_[i].request_size = kFree;
}

DeviceCore::Outcome DeviceCore::refuse(uint32_t id, DeviceErrorCode code) {
  add_one(counters_.refused);
  return Outcome{true, send_error(id, static_cast<uint16_t>(code), error_text(code), true)};
}

size_t DeviceCore::send_error(uint32_t call, uint16_t code, const char* text, bool text_in_flash) {
  tether_rpc_wire_DeviceMessage out = out_message(tether_rpc_wire_DeviceMessage_error_tag);
  out.body.error.call = call;
  out.body.error.code = code;
  TextBuilder builder(out.body.error.text, sizeof(out.body.error.text));
  if (text_in_flash) {
    builder.text(FlashText{text});
  } else if (text != nullptr) {
    builder.text(text);
  }
  return send_message(&out);
}

void DeviceCore::send_ack(uint32_t id, bool refused) {
  tether_rpc_wire_DeviceMessage out = out_message(tether_rpc_wire_DeviceMessage_ack_tag);
  out.body.ack.id = id;
  out.body.ack.refused = refused;
  send_message(&out);
}

void DeviceCore::send_hello() {
  tether_rpc_wire_DeviceMessage out = out_message(tether_rpc_wire_DeviceMessage_hello_tag);
  out.body.hello.schema_hash = service_->schema_hash;
  out.body.hello.session = session_id_;
  out.body.hello.max_payload = max_payload_;
  out.body.hello.methods = service_->method_count;
  send_message(&out);
}

size_t DeviceCore::send_message(const void* device_message, bool leading_delimiter) {
  uint8_t* const payload = scratch_.out;
  const pb_msgdesc_t* const fields =
      proxy::device::copy_descriptors(proxy::device::FlashDescriptor{tether_rpc_wire_DeviceMessage_fields},
                                      envelope_descriptors_, envelope_list_, kEnvelopeSubmessages);
  pb_ostream_t stream = pb_ostream_from_buffer(payload, max_out_);
  if (!pb_encode(&stream, fields, device_message)) {
    add_one(counters_.send_failures);
    return 0;
  }
  send_payload(ByteView(payload, stream.bytes_written), leading_delimiter);
  return stream.bytes_written;
}

void DeviceCore::send_payload(ByteView payload, bool leading_delimiter) {
  const Result<size_t> framed = proxy::encode_frame(payload, proxy::Integrity::crc16, leading_delimiter,
                                                    MutableByteView(scratch_.frame, proxy::max_frame_size(max_out_)));
  if (!framed.ok()) {
    add_one(counters_.send_failures);
    return;
  }
  sink_.write(sink_.context, ByteView(scratch_.frame, framed.value()));
}

void DeviceCore::finish(const void* host_message) {
  const tether_rpc_wire_HostMessage& in = *static_cast<const tether_rpc_wire_HostMessage*>(host_message);
  if (in.which_body == tether_rpc_wire_HostMessage_reset_tag && restart_ != nullptr) restart_(restart_context_);
}

void DeviceCore::on_failsafe(void* self, Millis) { static_cast<DeviceCore*>(self)->close_streams(); }

}  // namespace device
}  // namespace rpc
}  // namespace tether
