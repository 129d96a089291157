/// @file romi_serial.hpp
/// Tether's Romi device: the firmware side of the Romi text protocol, with the handler-table API of the
/// reference RomiSerial library and without its known defects (../shared/specs/romi.md, B1..B7).
///
/// ## Use
///
///     UartStream<Serial> serial;                               // or ArduinoSerial serial(Serial);
///     RomiSerial romi(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));
///     // or, with buffers sized to the handlers' requests and replies ("Sizing a device" below):
///     // BasicRomiSerial<16, 16> romi(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));
///     ...
///     for (;;) { romi.handle_input(); idle<Serial>(); }        // Arduino: loop() { romi.handle_input(); }
///
/// `handle_input()` reads every byte waiting, answers each complete request and drops a request that is
/// not complete 1 s after its '#'. Handlers are described in handler.hpp (their contract: one reply each).
///
/// ## What the device answers (wire behaviour)
///
/// Every response is `#` opcode `[` code ... `]` `:` id crc `\r\n`.
///   1. Bytes before '#' are ignored; '#' (re)starts a request anywhere.
///   2. A damaged frame gets `[code]` with the envelope code -1..-7 (-1 too long, -2 bad id, -3 bad CRC
///      digits, -4 CRC mismatch, -5 expected end, -6 missing metadata, -7 bad `xxxx`), the frame's opcode
///      (`_` when its first character is not one) and the id read so far (0 when none). A frame too long
///      for the buffer (a payload over the device's `PayloadCapacity`) gets exactly ONE `[-1]` and nothing
///      else: the rest of it is skipped (B1).
///   3. A good frame whose id and bytes equal those of the last request whose handler ran, arriving at
///      most `kReplyCacheLifetimeMs` (2 s, the host's call budget) after that request's response was
///      sent, is answered with that response again, byte for byte, without running the handler
///      (exactly-once, B3; the reference answers -15 instead). -15 is never sent. Later it runs: a new
///      host session may start with the previous one's last id and command. A fresh device knows no
///      id, so the first request is never a repeat whatever its id (B6).
///   4. Manual requests (`:xxxx`, typed in a terminal) are never treated as repeats and are not
///      remembered: they neither hit nor poison the cache (B6). Their response carries id 00.
///   5. Otherwise the payload is parsed: -8..-14 on a syntax error (`[code]`, the frame's opcode and id).
///   6. Then, in this order: unknown opcode -16, wrong number of integers -17, missing string -18,
///      string given but not expected -19.
///   7. Then the handler runs; no reply from it: -20. Its response (or the -20) is remembered for 3.
///   8. A request not complete 1 s after its '#' (`kRequestDeadlineMs`, the spec's controller timeout,
///      B7) is dropped and answered with `[-30]` (opcode of the partial frame or `_`, id 00); the device
///      then waits for the next '#'.
///   9. A response that does not fit `kReplyCapacity` bytes is replaced by `[-31]`.
///  10. A log frame received (`#!...`) is answered like the reference does: -14 (invalid opcode), `_`.
/// Every response echoes the opcode and id of the frame it answers (the reference echoes the last good
/// opcode on errors).
///
/// ## Memory (no heap; ATmega328P figures, avr-gcc 5.4 -Os)
/// One `RomiSerial` is 321 bytes of static RAM (measured: its symbol in romi-blink.elf), all bounded at
/// compile time:
///   - request buffer: `PayloadCapacity` + 5 = 63 bytes hold the frame between '#' and '\r' (58 payload
///     characters, ':', 4 metadata characters: every request a reference host can send), and the
///     decoder's state 20;
///   - parsed request: 31 bytes (12 int16 arguments; the string argument stays in the request buffer,
///     where its closing quote is the handler's NUL during the call: a copy would be 33 bytes more);
///   - reply buffer: `ReplyCapacity` = 72 bytes; it is also the reply cache: only handler replies to
///     requests with an id are formed there;
///   - the cache's key: the exact payload of the request that reply answers (`PayloadCapacity` = 58
///     bytes, its id and size in the state; a CRC-16 of the payload in 2 bytes was cheaper in RAM, but two
///     requests can share it);
///   - counters: 48 bytes (12, each 32-bit: `DeviceCounters`); pointers, the clock's last reading, the two
///     deadlines and state: 29 bytes.
/// The floor, for what this class promises: the frame being received (63), the key of the last one
/// that ran (58 + id + size) and its reply (65 of the 72 at least: a reference host accepts 65-byte
/// replies) must all be held at once, because a damaged copy of a re-sent request may arrive between
/// the reply and the good copy (exactly-once then needs the key intact: a key overwritten in place by
/// a diverging frame would run the good copy twice) = 188 bytes, plus the 48 bytes of 32-bit counters.
/// A device whose handlers take shorter requests and send shorter replies needs less of it: see below.
///
/// ## Sizing a device
/// `BasicRomiSerial<PayloadCapacity, ReplyCapacity>` is the same device with buffers for the requests
/// and replies of its handlers only: 2 x `PayloadCapacity` + `ReplyCapacity` + 133 bytes (`RomiSerial`,
/// `<58, 72>`: 321). Every size runs the same code (one copy in an image, whatever sizes it declares),
/// and behaves as `RomiSerial` for every request that fits. Choose:
///   - `PayloadCapacity` (1..58): the longest payload, between '#' and ':', of a request any handler
///     accepts. A payload is the opcode (1), then, when there are arguments, '[' and ']' (2) around the
///     arguments separated by ',' (one fewer than the arguments); an integer argument is at most 6
///     characters ("-32768"), a string at most 2 + its longest length (its quotes; at most 32). E.g. a
///     handler of two integers: 1 + 2 + 6 + 1 + 6 = 16; of one string of up to 32 characters:
///     1 + 2 + 34 = 37; of no argument: 1 (3 for "a[]", which the device takes too). A longer request
///     is answered `[-1]` (too long, rule 2: the frame's opcode, id 00, nothing else), where `RomiSerial`
///     would have parsed it and answered -8..-19 (e.g. -17 for too many integers): size for what the
///     hosts send, or a host that sends more gets -1 instead of the dispatcher's error.
///   - `ReplyCapacity` (14..72): 9 (`#`, opcode, ':', id, CRC, "\r\n") + the longest reply body a
///     handler sends: `send_ok` "[0]" 3, `send(text)` the text, `send_error(code, message)`
///     `[code,"message"]` (2 + the code's digits and sign + 3 + the message). At least 14, for the
///     device's own `[-NN]`. A longer reply is replaced by `[-31]` (rule 9), remembered like the reply
///     it replaces.
/// romi-bench (handlers a, e, c[2 integers], d[string of up to 32]) declares
/// `BasicRomiSerial<37, 16>`: d's 37 characters, e's `#e[0,1,2]:iicc\r\n` 16 bytes; 223 bytes of RAM
/// against `RomiSerial`'s 321. Checked at compile time: capacities outside the ranges do not build.
/// A `RomiSerialBase&` refers to a device of any size (e.g. code that polls several).
///
/// ## Time and stack
/// Time (ATmega328P cycles, benchmarks/avr_cycle_report.cpp): the clock is read once per
/// `handle_input()` and once after each handler, never per byte; timeouts are checked when the clock
/// moved. Bytes are read in batches (`IInputStream::read_some`; a batch short of 16 ends the call); the
/// body bytes of a frame go through the decoder's run loop (`Decoder::feed_body_run`) and nothing else;
/// a frame is checked, parsed and matched to its handler at its '\r'; at its '\n' the response's '#' is
/// sent first (every frame the device sends starts with it), then the cache lookup (the id, then the
/// bytes) and the call; the rest of a reply is formed with its CRC in one pass, in place in the cache's
/// copy. Stack: a request's dispatch needs ~150 bytes plus what the handler uses (`send_error` builds its
/// text in a 72-byte buffer; a manual request's reply and an error reply are formed on the stack, 72 and
/// 14 bytes, to leave the cached reply alone). Measured before that change: 155 bytes (romi-blink), 221
/// (romi-test), interrupts included.
/// Nothing is allocated at run time. Flash: ~5 KB for the device and the codec it uses (romi-bench).
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/time.hpp"
#include "tether/romi/device/handler.hpp"
#include "tether/romi/device/streams.hpp"
#include "tether/romi/decoder.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/romi/errors.hpp"
#include "tether/romi/limits.hpp"
#include "tether/romi/request_parser.hpp"

