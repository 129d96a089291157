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

// The DeviceMessage envelope is written here by hand, not by nanopb: its bodies are a few small
// integers around at most one bytes field, and nanopb's generic encoder (a sizing pass per submessage, its
// descriptors read from flash field by field, 64-bit varints) cost a stream message ~54,000 cycles on the
// ATmega328P. The bytes are nanopb's (tether_rpc.proto, proto3): fields in number order, zero integers,
// false and empty strings left out, the oneof's body always written, a handler's struct as a bytes field
// even when it encodes to nothing.
enum DeviceField : uint8_t {  // DeviceMessage.body
  kAckField = 1,
  kReplyField = 2,
  kErrorField = 3,
  kStreamField = 4,
  kHelloField = 5,
  kResetField = 6,
};
constexpr uint8_t kVarint = 0;
constexpr uint8_t kFixed64 = 1;
constexpr uint8_t kDelimited = 2;
// DeviceError.text's bound (tether_rpc.options: max_size 48, the NUL included).
constexpr size_t kErrorTextRoom = sizeof(tether_rpc_wire_DeviceError{}.text);

}  // namespace

// Each call of the writer's fields is a call, not a copy of its code (flash: the device has ~12 places
// that write fields).
#define TETHER_RPC_OUT_OF_LINE __attribute__((noinline))

// A protobuf writer on a bounded buffer; once something does not fit, nothing more is written and
// `size()` is 0.
class DeviceCore::Writer {
 public:
  Writer(uint8_t* buffer, size_t capacity) : begin_(buffer), at_(buffer), end_(buffer + capacity) {}

  void byte(uint8_t value) {
    if (at_ == end_) {
      fail();
      return;
    }
    *at_++ = value;
  }
  TETHER_RPC_OUT_OF_LINE void varint(uint32_t value) {
    while (value >= 0x80) {
      byte(static_cast<uint8_t>(value | 0x80));
      value >>= 7;
    }
    byte(static_cast<uint8_t>(value));
  }
  void tag(uint8_t field, uint8_t wire_type) { byte(static_cast<uint8_t>(field << 3 | wire_type)); }
  // A uint32 / bool field (proto3: left out when zero).
  TETHER_RPC_OUT_OF_LINE void number(uint8_t field, uint32_t value) {
    if (value == 0) return;
    tag(field, kVarint);
    varint(value);
  }
  // Opens a length-delimited field; `close` writes its length once its contents are written.
  TETHER_RPC_OUT_OF_LINE uint8_t* open(uint8_t field) {
    tag(field, kDelimited);
    uint8_t* const mark = at_;
    byte(0);
    return mark;
  }
  TETHER_RPC_OUT_OF_LINE void close(uint8_t* mark) {
    if (at_ == nullptr) return;
    const size_t length = static_cast<size_t>(at_ - mark - 1);
    if (length < 0x80) {  // the one byte `open` kept (every body of a device with 64-byte messages)
      *mark = static_cast<uint8_t>(length);
      return;
    }
    uint8_t extra = 0;  // the length's varint bytes beyond the first
    for (size_t rest = length >> 7; rest != 0; rest >>= 7) ++extra;
    if (static_cast<size_t>(end_ - at_) < extra) {
      fail();
      return;
    }
    memmove(mark + 1 + extra, mark + 1, length);
    at_ = mark;
    varint(static_cast<uint32_t>(length));
    at_ += length;
  }
  // A handler's struct as a bytes field, encoded once, in place.
  TETHER_RPC_OUT_OF_LINE void message(uint8_t field, const pb_msgdesc_t* fields, const void* message) {
    uint8_t* const mark = open(field);
    if (at_ == nullptr) return;
    pb_ostream_t stream = pb_ostream_from_buffer(at_, static_cast<size_t>(end_ - at_));
    if (!pb_encode(&stream, fields, message)) {
      fail();
      return;
    }
    at_ += stream.bytes_written;
    close(mark);
  }
  // A string field of at most kErrorTextRoom - 1 characters, from RAM or flash (left out when empty).
  TETHER_RPC_OUT_OF_LINE void text(uint8_t field, const char* text, bool in_flash) {
    if (text == nullptr || at_ == nullptr) return;
    uint8_t* const mark = open(field);
    if (at_ == nullptr || static_cast<size_t>(end_ - at_) < kErrorTextRoom) {
      fail();
      return;
    }
    TextBuilder builder(reinterpret_cast<char*>(at_), kErrorTextRoom);
    if (in_flash) {
      builder.text(FlashText{text});
    } else {
      builder.text(text);
    }
    if (builder.size() == 0) {
      at_ = mark - 1;  // an empty string is left out
      return;
    }
    at_ += builder.size();
    close(mark);
  }
  TETHER_RPC_OUT_OF_LINE void fixed64(uint8_t field, uint64_t value) {
    if (value == 0) return;
    tag(field, kFixed64);
    for (uint8_t i = 0; i < 8; ++i) {
      byte(static_cast<uint8_t>(value));
      value >>= 8;
    }
  }
  // Bytes written; 0 when something did not fit.
  size_t size() const { return at_ == nullptr ? 0 : static_cast<size_t>(at_ - begin_); }

