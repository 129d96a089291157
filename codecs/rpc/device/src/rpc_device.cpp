// The rpc device's size-independent part: see tether/rpc/device/rpc_device.hpp for the wire behaviour.
#include "tether/rpc/device/rpc_device.hpp"

#include <string.h>

#include "tether/proxy/device/text.hpp"
#include "tether/rpc/device/envelope.hpp"
#include "tether_rpc.pb.h"

namespace tether {
namespace rpc {
namespace device {

static_assert(tether_rpc_wire_HostMessage_size <= DefaultLimits::kMaxPayload, "a HostMessage must fit the decoder");
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

// Their table in flash too (a switch's table would be in RAM), by code from unknown_method.
const char* const kErrorTexts[] TETHER_IN_FLASH = {
    kUnknownMethod, kBadRequest,   kNotUnary,         kNotStreaming,  kPeriodTooShort,
    kRequestTooLarge, kReplyTooLarge, kNotAHostMessage, kUnknownMessage, kStreamsFull,
};
static_assert(sizeof kErrorTexts / sizeof kErrorTexts[0] ==
                  static_cast<uint16_t>(DeviceErrorCode::streams_full) -
                      static_cast<uint16_t>(DeviceErrorCode::unknown_method) + 1,
              "one text per DeviceErrorCode");

const char* error_text(DeviceErrorCode code) {
  const char* text;
  copy_from_flash(&text, &kErrorTexts[static_cast<uint16_t>(code) - static_cast<uint16_t>(DeviceErrorCode::unknown_method)],
                  sizeof text);
  return text;
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

using wire::Writer;

// The envelope's fields, each out of line (the device has ~12 places that write them).
#define TETHER_RPC_OUT_OF_LINE __attribute__((noinline))

uint8_t* open_field(Writer& out, uint8_t field) {
  out.byte(static_cast<uint8_t>(field << 3 | kDelimited));
  return out.open();
}
// A uint32 / bool field (proto3: left out when zero).
TETHER_RPC_OUT_OF_LINE void put_number(Writer& out, uint8_t field, uint32_t value) {
  if (value != 0) out.field_u32(static_cast<uint8_t>(field << 3 | kVarint), value);
}
// A string field of at most kErrorTextRoom - 1 characters, from RAM or flash (left out when empty).
TETHER_RPC_OUT_OF_LINE void put_text(Writer& out, uint8_t field, const char* text, bool in_flash) {
  if (text == nullptr || !out.ok()) return;
  uint8_t* const start = out.position();
  uint8_t* const mark = open_field(out, field);
  uint8_t* const room = out.room(kErrorTextRoom - 1);
  if (room == nullptr) return;
  // One loop for both memories (two text builders cost ~0.3 KB of flash on the AVR).
  const uint8_t* const from = reinterpret_cast<const uint8_t*>(text);
  uint8_t size = 0;
  for (; size < kErrorTextRoom - 1; ++size) {
    const uint8_t c = in_flash ? proxy::device::read_flash_byte(from + size) : from[size];
    if (c == 0) break;
    room[size] = c;
  }
  if (size == 0) {
    out.rewind(start);  // an empty string is left out
    return;
  }
  out.advance(size);
  out.close(mark);
}
TETHER_RPC_OUT_OF_LINE void put_fixed64(Writer& out, uint8_t field, uint64_t value) {
  if (value == 0) return;
  out.byte(static_cast<uint8_t>(field << 3 | kFixed64));
  out.raw(&value, 8);
}
// A handler's struct as a bytes field, encoded once, in place.
TETHER_RPC_OUT_OF_LINE void put_message(Writer& out, uint8_t field, EncodeFunction encode, const void* message) {
  uint8_t* const mark = open_field(out, field);
  if (!encode(out, message)) {
    out.fail();
    return;
  }
  out.close(mark);
}

}  // namespace

void DeviceCore::bind(const Service& service, FrameSink sink, RestartFunction restart, void* restart_context,
                      size_t max_payload, size_t max_out, StreamSlot* slots, uint8_t slot_count, uint8_t* requests,
                      uint8_t request_bytes) {
  service_ = &service;
  sink_ = sink;
  restart_ = restart;
  restart_context_ = restart_context;
  max_payload_ = static_cast<uint16_t>(max_payload);
  max_out_ = static_cast<uint16_t>(max_out);
  slots_ = slots;
  requests_ = requests;
  slot_count_ = slot_count;
  request_bytes_ = request_bytes;
}

bool DeviceCore::poll_frame_deadline(Millis now) {
  if (!partial_.expired(now)) return false;
  partial_.disarm();
  add_one(counters_.link.partial_timeouts);
  return true;
}

TETHER_RPC_OUT_OF_LINE void DeviceCore::begin_with(Scratch& scratch, uint32_t session_id, Millis now) {
  scratch_ = &scratch;
  start(session_id, now);
  scratch_ = nullptr;
}

TETHER_RPC_OUT_OF_LINE void DeviceCore::poll_with(Scratch& scratch, Millis now) {
  scratch_ = &scratch;
  poll_time(now);
  scratch_ = nullptr;
}

TETHER_RPC_OUT_OF_LINE void DeviceCore::handle_frame(Scratch& scratch, const Cache& cache, ByteView payload,
                                                     uint16_t fingerprint, Millis now) {
  frame_handled();
  scratch_ = &scratch;
  tether_rpc_wire_HostMessage in;  // zeroed by the decoder
  if (decode(payload, &in)) {
    if (const CacheHead* const kept = cached(cache, in.id, fingerprint)) {
      // A re-send: its first answer again, then the ack; nothing runs.
      if (kept->size != 0) send_again(in.id, ByteView(reinterpret_cast<const uint8_t*>(kept + 1), kept->size));
      send_ack(in.id, false);
    } else {
      const Outcome outcome = run(&in, now);
      // Only what ran is remembered: a refused message is looked at again when re-sent.
      if (!outcome.refused) remember(cache, in.id, fingerprint, outcome.answer);
      send_ack(in.id, outcome.refused);
      finish(&in);
    }
  }
  scratch_ = nullptr;
}

const DeviceCore::CacheHead* DeviceCore::cached(const Cache& cache, uint32_t id, uint16_t fingerprint) {
  const uint8_t* entry = reinterpret_cast<const uint8_t*>(cache.entries);
  for (uint8_t i = 0; i < cached_; ++i, entry += cache.stride) {
    const CacheHead* const head = reinterpret_cast<const CacheHead*>(entry);
    if (head->id == id && head->fingerprint == fingerprint) {
      add_one(counters_.link.duplicates);
      return head;
    }
  }
  return nullptr;
}

void DeviceCore::remember(const Cache& cache, uint32_t id, uint16_t fingerprint, ByteView answer) {
  CacheHead* const head =
      reinterpret_cast<CacheHead*>(reinterpret_cast<uint8_t*>(cache.entries) + cache_next_ * cache.stride);
  cache_next_ = static_cast<uint8_t>(cache_next_ + 1 == cache.depth ? 0 : cache_next_ + 1);
  if (cached_ < cache.depth) ++cached_;
  head->id = id;
  head->fingerprint = fingerprint;
  // An answer over the room (never: the limits are the schema's largest) is kept as none.
  const bool fits = answer.size() <= static_cast<size_t>(cache.stride - sizeof(CacheHead));
  head->size = static_cast<uint16_t>(fits ? answer.size() : 0);
  if (fits && !answer.empty()) memcpy(head + 1, answer.data(), answer.size());
}

void DeviceCore::start(uint32_t session_id, Millis now) {
  session_id_ = session_id;
  ping_.arm(now, kPingSilenceMs);
  in_failsafe_ = false;
  next_info_.arm(now, kInfoPeriodMs);
  Writer out(scratch_->out, max_out_);
  uint8_t* const body = open_field(out, kResetField);
  put_number(out, 1, session_id);  // ResetEvent.session
  out.close(body);
  send_message(out, true);
}

void DeviceCore::track_frame(bool was_in_frame, bool in_frame, Millis now) {
  if (!was_in_frame && in_frame) {
    partial_.arm(now, kPartialFrameMs);
    frame_handled();  // a new deadline: the next poll computes the earliest again
  } else if (was_in_frame && !in_frame) {
    partial_.disarm();
  }
}

void DeviceCore::poll_time(Millis now) {
  if (!in_failsafe_ && ping_.expired(now)) {  // the failsafe: every stream closed
    in_failsafe_ = true;
    add_one(counters_.link.failsafes);
    close_streams();
  }
  if (next_info_.expired(now)) {
    send_hello();
    next_info_.arm(next_info_.at(), kInfoPeriodMs);
    if (next_info_.expired(now)) next_info_.arm(now, kInfoPeriodMs);  // fell behind: no burst
  }
  for (uint8_t i = 0; i < slot_count_; ++i) {
    if (slots_[i].next.expired(now)) run_stream(i, now);
  }
  plan();
}

// The earliest deadline left (DeviceHello's is always armed): `poll` does nothing before it.
TETHER_RPC_OUT_OF_LINE void DeviceCore::plan() {
  Millis due = next_info_.at();
  if (!in_failsafe_) due = earlier(due, ping_);
  due = earlier(due, partial_);
  for (uint8_t i = 0; i < slot_count_; ++i) due = earlier(due, slots_[i].next);
  next_due_ = due;
}

TETHER_RPC_OUT_OF_LINE Millis DeviceCore::earlier(Millis due, Deadline deadline) {
  return deadline.armed() && tick_difference(deadline.at(), due) < 0 ? deadline.at() : due;
}

TETHER_RPC_OUT_OF_LINE bool DeviceCore::decode(ByteView payload, void* host_message) {
  if (decode_host_message(payload.data(), payload.size(), *static_cast<tether_rpc_wire_HostMessage*>(host_message))) {
    return true;
  }
  add_one(counters_.decode_errors);
  send_error(0, static_cast<uint16_t>(DeviceErrorCode::bad_envelope), kNotAHostMessage, true);
  return false;
}

DeviceCore::Outcome DeviceCore::run(const void* host_message, Millis now) {
  const tether_rpc_wire_HostMessage& in = *static_cast<const tether_rpc_wire_HostMessage*>(host_message);
  switch (in.which_body) {
    case tether_rpc_wire_HostMessage_hello_tag:
      send_hello();
      return Outcome{false, ByteView()};
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
        if (slots_[i].next.armed() && slots_[i].id == in.body.close.stream) slots_[i].next.disarm();
      }
      return Outcome{false, ByteView()};
    case tether_rpc_wire_HostMessage_ping_tag:
      ping_.arm(now, kPingSilenceMs);
      in_failsafe_ = false;
      return Outcome{false, ByteView()};
    case tether_rpc_wire_HostMessage_reset_tag:
      return Outcome{false, ByteView()};  // finish() restarts, after the ack
    default:
      return refuse(in.id, DeviceErrorCode::unknown_message);
  }
}

bool DeviceCore::decode_request(const Method& method, ByteView request) {
  return method.decode_request(request.data(), request.size(), scratch_->request);
}

TETHER_RPC_OUT_OF_LINE Service DeviceCore::service() const {
  Service service;
  copy_from_flash(&service, service_, sizeof service);
  return service;
}

TETHER_RPC_OUT_OF_LINE Method DeviceCore::method(const Service& service, uint8_t index) {
  Method method;
  copy_from_flash(&method, &service.methods[index], sizeof method);
  return method;
}

TETHER_RPC_OUT_OF_LINE DeviceCore::Outcome DeviceCore::call(uint32_t id, uint32_t method, ByteView request) {
  const Service s = service();
  if (method >= s.method_count) return refuse(id, DeviceErrorCode::unknown_method);
  const Method m = this->method(s, static_cast<uint8_t>(method));
  if (m.streaming) return refuse(id, DeviceErrorCode::not_unary);
  if (!decode_request(m, request)) return refuse(id, DeviceErrorCode::bad_request);
  memset(scratch_->reply, 0, scratch_->reply_size);
  add_one(counters_.calls);
  const Status status = m.handler(scratch_->request, scratch_->reply);
  if (!status.is_ok()) {
    add_one(counters_.handler_errors);
    return Outcome{false, send_error(id, status.code(), status.text(), status.text_in_flash())};
  }
  Writer out(scratch_->out, max_out_);
  uint8_t* const body = open_field(out, kReplyField);
  put_number(out, 1, id);                              // Reply.call
  uint8_t* const kept = out.position();
  put_message(out, 2, m.encode_reply, scratch_->reply);        // Reply.reply
  out.close(body);
  if (send_message(out) == 0) {  // it ran: the answer is the error, remembered like a reply
    return Outcome{false, send_error(id, static_cast<uint16_t>(DeviceErrorCode::reply_too_large), kReplyTooLarge, true)};
  }
  return Outcome{false, ByteView(kept, static_cast<size_t>(out.position() - kept))};
}

TETHER_RPC_OUT_OF_LINE DeviceCore::Outcome DeviceCore::open(uint32_t id, uint32_t method, ByteView request, uint32_t period, Millis now) {
  const Service s = service();
  if (method >= s.method_count) return refuse(id, DeviceErrorCode::unknown_method);
  const Method m = this->method(s, static_cast<uint8_t>(method));
  if (!m.streaming) return refuse(id, DeviceErrorCode::not_streaming);
  if (period == 0 || period < min_period_ms_ || period > 0xFFFFu) return refuse(id, DeviceErrorCode::period_too_short);
  if (request.size() > request_bytes_) return refuse(id, DeviceErrorCode::request_too_large);
  if (!decode_request(m, request)) return refuse(id, DeviceErrorCode::bad_request);
  // The method's own slot (a re-open replaces its stream), else a free one.
  uint8_t chosen = kNone;
  for (uint8_t i = 0; i < slot_count_; ++i) {
    if (!slots_[i].next.armed()) {
      if (chosen == kNone) chosen = i;
    } else if (slots_[i].method == method) {
      chosen = i;
      break;
    }
  }
  if (chosen == kNone) return refuse(id, DeviceErrorCode::streams_full);
  StreamSlot& slot = slots_[chosen];
  slot.id = id;
  slot.method = static_cast<uint8_t>(method);
  slot.period = static_cast<uint16_t>(period);
  slot.seq = 0;
  slot.request_size = static_cast<uint8_t>(request.size());
  memcpy(requests_ + chosen * request_bytes_, request.data(), request.size());
  slot.next.arm_at(now);  // the first message at the next poll
  return Outcome{false, ByteView()};
}

TETHER_RPC_OUT_OF_LINE void DeviceCore::run_stream(uint8_t index, Millis now) {
  StreamSlot& slot = slots_[index];
  const Service s = service();
  const Method m = method(s, slot.method);
  if (!decode_request(m, ByteView(requests_ + index * request_bytes_, slot.request_size))) {
    slot.next.disarm();  // it decoded when the stream opened: only a bug gets here
    send_error(slot.id, static_cast<uint16_t>(DeviceErrorCode::bad_request), kBadRequest, true);
    return;
  }
  memset(scratch_->reply, 0, scratch_->reply_size);
  const Status status = m.handler(scratch_->request, scratch_->reply);
  if (!status.is_ok()) {
    add_one(counters_.handler_errors);
    slot.next.disarm();
    send_error(slot.id, status.code(), status.text(), status.text_in_flash());
    return;
  }
  Writer out(scratch_->out, max_out_);
  uint8_t* const body = open_field(out, kStreamField);
  put_number(out, 1, slot.id);                          // StreamMessage.stream
  put_number(out, 2, slot.seq);                         // StreamMessage.seq
  put_message(out, 3, m.encode_reply, scratch_->reply);        // StreamMessage.message
  out.close(body);
  if (send_message(out) == 0) {
    slot.next.disarm();
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
    if (slots_[i].next.armed() && slots_[i].id == id) return true;
  }
  return false;
}

uint8_t DeviceCore::open_streams() const {
  uint8_t open = 0;
  for (uint8_t i = 0; i < slot_count_; ++i) {
    if (slots_[i].next.armed()) ++open;
  }
  return open;
}

void DeviceCore::close_streams() {
  for (uint8_t i = 0; i < slot_count_; ++i) slots_[i].next.disarm();
}

DeviceCore::Outcome DeviceCore::refuse(uint32_t id, DeviceErrorCode code) {
  add_one(counters_.refused);
  return Outcome{true, send_error(id, static_cast<uint16_t>(code), error_text(code), true)};
}

ByteView DeviceCore::send_error(uint32_t call, uint16_t code, const char* text, bool text_in_flash) {
  Writer out(scratch_->out, max_out_);
  uint8_t* const body = open_field(out, kErrorField);
  put_number(out, 1, call);                   // DeviceError.call
  uint8_t* const kept = out.position();
  put_number(out, 2, code);                   // DeviceError.code
  put_text(out, 3, text, text_in_flash);      // DeviceError.text
  out.close(body);
  if (send_message(out) == 0) return ByteView();
  return ByteView(kept, static_cast<size_t>(out.position() - kept));
}

void DeviceCore::send_again(uint32_t id, ByteView kept) {
  Writer out(scratch_->out, max_out_);
  // What follows the call field tells the body: Reply.reply (field 2, length-delimited) or
  // DeviceError.code (field 2, a varint: never zero in an error).
  uint8_t* const body = open_field(out, kept[0] == (2 << 3 | kDelimited) ? kReplyField : kErrorField);
  put_number(out, 1, id);                     // Reply.call / DeviceError.call
  out.raw(kept.data(), kept.size());
  out.close(body);
  send_message(out);
}

void DeviceCore::send_ack(uint32_t id, bool refused) {
  Writer out(scratch_->out, max_out_);
  uint8_t* const body = open_field(out, kAckField);
  put_number(out, 1, id);                     // Ack.id
  put_number(out, 2, refused ? 1 : 0);        // Ack.refused
  out.close(body);
  send_message(out);
}

void DeviceCore::send_hello() {
  Writer out(scratch_->out, max_out_);
  uint8_t* const body = open_field(out, kHelloField);
  const Service s = service();
  put_fixed64(out, 1, s.schema_hash);           // DeviceHello.schema_hash
  put_number(out, 2, session_id_);              // DeviceHello.session
  put_number(out, 3, max_payload_);             // DeviceHello.max_payload
  put_number(out, 4, s.method_count);           // DeviceHello.methods
  out.close(body);
  send_message(out);
}

size_t DeviceCore::send_message(const Writer& message, bool leading_delimiter) {
  const size_t size = message.size();
  if (size == 0) {
    add_one(counters_.send_failures);
    return 0;
  }
  send_payload(ByteView(scratch_->out, size), leading_delimiter);
  return size;
}

void DeviceCore::send_payload(ByteView payload, bool leading_delimiter) {
  const Result<size_t> framed = proxy::encode_frame(payload, proxy::Integrity::crc16, leading_delimiter,
                                                    MutableByteView(scratch_->frame, proxy::max_frame_size(max_out_)));
  if (!framed.ok()) {
    add_one(counters_.send_failures);
    return;
  }
  sink_.write(sink_.context, ByteView(scratch_->frame, framed.value()));
}

void DeviceCore::finish(const void* host_message) {
  const tether_rpc_wire_HostMessage& in = *static_cast<const tether_rpc_wire_HostMessage*>(host_message);
  if (in.which_body == tether_rpc_wire_HostMessage_reset_tag && restart_ != nullptr) restart_(restart_context_);
}


#if defined(__AVR__)
namespace {
// The images keep their device in a global with no start-up code (constant-initialised): this does not
// compile when a constructor on the way stops being constant. AVR only: the host's CRC is not a literal type.
const Method kConstantMethods[] TETHER_IN_FLASH = {{nullptr, nullptr, nullptr, false}};
const Service kConstantService TETHER_IN_FLASH = {0, kConstantMethods, 1};
constexpr Device<> kConstantInitialisedDevice(kConstantService, FrameSink{nullptr, nullptr});
constexpr Device<> kUnboundDevice;
}  // namespace
#endif

}  // namespace device
}  // namespace rpc
}  // namespace tether