namespace tether {
namespace romi {
namespace device {

/// A millisecond clock (wrapping 32-bit counter), e.g. Arduino's `millis`.
typedef uint32_t (*ClockFunction)();

/// The platform's millisecond clock, chosen at link time: Arduino's `millis()` in Arduino builds
/// (src/clock_arduino.cpp), `tether::firmware::millis()` on Tether's runtime (src/clock_tether_runtime.cpp).
/// Other platforms (host tests) pass their own clock to `RomiSerial` and do not link either.
uint32_t default_clock();

/// The link counters a device keeps: those of `LinkCounters` it increments, under the same names and
/// with the same meaning (the other five stay 0 on a device: 28 bytes of RAM instead of 48). Counters
/// only grow (wrap at 2^32). Converts to `LinkCounters` for code that reads every codec the same way.
struct DeviceLinkCounters {
  uint32_t frames_ok = 0;         ///< Well-formed request frames.
  uint32_t crc_errors = 0;        ///< Frames answered -4 (CRC mismatch).
  uint32_t framing_errors = 0;    ///< Frames answered -2, -3, -5, -6, -7.
  uint32_t oversize_frames = 0;   ///< Frames answered -1 (too long).
  uint32_t resyncs = 0;           ///< Garbage or a half frame skipped.
  uint32_t partial_timeouts = 0;  ///< Requests dropped at their deadline (answered -30).
  uint32_t duplicates = 0;        ///< Repeats answered from the reply cache.