 private:
  void fail() { at_ = end_ = nullptr; }

  uint8_t* begin_;
  uint8_t* at_;
  uint8_t* end_;
};

void DeviceCore::start(uint32_t session_id, Millis now) {
  session_id_ = session_id;
  watchdog_.start(now);
  next_info_.arm(now, kInfoPeriodMs);
  Writer out(scratch_.out, max_out_);
  uint8_t* const body = out.open(kResetField);
  out.number(1, session_id);  // ResetEvent.session
  out.close(body);
  send_message(out, true);
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
  static_assert(TETHER_PB_SUBMESSAGE_FIELDS(tether_rpc_wire_HostMessage) <= kEnvelopeSubmessages,
                "the envelope's descriptor copy has room for every body");
  // On the stack for the decode only (the answers are written by hand: no descriptors).
  const proxy::device::DescriptorCopy<kEnvelopeSubmessages> fields(
      proxy::device::FlashDescriptor{tether_rpc_wire_HostMessage_fields});
  if (proxy::device::decode_message(fields.get(), payload, host_message)) return true;
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
  Writer out(scratch_.out, max_out_);
  uint8_t* const body = out.open(kReplyField);
  out.number(1, id);                              // Reply.call
  out.message(2, m.reply, service_->reply);       // Reply.reply
  out.close(body);
  size_t size = send_message(out);
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
  Writer out(scratch_.out, max_out_);
  uint8_t* const body = out.open(kStreamField);
  out.number(1, slot.id);                          // StreamMessage.stream
  out.number(2, slot.seq);                         // StreamMessage.seq
  out.message(3, m.reply, service_->reply);        // StreamMessage.message
  out.close(body);
  if (send_message(out) == 0) {
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
  Writer out(scratch_.out, max_out_);
  uint8_t* const body = out.open(kErrorField);
  out.number(1, call);                   // DeviceError.call
  out.number(2, code);                   // DeviceError.code
  out.text(3, text, text_in_flash);      // DeviceError.text
  out.close(body);
  return send_message(out);
}

void DeviceCore::send_ack(uint32_t id, bool refused) {
  Writer out(scratch_.out, max_out_);
  uint8_t* const body = out.open(kAckField);
  out.number(1, id);                     // Ack.id
  out.number(2, refused ? 1 : 0);        // Ack.refused
  out.close(body);
  send_message(out);
}

void DeviceCore::send_hello() {
  Writer out(scratch_.out, max_out_);
  uint8_t* const body = out.open(kHelloField);
  out.fixed64(1, service_->schema_hash);   // DeviceHello.schema_hash
  out.number(2, session_id_);              // DeviceHello.session
  out.number(3, max_payload_);             // DeviceHello.max_payload
  out.number(4, service_->method_count);   // DeviceHello.methods
  out.close(body);
  send_message(out);
}

size_t DeviceCore::send_message(const Writer& message, bool leading_delimiter) {
  const size_t size = message.size();
  if (size == 0) {
    add_one(counters_.send_failures);
    return 0;
  }
  send_payload(ByteView(scratch_.out, size), leading_delimiter);
  return size;
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
