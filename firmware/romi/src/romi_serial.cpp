// Tether's Romi device (romi_serial.hpp): envelope decoding, exactly-once cache, dispatch, replies.
#include "tether/romi/device/romi_serial.hpp"

#include <string.h>

#include "tether/core/crc.hpp"
#include "tether/romi/device/array_text.hpp"
#include "tether/romi/encoder.hpp"

namespace tether {
namespace romi {
namespace device {

static_assert(RomiSerial::kPayloadCapacity == kMaxDevicePayload && RomiSerial::kReplyCapacity == 72,
              "RomiSerial keeps the spec's maxima");
#if defined(__AVR__)
// What romi_serial.hpp says a device takes ("Memory", "Sizing a device").
static_assert(sizeof(RomiSerial) == 321 && sizeof(BasicRomiSerial<37, 16>) == 223 &&
                  sizeof(BasicRomiSerial<1, 14>) == 2 * 1 + 14 + 133,
              "a device is 2 x PayloadCapacity + ReplyCapacity + 133 bytes: update the header's figures");
#endif

constexpr uint8_t RomiSerialBase::kMaxPayloadCapacity;
constexpr uint8_t RomiSerialBase::kMinPayloadCapacity;
constexpr uint8_t RomiSerialBase::kMaxReplyCapacity;
constexpr uint8_t RomiSerialBase::kMinReplyCapacity;
constexpr Duration RomiSerialBase::kRequestDeadlineMs;
constexpr Duration RomiSerialBase::kReplyCacheLifetimeMs;
constexpr uint8_t RomiSerialBase::kFrameMetadata;

namespace {

ByteView text_view(const char* text) { return ByteView::from_chars(text, text == nullptr ? 0 : strlen(text)); }

}  // namespace

RomiSerialBase::RomiSerialBase(IInputStream& in, IOutputStream& out, const MessageHandler* handlers, uint8_t count,
                               ClockFunction clock, uint8_t* buffers, uint8_t payload_capacity,
                               uint8_t reply_capacity)
    : RomiSerialState() {  // all zero (see there)
  in_ = &in;
  out_ = &out;
  handlers_ = handlers;
  handler_count_ = count;
  clock_ = clock;
  // The buffers: the request frame (payload and metadata), then the reply, then the cache's key.
  decoder_.use_buffer(buffers, static_cast<uint8_t>(payload_capacity + kFrameMetadata));
  reply_capacity_ = reply_capacity;
  decoder_.count_into(counters_.link);
}

void RomiSerialBase::set_handlers(const MessageHandler* handlers, uint8_t count) {
  handlers_ = handlers;
  handler_count_ = count;
  // A frame awaiting its '\n' was prepared with the old table: it is looked up in the new one.
  if (decoder_.awaiting_end()) prepare(decoder_.frame());
}

inline void RomiSerialBase::receive_special(uint8_t byte) {
  if (byte == '\n' && decoder_.awaiting_end()) {
    // This '\n' completes a frame: the response's '#' (see receive) leaves first, before the call
    // into the out-of-line path, as the first thing the turnaround does.
    out_->write('#');
    hash_sent_ = true;
  } else if (byte == '#') {  // after the '\n' test: not on the turnaround's path
    begin_request();
    return;
  }
  receive(byte);
}

void RomiSerialBase::handle_input() {
  if (call_ != Call::none) return;
  // One clock read per call and one per handler run, none per byte (the AVR's hot path): the bytes
  // waiting arrived before the read, and only a handler takes long enough to make `now` stale.
  // Timeouts are checked when `now` changes, not per byte: at one `now`, nothing a byte does makes a
  // deadline pass (a frame's deadline starts at `now`, the cache's lifetime after the reply). Every
  // `now_` the device takes was checked (here, in handle_byte, or after a handler in dispatch), so
  // a call within the same millisecond as the last one has nothing to check (and nothing to store).
  const Millis now = clock_ != nullptr ? clock_() : 0;
  if (now != now_) handle_timeouts(now);  // sets now_
  // Bytes come in batches (one virtual call each), handled one by one in arrival order. A byte inside
  // a frame's body is stored by the decoder's inline path and nothing else happens to it; only the
  // frame's '#', '\r' and '\n' (and bytes outside frames) take the out-of-line path.
  uint8_t batch[16];
  for (uint8_t count = sizeof(batch); count == sizeof(batch);) {
    // A batch that did not fill up drained the stream (read_some takes every byte waiting up to its
    // capacity): no second call just to learn that. Bytes arriving meanwhile wait for the next call.
    count = in_->read_some(batch, sizeof(batch));
    const uint8_t* next = batch;
    for (uint8_t left = count; left != 0;) {
      // A run of body bytes in one tight loop, then the byte that ended it.
      const uint8_t run = decoder_.feed_body_run(next, left);
      next += run;
      left = static_cast<uint8_t>(left - run);
      if (left == 0) break;
      // After a handler nothing is left to time out (its frame ended the partial-frame deadline, the
      // cache's lifetime starts now): the later bytes of the batch are only dated by its reply (now_).
      receive_special(*next++);
      --left;
    }
  }
}

void RomiSerialBase::handle_timeouts(Millis now) {
  if (call_ != Call::none) return;
  now_ = now;  // the bytes that follow arrived at `now` at the earliest
  // The cached reply outlives every re-send of its request (they all come within the host's call
  // budget); after that, the same id and bytes are a new session's command and must run.
  expire_cache();
  // The deadline of the request being received, if there is one (the frame's '#' armed it).
  if (!decoder_.receiving() || !tick_reached(now, frame_deadline_)) return;
  add_one(counters_.link.partial_timeouts);
  // The request being received is too late: drop it, say so, wait for the next '#'.
  decoder_.abandon();  // the frame now says the partial opcode, id 0: what the response echoes
  send_code(Error::controller_timeout, false);
}

void RomiSerialBase::expire_cache() {
  if (cache_expired(now_)) cached_request_size_ = 0;  // nothing cached
}

void RomiSerialBase::handle_byte(uint8_t byte, Millis now) {
  if (call_ != Call::none) return;
  handle_timeouts(now);  // sets now_; a byte arriving after the deadline does not extend it
  if (!decoder_.feed_body(byte)) receive_special(byte);
}

void RomiSerialBase::begin_request() {
  frame_deadline_ = now_ + kRequestDeadlineMs;  // a new '#' restarts the window
  decoder_.feed_hash();
}

void RomiSerialBase::receive(uint8_t byte) {
  // Never a '#' (receive_special takes those: begin_request).
  const DecodeStatus status = decoder_.feed_special(byte);
  if (status == DecodeStatus::more) {
    // The frame's '\r' checked out and only its '\n' is missing: parse it now, so the
    // '\n' leaves only the cache lookup and the dispatch (the turnaround).
    if (byte == '\r' && decoder_.awaiting_end()) prepare(decoder_.frame());
    return;
  }
  // A frame or an error: a response follows, and every frame the device sends (the response, or a
  // log line a handler sends before it) starts with '#'. That byte leaves now, before the lookup, the
  // parse checks and the handler: the turnaround is this path, not the handler's.
  if (!hash_sent_) {
    out_->write('#');
    hash_sent_ = true;
  }
  const Frame& frame = decoder_.frame();
  if (status == DecodeStatus::error) {
    send_code(decoder_.error(), false);  // the frame's opcode so far, id 0 when none was read
    return;
  }
  handle_frame(frame);
}

void RomiSerialBase::prepare(const Frame& frame) {
  if (frame.log) return;
  Error parsed = parse_request(frame.payload, request_);
  if (parsed == Error::no_error) {
    const MessageHandler* handler = nullptr;
    for (uint8_t i = 0; i < handler_count_; ++i) {
      if (handlers_[i].opcode == request_.opcode) {
        handler = &handlers_[i];
        break;
      }
    }
    if (handler == nullptr || handler->callback == nullptr) {
      parsed = Error::unknown_opcode;
    } else if (request_.argument_count != handler->number_arguments) {
      parsed = Error::bad_number_of_arguments;
    } else if (request_.has_string != handler->requires_string) {
      parsed = handler->requires_string ? Error::missing_string : Error::bad_string;
    }
    handler_ = handler;
  }
  parsed_ = static_cast<int8_t>(parsed);
}

void RomiSerialBase::handle_frame(const Frame& frame) {
  if (frame.log) {
    // "#!text": '!' is no opcode (a log frame's opcode is '_'); the reference's message parser says the same.
    send_code(Error::invalid_opcode, false);
    return;
  }
  if (!frame.manual && is_repeat(frame.id, frame.payload)) {
    // Exactly-once: the same response again (the reply buffer holds it: nothing else writes there),
    // the handler does not run.
    add_one(counters_.link.duplicates);
    start_frame();
    // Its size, from the frame itself: its ':' is the first after the opcode (form_response turns a
    // body's ':' into '-'), and 6 bytes follow it (id, CRC, "\r\n").
    const uint8_t* const reply = this->reply();
    uint8_t colon = 2;
    while (reply[colon] != ':') ++colon;
    write(ByteView(reply + 1, colon + 6u));
    return;
  }
  dispatch(frame);
}

bool RomiSerialBase::is_repeat(uint8_t id, ByteView payload) {
  // The exact key: id first (a host's next call has another id, so the bytes are compared only for a
  // re-send or a new host session that starts with the same id), then every byte of the payload.
  // (A cached request has an opcode at least: size 0 is an empty cache, which no payload matches.)
  if (id != cached_id_ || payload.size() != cached_request_size_) return false;
  const uint8_t* const key = cached_request();
  for (uint8_t i = 0; i < cached_request_size_; ++i) {
    if (payload[i] != key[i]) return false;
  }
  return true;
}

void RomiSerialBase::dispatch(const Frame& frame) {
  const uint8_t id = frame.id;  // 0 for a manual frame
  // prepare() parsed the frame and looked its handler up at the '\r' (a parsed request's opcode is
  // the frame's).
  if (parsed_ != 0) {
    send_code(static_cast<Error>(parsed_), false);
    return;
  }
  const MessageHandler* handler = handler_;

  // While the handler runs (and until its reply is out), the request's opcode is request_'s and its id
  // and manual flag the frame's: no byte reaches the decoder during the call.
  call_ = Call::awaiting_reply;
  add_one_inline(counters_.executed);  // every request's: inline (add_one's call costs ~25 cycles on the AVR)
  // The string argument is terminated in place in the frame: its closing '"' is the handler's NUL, and
  // is put back after the call (the frame's bytes become the cache's key below).
  const char* string = "";
  uint8_t* quote = nullptr;
  if (request_.has_string) {
    string = reinterpret_cast<const char*>(request_.string_view.data());
    // The decoder's own buffer (not const): the view is const only to the decoder's readers.
    quote = const_cast<uint8_t*>(request_.string_view.end());
    *quote = '\0';
  }
  handler->callback(this, request_.arguments, string);
  if (quote != nullptr) *quote = '"';
  const bool replied = call_ == Call::replied;
  call_ = Call::none;
  if (!replied) {
    add_one(counters_.silent_handlers);
    send_code(Error::no_reply, true);
  }
  // The handler may have taken a while: the cache's lifetime starts when the reply went out.
  if (clock_ != nullptr) now_ = clock_();
  // Remember what the request got, so a re-sent copy gets it again (manual requests have no id).
  if (!frame.manual) {
    // The key is the request itself (the reply stays in the reply buffer). A complete frame's payload
    // always fits: the decoder holds at most the payload capacity's characters before the ':'.
    // The loop's bounds in locals: a store through `key` could alias the members they come from, which
    // would then be loaded again for every byte.
    const uint8_t size = static_cast<uint8_t>(frame.payload.size());
    const uint8_t* const payload = frame.payload.data();
    uint8_t* const key = cached_request();
    cached_id_ = id;
    cached_request_size_ = size;
    for (uint8_t i = 0; i < size; ++i) key[i] = payload[i];
    cache_expires_at_ = now_ + kReplyCacheLifetimeMs + 1;  // expired strictly after the lifetime
  } else {
    // The new `now_` is checked like handle_input's (this request's own deadline ended with its frame):
    // the cache kept through a manual request may have expired during its handler.
    expire_cache();
  }
}

// The handlers' interface forwards to the one implementation (handler.hpp: not virtual, so unused
// replies are not linked).
void IRomiSerial::send_ok() { static_cast<RomiSerialBase*>(this)->send_ok(); }
void IRomiSerial::send_error(int code, const char* message) { static_cast<RomiSerialBase*>(this)->send_error(code, message); }
void IRomiSerial::send(const char* message) { static_cast<RomiSerialBase*>(this)->send(message); }
void IRomiSerial::log(const char* text) { static_cast<RomiSerialBase*>(this)->log(text); }

void RomiSerialBase::send_ok() { handler_reply(ByteView::from_literal("[0]")); }

void RomiSerialBase::send_error(int code, const char* message) {
  if (call_ != Call::awaiting_reply) {
    add_one(counters_.extra_replies);
    return;
  }
  ArrayText<kMaxReplyCapacity> body;
  body.add_int(code);
  if (message != nullptr) body.add_string(message);
  if (!body.ok()) {
    // The body alone does not fit the largest reply buffer, so the frame would not fit this one either.
    call_ = Call::replied;
    add_one(counters_.replies_too_long);
    send_code(Error::reply_too_long, true);
    return;
  }
  handler_reply(text_view(body.c_str()));
}

void RomiSerialBase::send(const char* message) {
  if (message == nullptr) {
    if (call_ == Call::awaiting_reply) return;  // no reply: the device answers -20 after the handler
    add_one(counters_.extra_replies);
    return;
  }
  handler_reply(text_view(message));
}

void RomiSerialBase::handler_reply(ByteView body) {
  if (call_ != Call::awaiting_reply) {
    add_one(counters_.extra_replies);
    return;
  }
  call_ = Call::replied;
  // Checked in the view's width: a handler's text may be longer than 255 bytes.
  if (body.size() + kResponseOverhead > reply_capacity_) {
    send_too_long();
    return;
  }
  send_response(body.data(), static_cast<uint8_t>(body.size()));
}

void RomiSerialBase::send_too_long() {
  add_one(counters_.replies_too_long);
  send_code(Error::reply_too_long, true);  // fits every reply buffer
}

void RomiSerialBase::log(const char* text) {
  start_frame();
  out_->write('!');
  if (text != nullptr) {
    for (; *text != '\0'; ++text) out_->write(*text == '\r' || *text == '\n' ? ' ' : *text);
  }
  write(ByteView::from_literal(":xxxx\r\n"));
}

void RomiSerialBase::send_response(const uint8_t* body, uint8_t size) {
  if (decoder_.frame().manual) {
    send_uncached(body, size);
    return;
  }
  // A handler's reply to a request with an id: the cache's copy.
  send_frame(body, size, reply());
}

void RomiSerialBase::send_uncached(const uint8_t* body, uint8_t size) {
  // Manual requests are not cached: the reply buffer keeps the cached reply. Every reply passed the
  // device's capacity, at most kMaxReplyCapacity.
  uint8_t frame[kMaxReplyCapacity];
  send_frame(body, size, frame);
}

void RomiSerialBase::send_frame(const uint8_t* body, uint8_t size, uint8_t* frame) {
  // The frame's first byte leaves at once (if receive() has not sent it already): the UART sends it (a
  // byte time, ~1400 cycles at 115200) while the rest is formed, which then follows it.
  start_frame();
  const Frame& request = decoder_.frame();
  size = form_response(request.opcode, body, size, request.id, frame);
  write(ByteView(frame + 1, size - 1u));
}

void RomiSerialBase::send_code(Error code, bool handler_reply) {
  if (!handler_reply) add_one(counters_.rejected);
  // Protocol codes are -1..-99: "[-" one or two digits "]", formed here without the general number
  // formatter (its 32-bit digit loop would be linked into every image for this alone), and not kept
  // as literals either (avr-gcc copies string literals to RAM: "[-20]" and "[-31]" were 12 bytes).
  uint8_t magnitude = static_cast<uint8_t>(-static_cast<int16_t>(code));
  uint8_t body[5] = {'[', '-'};
  uint8_t size = 2;
  if (magnitude >= 10) {
    uint8_t tens = 0;
    while (magnitude >= 10) {
      magnitude = static_cast<uint8_t>(magnitude - 10u);
      ++tens;
    }
    body[size++] = static_cast<uint8_t>('0' + tens);
  }
  body[size++] = static_cast<uint8_t>('0' + magnitude);
  body[size++] = ']';
  if (handler_reply) {
    send_response(body, size);  // remembered like any handler reply (unless manual)
  } else {
    send_uncached(body, size);  // the reply buffer keeps the cached reply
  }
}

void RomiSerialBase::start_frame() {
  if (hash_sent_) {
    hash_sent_ = false;
  } else {
    out_->write('#');
  }
}

void RomiSerialBase::write(ByteView bytes) { out_->write_all(bytes.data(), static_cast<uint8_t>(bytes.size())); }

}  // namespace device
}  // namespace romi
}  // namespace tether