  /// These counters as `LinkCounters` (the fields a device does not count are 0).
  operator LinkCounters() const {
    LinkCounters link;
    link.frames_ok = frames_ok;
    link.crc_errors = crc_errors;
    link.framing_errors = framing_errors;
    link.oversize_frames = oversize_frames;
    link.resyncs = resyncs;
    link.partial_timeouts = partial_timeouts;
    link.duplicates = duplicates;
    return link;
  }
};

/// Diagnostics of one device. Counters only grow (wrap at 2^32). Plain data: copy it for a snapshot.
struct DeviceCounters {
  /// Link counters, named as in every Tether codec's `LinkCounters`.
  DeviceLinkCounters link;
  /// Handlers run (each at most once per request).
  uint32_t executed = 0;
  /// Error responses the device built itself: -1..-14, -16..-19, -30 (not -20/-31, counted below).
  uint32_t rejected = 0;
  /// Handlers that returned without replying (answered -20).
  uint32_t silent_handlers = 0;
  /// `send_*` calls ignored: a handler's second reply, or a reply outside any handler.
  uint32_t extra_replies = 0;
  /// Responses replaced by -31 because they did not fit `RomiSerial::kReplyCapacity`.
  uint32_t replies_too_long = 0;
};

namespace detail {

/// The state of a `RomiSerialBase`: all zero bytes at first, but for what the constructor sets (the
/// streams, the handler table, the clock, the decoder's counters and buffer, the reply capacity). The
/// device value-initializes it, so it is zero-filled in one loop: on the AVR the
/// members' own zero initializers then cost nothing, instead of one store per member (4 bytes of flash
/// each): romi-bench's static constructor went from 296 to 190 bytes, and to 116 with the decoder and the
/// pointers inside. The buffers whose sizes are the device's capacities are not here but in
/// `BasicRomiSerial` (static storage is zero anyway, and the device writes them before reading them).
struct RomiSerialState {
  enum class Call : uint8_t { none, awaiting_reply, replied };

  // The small members first: a handler's reply path reaches them through `this` with a displacement,
  // which the AVR's ldd/std take only up to 63.
  Call call_;  // a handler's call: none outside one, awaiting_reply until it replies, then replied
  bool hash_sent_;  // the '#' of the next frame out left already (receive(), at a frame's end)
  uint8_t reply_capacity_;  // bytes of the reply buffer (the device's ReplyCapacity)
  // The frame awaiting its '\n' (every complete frame passed its '\r', where prepare() ran): the Error of
  // parse_request for request_, then of the dispatch check; its handler when that is no_error.
  int8_t parsed_;
  const MessageHandler* handler_;
  // When the bytes being handled arrived; after a handler, when its reply went out. Timeouts were
  // checked at this instant (handle_input checks them when the clock differs).
  Millis now_;
  // The request being received must end by then: set at its '#', in force while the decoder is
  // receiving() (from that '#' to the byte that completes or fails the frame).
  Millis frame_deadline_;
  Millis cache_expires_at_;  // when the cached reply stops answering repeats (if there is one)
  // Id and size of the request whose reply is in the reply buffer (the cached reply: only handler
  // replies to requests with an id are written there); its bytes are in the key buffer. Size 0:
  // nothing cached (a request that ran a handler has an opcode at least).
  uint8_t cached_id_;
  uint8_t cached_request_size_;
  // Default-constructed inside the zero-filled state (its members' zero initializers then cost no
  // code), pointed at counters_.link and at the device's buffers by the device's constructor. Within
  // the first 64 bytes too: the reply buffer's address is computed from its buffer's.
  Decoder<kRunTimeCapacity, DeviceLinkCounters> decoder_;
  // The request being handled (its arguments are the handler's `args`; its string stays in the frame).
  ParsedRequest request_;
  DeviceCounters counters_;
  IInputStream* in_;
  IOutputStream* out_;
  const MessageHandler* handlers_;
  uint8_t handler_count_;
  ClockFunction clock_;
};

}  // namespace detail

/// What every Romi device has, whatever its capacities: the whole behaviour (the file comment) and the
/// code, shared by the `BasicRomiSerial` of every size in an image. Not constructed directly: declare a
/// `RomiSerial` or a `BasicRomiSerial<PayloadCapacity, ReplyCapacity>`; a `RomiSerialBase&` refers to
/// either (e.g. a function that polls devices of several sizes).
/// Not copyable. Not reentrant: use it from the main loop only (never from an interrupt handler).
class RomiSerialBase : public IRomiSerial, private detail::RomiSerialState {
 public:
  /// Largest `PayloadCapacity`: 58, the longest payload a reference host sends (`kMaxDevicePayload`;
  /// Tether hosts send at most 56).
  static constexpr uint8_t kMaxPayloadCapacity = kMaxDevicePayload;
  /// Smallest `PayloadCapacity`: 1, requests that are an opcode alone (`#a:<id><crc>`).
  static constexpr uint8_t kMinPayloadCapacity = 1;
  /// Largest `ReplyCapacity`: 72 >= 65, the longest response a reference host accepts (57 characters
  /// between '#' and ':'); e.g. `[0,` + eleven 5-digit values fits.
  static constexpr uint8_t kMaxReplyCapacity = 72;
  /// Smallest `ReplyCapacity`: 14, the device's own responses (`[-NN]`, e.g. `#a[-16]:01cc\r\n`).
  static constexpr uint8_t kMinReplyCapacity = static_cast<uint8_t>(5 + kResponseOverhead);
  /// Time from a request's '#' to its '\n' before it is dropped with -30 (the spec's 1 s).
  static constexpr Duration kRequestDeadlineMs = kControllerDeadlineMs;
  /// How long after it was sent a reply answers a repeat of its request: the host's call budget (2 s),
  /// within which every re-send of a call arrives. Later, the same id and bytes are a new command (a new
  /// host session that happens to start with the last id) and run.
  static constexpr Duration kReplyCacheLifetimeMs = kHostCallBudgetMs;

  /// Not copyable: handlers and streams are bound to this instance.
  RomiSerialBase(const RomiSerialBase&) = delete;
  /// Not assignable.
  RomiSerialBase& operator=(const RomiSerialBase&) = delete;

  /// Replaces the handler table (not from inside a handler).
  void set_handlers(const MessageHandler* handlers, uint8_t count);

  /// Reads and handles every byte waiting on the input stream, then checks the request deadline.
  /// Call it from the main loop (Arduino: `loop()`), as often as possible: the deadline is checked
  /// only here. Returns at once when called from inside a handler (contract 7).
  void handle_input();

  /// Sans-I/O entry: handles one received byte at `now` (ms on the same clock as the deadline).
  /// `handle_input()` does the same for each byte. Ignored when called from inside a handler. With a
  /// clock, the reply's send time (start of its cache lifetime) is read from it after the handler ran;
  /// without one it is `now`.
  void handle_byte(uint8_t byte, Millis now);
  /// Sans-I/O entry: answers -30 if the request being received is past its deadline at `now`, and
  /// forgets the cached reply once it is older than `kReplyCacheLifetimeMs`.
  void handle_timeouts(Millis now);

  /// See `IRomiSerial::send_ok`.
  void send_ok();
  /// See `IRomiSerial::send_error`.
  void send_error(int code, const char* message);
  /// See `IRomiSerial::send`.
  void send(const char* message);
  /// See `IRomiSerial::log`.
  void log(const char* text);

  /// The diagnostics counters.
  const DeviceCounters& counters() const { return counters_; }
  /// True while a handler runs.
  bool in_handler() const { return call_ != Call::none; }
  /// This device's `PayloadCapacity`: longer requests are answered -1.
  uint8_t payload_capacity() const { return static_cast<uint8_t>(decoder_.capacity() - kFrameMetadata); }
  /// This device's `ReplyCapacity`: longer responses are replaced by -31.
  uint8_t reply_capacity() const { return reply_capacity_; }

 protected:
  /// Bytes of a request frame after its payload: ':', two id and two CRC characters.
  static constexpr uint8_t kFrameMetadata = 5;
  /// Buffer bytes a device of these capacities needs (`buffers` below): the request being received
  /// (payload and metadata), the reply, the cache's key (the payload of the request the reply answers).
  static constexpr size_t buffer_size(uint8_t payload_capacity, uint8_t reply_capacity) {
    return static_cast<size_t>(payload_capacity + kFrameMetadata + reply_capacity + payload_capacity);
  }
  /// A device over `buffer_size(payload_capacity, reply_capacity)` bytes at `buffers`, which must
  /// outlive it (`BasicRomiSerial` passes its own; their contents need no initialization). The other
  /// arguments are `BasicRomiSerial`'s.
  RomiSerialBase(IInputStream& in, IOutputStream& out, const MessageHandler* handlers, uint8_t count,
                 ClockFunction clock, uint8_t* buffers, uint8_t payload_capacity, uint8_t reply_capacity);
  /// Nothing to release (no heap); not virtual: a device is never deleted through its base.
  ~RomiSerialBase() = default;

 private:
  // The reply buffer (reply_capacity_ bytes, after the frame's) and the cache's key (after the reply).
  uint8_t* reply() { return decoder_.buffer() + decoder_.capacity(); }
  uint8_t* cached_request() { return reply() + reply_capacity_; }
  bool cache_expired(Millis now) const { return cached_request_size_ != 0 && tick_reached(now, cache_expires_at_); }
  // Forgets the cached reply if it expired at now_ (after a clock reading; one copy for both callers).
  __attribute__((noinline)) void expire_cache();
  // A byte the decoder's inline path did not take ('\r', '\n', bytes outside frames, overflow; a '#' goes
  // to begin_request), without the timeout check. Out of line: the per-byte loop stays small.
  __attribute__((noinline)) void receive(uint8_t byte);
  // A frame's '#' (its deadline, the decoder's start): apart from receive(), whose parse and dispatch
  // make it save five registers a call that this path does not need.
  __attribute__((noinline)) void begin_request();
  // receive(), after sending the response's '#' at once when `byte` completes a frame (the turnaround).
  __attribute__((always_inline)) void receive_special(uint8_t byte);
  void handle_frame(const Frame& frame);
  void prepare(const Frame& frame);  // parse and look up the handler, at the frame's '\r'
  bool is_repeat(uint8_t id, ByteView payload);  // the cached reply answers this request
  void dispatch(const Frame& frame);
  // The reply of send_ok() and send(); out of line, or avr-gcc copies it into every handler that calls them.
  __attribute__((noinline)) void handler_reply(ByteView body);
  // A handler's reply that does not fit: -31 instead. Out of line, so that handler_reply's usual path
  // saves no registers (its call here needs `this` after another call).
  __attribute__((noinline)) void send_too_long();
  // The responses' functions echo the opcode and id of the decoder's frame: the request being handled
  // (a parsed request's opcode is its frame's), the frame a protocol error answers, or the frame a
  // deadline dropped (Decoder::abandon). Their arguments then fit the registers a call may clobber (on
  // the AVR: nothing saved to forward them, and tail calls).
  // A handler's response (or -20, -31 for it), `size` bytes at `body` (that fit the reply buffer: checked
  // by handler_reply), cached unless the request is manual.
  void send_response(const uint8_t* body, uint8_t size);
  // Sends `[code]` for a protocol code (-1..-99): a handler's response (-20, -31: remembered like the
  // handler's own, send_response) or the device's own (counted as rejected, never cached).
  void send_code(Error code, bool handler_reply);
  // A reply that must not touch the cache (manual requests), formed on the stack: out of line, so its
  // 72-byte buffer stays off the common path.
  __attribute__((noinline)) void send_uncached(const uint8_t* body, uint8_t size);
  // Forms the response into `frame` (the reply buffer, i.e. the cache's copy, or a caller's buffer with
  // room for `size` + kResponseOverhead) and sends it. One function for every response: the inlined
  // formatter is linked once.
  __attribute__((noinline)) void send_frame(const uint8_t* body, uint8_t size, uint8_t* frame);
  void start_frame();  // sends a frame's '#', unless receive() sent it already
  void write(ByteView bytes);
};

/// A Romi device whose buffers hold requests of up to `PayloadCapacity` payload characters (opcode and
/// arguments, between '#' and ':') and responses of up to `ReplyCapacity` bytes ('#' to '\n'). The
/// code is `RomiSerialBase`'s, shared by every size; only the buffers differ (see "Sizing a device" in
/// the file comment). `RomiSerial` is `BasicRomiSerial<58, 72>`. On the AVR it takes
/// 2 x PayloadCapacity + ReplyCapacity + 133 bytes of RAM (`RomiSerial`: 321).
template <uint8_t PayloadCapacity, uint8_t ReplyCapacity>
class BasicRomiSerial final : public RomiSerialBase {
  static_assert(PayloadCapacity >= kMinPayloadCapacity && PayloadCapacity <= kMaxPayloadCapacity,
                "PayloadCapacity: 1..58 characters");
  static_assert(ReplyCapacity >= kMinReplyCapacity && ReplyCapacity <= kMaxReplyCapacity,
                "ReplyCapacity: 14..72 bytes");

 public:
  /// Longest request payload (opcode and arguments) accepted; a longer request is answered -1 (too long).
  static constexpr uint8_t kPayloadCapacity = PayloadCapacity;
  /// Largest response frame, '#' to '\n'; a handler reply that does not fit is replaced by -31.
  static constexpr uint8_t kReplyCapacity = ReplyCapacity;
  /// Bytes of the buffers (part of this object): request frame, reply, cache key.
  static constexpr size_t kBufferSize = buffer_size(PayloadCapacity, ReplyCapacity);

  /// Device reading `in`, writing `out`, dispatching to `handlers[0..count)` (which must outlive it),
  /// timing requests with `clock` (null: no request deadline). The streams may be the same object.
  BasicRomiSerial(IInputStream& in, IOutputStream& out, const MessageHandler* handlers = nullptr, uint8_t count = 0,
                  ClockFunction clock = default_clock)
      : RomiSerialBase(in, out, handlers, count, clock, buffers_, PayloadCapacity, ReplyCapacity) {}

 private:
  uint8_t buffers_[kBufferSize];
};

template <uint8_t PayloadCapacity, uint8_t ReplyCapacity>
constexpr uint8_t BasicRomiSerial<PayloadCapacity, ReplyCapacity>::kPayloadCapacity;
template <uint8_t PayloadCapacity, uint8_t ReplyCapacity>
constexpr uint8_t BasicRomiSerial<PayloadCapacity, ReplyCapacity>::kReplyCapacity;
template <uint8_t PayloadCapacity, uint8_t ReplyCapacity>
constexpr size_t BasicRomiSerial<PayloadCapacity, ReplyCapacity>::kBufferSize;

/// The device of the RomiSerial API, at the spec's maxima: every request a reference host can send
/// (58-character payloads), replies up to 72 bytes. What every sketch declares.
using RomiSerial = BasicRomiSerial<RomiSerialBase::kMaxPayloadCapacity, RomiSerialBase::kMaxReplyCapacity>;

}  // namespace device
}  // namespace romi
}  // namespace tether
