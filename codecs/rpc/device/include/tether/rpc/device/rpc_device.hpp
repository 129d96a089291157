/// @file rpc_device.hpp
/// The device side of the rpc codec: a schema's service (service.hpp) served over the proxy's framing,
/// `COBS(crc16 ‖ HostMessage) ‖ 00` in, `COBS(crc16 ‖ DeviceMessage) ‖ 00` out (tether_rpc.proto,
/// nanopb, no heap). Sans-I/O like the other device engines: bytes in, time as `now`, frames out through
/// a `FrameSink`.
///
/// ## Use (what `tether generate` writes around it)
///
///     Device<> device(service, FrameSink{write_to_uart, nullptr}, flush_and_reset, nullptr);
///     device.begin(boot_session_id(), millis());         // end of setup: sends ResetEvent
///     for (;;) { consume(device.handle_bytes(received, millis())); device.poll(millis()); }
///
/// ## Wire behaviour
///   1. Boot: `begin` sends `ResetEvent{session}` after one 0x00; then `DeviceHello` every kInfoPeriodMs
///      (5 s) and whenever a Hello asks (the host compares the schema hash and the session).
///   2. Frames: as the proxy device's (empty ignored; bad COBS, CRC mismatches, payloads over
///      Limits::kMaxPayload and frames not complete kPartialFrameMs after their first byte dropped and
///      counted in `counters().link`).
///   3. A payload that is not a HostMessage: `DeviceError{call 0, bad_envelope}`, no ack (no id to ack).
///   4. Every HostMessage is acknowledged with `Ack{id, refused}`, AFTER what it causes (its Reply or
///      DeviceError), so the ack closes the exchange. `refused`: the runtime did not run it (a DeviceError
///      with one of Tether's codes says why); a handler's own error is not a refusal.
///   5. A message whose id AND payload CRC match one of the last Limits::kDuplicateDepth run is a re-send:
///      the device sends its first answer again from the cache (the same Reply or DeviceError bytes),
///      then the Ack; it runs nothing. A refused message is not remembered.
///   6. Bodies:
///      - Call{method, request}: the request is decoded into the method's input struct, the reply struct
///        zeroed, the handler called; `Status::ok()` sends `Reply{call = id, reply}`, an error
///        `DeviceError{call = id, code, text}`. Refusals: unknown_method, not_unary, bad_request. A reply
///        that does not fit a frame is answered `DeviceError{reply_too_large}`, not refused: the handler
///        ran, and a re-send gets that answer again rather than a second run.
///      - OpenStream{method, request, period_ms}: from then on the handler is called once per period
///        (the first at the next `poll`) and each message it fills is sent as `StreamMessage{stream = id,
///        seq, message}`, seq from 0. One stream per method: opening a method that streams already
///        replaces its stream. A handler error ends the stream with `DeviceError{call = stream id, ...}`.
///        Refusals: unknown_method, not_streaming, bad_request, period_too_short (below
///        `set_min_period_ms`), request_too_large (over Limits::kStreamRequestBytes), streams_full
///        (Limits::kStreams other methods stream already).
///      - CloseStream{stream}: the stream opened by that id stops (nothing if none).
///      - Ping: feeds the failsafe (any message would not do: a host that only calls would otherwise keep
///        streams alive after it stopped listening).
///      - Reset: the Ack is sent, then the restart hook.
///      - Hello: `DeviceHello`.
///      - none of those: `DeviceError{unknown_message}`, refused.
///   7. Failsafe: kPingSilenceMs (10 s) without a Ping closes every stream (counted in `link.failsafes`);
///      the host re-opens them when it is back.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/core/time.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/device/io.hpp"
#include "tether/rpc/device/service.hpp"
#include "tether/rpc/errors.hpp"

namespace tether {
namespace rpc {
namespace device {

using proxy::device::FrameSink;
using proxy::device::RestartFunction;

/// What the exactly-once cache keeps of a DeviceError: its code (a key and up to 3 bytes) and its text (a
/// key, a length and at most 47 characters); a Reply's is its reply field (a key, a length, the bytes).
constexpr uint16_t kErrorAnswerBytes = 4 + 2 + 47;

/// Sizes of a device's tables; `tether generate` derives them from the schema.
struct DefaultLimits {
  static constexpr size_t kMaxPayload = 96;          ///< Largest HostMessage payload accepted.
  static constexpr uint8_t kStreams = 2;             ///< Streams open at once.
  static constexpr uint8_t kStreamRequestBytes = 16;  ///< Largest encoded request a stream keeps.
  static constexpr uint8_t kDuplicateDepth = 4;      ///< Calls remembered (>= the host's calls in flight).
  static constexpr uint16_t kReplyCacheBytes = 64;   ///< Room of an answer remembered for a re-send: the
                                                     ///< Reply's or DeviceError's fields after its call id
                                                     ///< (>= kErrorAnswerBytes and every unary reply's).

  static constexpr size_t kMaxOutPayload = 72;       ///< Largest DeviceMessage payload sent (>= 64: a
                                                     ///< DeviceError with its text, a DeviceHello).
  static constexpr size_t kRequestStructBytes = 64;  ///< Largest request struct (sizeof, the input types').
  static constexpr size_t kReplyStructBytes = 64;    ///< Largest reply struct (sizeof, the output types').
  /// Where the answer buffers (the reply's encoding, its frame, the request and reply structs) live while
  /// a frame or a timer is handled: false, on the stack of that entry point only (RAM shared with the rest
  /// of the program when idle); true, in static RAM, so that the build's RAM figure counts them and a
  /// schema too large for the board fails the link instead of overflowing the stack at its first call.
  /// Optional in a `Limits` (false when absent).
  static constexpr bool kStaticBuffers = false;
};

/// `Limits::kStaticBuffers`, false when the limits do not say.
template <class Limits, class = void>
struct StaticBuffers {
  static constexpr bool value = false;  ///< On the stack.
};
/// `Limits::kStaticBuffers` when the limits say.
template <class Limits>
struct StaticBuffers<Limits, decltype(void(Limits::kStaticBuffers))> {
  static constexpr bool value = Limits::kStaticBuffers;  ///< As the limits say.
};

/// Diagnostics of an rpc device. Counters only grow (wrap at 2^32). Plain data.
struct DeviceCounters {
  /// Frame layer and session engine: frames_ok, crc_errors, framing_errors, oversize_frames, resyncs,
  /// partial_timeouts, duplicates, failsafes.
  LinkCounters link;
  uint32_t decode_errors = 0;     ///< Checked frames whose payload was not a HostMessage.
  uint32_t calls = 0;             ///< Handlers run for calls.
  uint32_t stream_messages = 0;   ///< Stream messages sent.
  uint32_t handler_errors = 0;    ///< Handlers that returned an error (calls and streams).
  uint32_t refused = 0;           ///< Messages refused by the runtime (a DeviceError with Tether's code).
  uint32_t send_failures = 0;     ///< Messages that did not encode (a reply too large is counted here too).
};

/// Shared, size-independent part of Device (one copy of the code whatever the limits).
class DeviceCore {
 public:
  /// Silence (no Ping) that closes the streams.
  static constexpr Duration kPingSilenceMs = 10000;
  /// Period of DeviceHello.
  static constexpr Duration kInfoPeriodMs = 5000;
  /// Time a frame may take from its first byte to its delimiter.
  static constexpr Duration kPartialFrameMs = 100;

  /// This boot's session.
  uint32_t session_id() const { return session_id_; }
  /// Diagnostics.
  const DeviceCounters& counters() const { return counters_; }
  /// Streams running now.
  uint8_t open_streams() const;
  /// Shortest stream period accepted (default and at least 1 ms; the generated glue sets one frame time at
  /// its baud).
  void set_min_period_ms(uint16_t period) { min_period_ms_ = period; }

 protected:
  // A stream's slot; all zeros (its deadline disarmed) when it serves no stream, so that a device needs no
  // code to start (constant-initialised: .bss).
  struct StreamSlot {
    uint32_t id;
    Deadline next;  // armed exactly while the slot serves a stream
    uint32_t seq;
    uint16_t period;
    uint8_t method;
    uint8_t request_size;
  };

  // `slots` and `requests` (slot_count rows of request_bytes) are the derived device's tables.
  constexpr DeviceCore(const Service& service, FrameSink sink, RestartFunction restart, void* restart_context,
             size_t max_payload, size_t max_out, StreamSlot* slots, uint8_t slot_count, uint8_t* requests,
             uint8_t request_bytes)
      : service_(&service),
        sink_(sink),
        restart_(restart),
        restart_context_(restart_context),
        max_payload_(static_cast<uint16_t>(max_payload)),
        max_out_(static_cast<uint16_t>(max_out)),
        slots_(slots),
        requests_(requests),
        slot_count_(slot_count),
        request_bytes_(request_bytes) {}
  // All zeros, bound later (`bind`).
  constexpr DeviceCore() {}
  // What the first constructor takes, for a device made by the second.
  void bind(const Service& service, FrameSink sink, RestartFunction restart, void* restart_context,
            size_t max_payload, size_t max_out, StreamSlot* slots, uint8_t slot_count, uint8_t* requests,
            uint8_t request_bytes);

  // What a body's handling produced, for the ack and the duplicate cache.
  struct Outcome {
    bool refused;
    ByteView answer;  // the Reply / DeviceError sent, its fields after the call id (empty: none)
  };

  static constexpr uint8_t kNone = 0xFF;  // no slot

  // The derived device's buffers on its entry point's stack (the sizes are its limits'): `out` for the
  // payload being sent (max_out bytes; after `run`, the answer to remember), `frame` for its frame, the
  // structs a request is decoded into and a handler fills (only a call or a stream message needs them:
  // no static RAM for them).
  struct Scratch {
    uint8_t* out;
    uint8_t* frame;
    void* request;
    void* reply;
    uint16_t reply_size;
  };

  // The exactly-once cache's entries (the derived device's table, `depth` rows of `stride` bytes: a head,
  // then the answer's bytes).
  struct CacheHead {
    uint32_t id;
    uint16_t fingerprint;
    uint16_t size;  // of the answer kept
  };
  template <uint16_t kCapacity>
  struct CacheEntry {
    CacheHead head;
    uint8_t bytes[kCapacity];  // right after the head (byte aligned)
  };
  struct Cache {
    CacheHead* entries;
    uint16_t stride;  // bytes from an entry to the next (head and answer room)
    uint8_t depth;
  };

  // The entry points' work, out of line with small frames (the derived device's own entry points only put
  // their buffers on the stack): each runs with `scratch` as its buffers.
  void begin_with(Scratch& scratch, uint32_t session_id, Millis now);
  void poll_with(Scratch& scratch, Millis now);
  // A checked frame's payload: decoded, looked up in `cache`, run, answered, acknowledged.
  void handle_frame(Scratch& scratch, const Cache& cache, ByteView payload, uint16_t fingerprint, Millis now);

  void start(uint32_t session_id, Millis now);
  void track_frame(bool was_in_frame, bool in_frame, Millis now);
  bool poll_frame_deadline(Millis now);
  // False while nothing can be due: no frame started or was handled since the last `poll` and `now` is
  // before the earliest deadline it left (the loop polls after every byte in or out and at every clock
  // tick; most of those passes end here, with one comparison).
  bool poll_due(Millis now) {
    if (polled_ && !tick_reached(now, next_due_)) return false;
    polled_ = true;
    return true;
  }
  // A frame was handled or started: the next `poll` runs whatever the time (an opened stream's first
  // message, a ping's new failsafe deadline, a frame's partial-frame deadline).
  void frame_handled() { polled_ = false; }
  void poll_time(Millis now);
  void plan();  // next_due_ from the deadlines
  static Millis earlier(Millis due, Deadline deadline);  // `deadline` when armed and before `due`
  // Decodes the envelope; false when it is not one (counted, answered).
  bool decode(ByteView payload, void* host_message);
  // Runs a decoded HostMessage; its answer (if any) is left in the scratch `out`.
  Outcome run(const void* host_message, Millis now);
  // Sends an answer again to the message `id`: `kept` is an Outcome's answer, as the cache kept it.
  void send_again(uint32_t id, ByteView kept);
  void send_ack(uint32_t id, bool refused);
  void send_payload(ByteView payload, bool leading_delimiter = false);
  void finish(const void* host_message);  // a Reset body's restart
  bool slot_open(uint32_t id) const;
  void close_streams();  // every slot free (the failsafe)

  DeviceCounters counters_;

 private:
  Outcome call(uint32_t id, uint32_t method, ByteView request);
  Outcome open(uint32_t id, uint32_t method, ByteView request, uint32_t period, Millis now);
  void run_stream(uint8_t slot, Millis now);
  bool decode_request(const Method& method, ByteView request);
  Outcome refuse(uint32_t id, DeviceErrorCode code);
  // Sends a DeviceError; returns its fields after the call id (empty when it did not fit).
  ByteView send_error(uint32_t call, uint16_t code, const char* text, bool text_in_flash);
  // The service and its methods, read from flash.
  Service service() const;
  static Method method(const Service& service, uint8_t index);
  // Sends the DeviceMessage written in the scratch `out`; its size, 0 when it did not fit (counted).
  size_t send_message(const wire::Writer& message, bool leading_delimiter = false);
  void send_hello();
  // The cache entry of message `id` with `fingerprint`, null when none.
  const CacheHead* cached(const Cache& cache, uint32_t id, uint16_t fingerprint);
  void remember(const Cache& cache, uint32_t id, uint16_t fingerprint, ByteView answer);

  // Zero-initialised (a global device with nothing non-zero is in .bss: no flash for its image).
  const Service* service_ = nullptr;
  FrameSink sink_ = {nullptr, nullptr};
  RestartFunction restart_ = nullptr;
  void* restart_context_ = nullptr;
  Deadline partial_;     // armed from a frame's first byte to its end (kPartialFrameMs)
  Deadline ping_;        // the failsafe's: kPingSilenceMs after the last Ping
  bool in_failsafe_ = false;
  Deadline next_info_;
  uint32_t session_id_ = 0;
  uint16_t min_period_ms_ = 0;  // 0: 1
  Millis next_due_ = 0;  // the earliest deadline the last `poll` left
  bool polled_ = false;
  uint16_t max_payload_ = 0;
  uint16_t max_out_ = 0;
  Scratch* scratch_ = nullptr;
  uint8_t cached_ = 0;      // cache entries in use
  uint8_t cache_next_ = 0;  // the entry the next answer replaces
  StreamSlot* slots_ = nullptr;
  uint8_t* requests_ = nullptr;
  uint8_t slot_count_ = 0;
  uint8_t request_bytes_ = 0;
};

/// An rpc device with `Limits`' table sizes. Not copyable; main loop only (never from an interrupt).
template <class Limits = DefaultLimits>
class Device : public DeviceCore {
 public:
  /// Device serving `service` (declared `TETHER_IN_FLASH`), sending through `sink`, restarting through `restart(restart_context)`
  /// (null: Reset is acked and ignored, for tests). `service` must outlive it. Constant: a global device is
  /// all zeros and constants (.bss/.data), no start-up code.
  constexpr Device(const Service& service, FrameSink sink, RestartFunction restart = nullptr,
                   void* restart_context = nullptr)
      : DeviceCore(service, sink, restart, restart_context, Limits::kMaxPayload, Limits::kMaxOutPayload, slot_table_,
                   Limits::kStreams, &request_table_[0][0], Limits::kStreamRequestBytes),
        decoder_(proxy::Integrity::crc16, counters_.link) {}
  /// A device with nothing bound: all zeros (a global one is in .bss, no flash for its image and no
  /// start-up code). `bind` it before anything else.
  constexpr Device() {}
  /// Binds a device made by the constructor without arguments, as the other constructor does.
  void bind(const Service& service, FrameSink sink, RestartFunction restart = nullptr, void* restart_context = nullptr) {
    DeviceCore::bind(service, sink, restart, restart_context, Limits::kMaxPayload, Limits::kMaxOutPayload, slot_table_,
                     Limits::kStreams, &request_table_[0][0], Limits::kStreamRequestBytes);
    decoder_.bind(proxy::Integrity::crc16, counters_.link);
  }
  Device(const Device&) = delete;
  Device& operator=(const Device&) = delete;

  /// End of setup: remembers `session_id`, starts the clocks at `now`, sends ResetEvent.
  void begin(uint32_t session_id, Millis now) {
    Home home;
    begin_with(home.get(), session_id, now);
  }

  /// Handles one received byte at `now`; a completed frame is handled at once.
  void handle_byte(uint8_t byte, Millis now) {
    const bool was_in_frame = decoder_.in_frame();
    const DecodeStatus status = decoder_.feed(byte);
    track_frame(was_in_frame, decoder_.in_frame(), now);
    if (status == DecodeStatus::frame) handle_payload(decoder_.frame(), decoder_.checksum(), now);
  }

  /// Handles received bytes up to and including the first one that completes a frame (handled at once)
  /// or drops one; returns how many it used: call again with the rest.
  size_t handle_bytes(ByteView bytes, Millis now) {
    const bool was_in_frame = decoder_.in_frame();
    const FeedResult fed = decoder_.feed(bytes);
    track_frame(was_in_frame, decoder_.in_frame(), now);
    if (fed.status == DecodeStatus::frame) handle_payload(decoder_.frame(), decoder_.checksum(), now);
    return fed.consumed;
  }

  /// Handles time: due stream messages, DeviceHello, the failsafe, the partial-frame deadline. Call every
  /// loop pass.
  void poll(Millis now) {
    if (!poll_due(now)) return;
    if (poll_frame_deadline(now)) decoder_.restart();
    Home home;
    poll_with(home.get(), now);
  }

  /// True while the stream opened by message `id` runs.
  bool stream_open(uint32_t id) const { return slot_open(id); }

 private:
  static_assert(Limits::kMaxOutPayload >= 64, "a DeviceError with its text and a DeviceHello must fit");
  static_assert(Limits::kReplyCacheBytes >= kErrorAnswerBytes, "a DeviceError with its text must be remembered");
  // Room for a struct, aligned for any field a nanopb struct has.
  template <size_t kSize>
  union StructRoom {
    uint64_t align;
    uint8_t bytes[kSize];
  };
  struct Buffers : Scratch {
    Buffers() : Scratch{out, frame, request.bytes, reply.bytes, static_cast<uint16_t>(sizeof reply.bytes)} {}
    uint8_t out[Limits::kMaxOutPayload];
    uint8_t frame[proxy::max_frame_size(Limits::kMaxOutPayload)];
    StructRoom<Limits::kRequestStructBytes> request;
    StructRoom<Limits::kReplyStructBytes> reply;
  };
  // An entry point's buffers: on its stack (a member of the home), or one static set for the type.
  template <bool kStatic, class Unused = void>
  struct BufferHome {
    Buffers local;
    Buffers& get() { return local; }
  };
  template <class Unused>
  struct BufferHome<true, Unused> {
    Buffers& get() { return static_buffers_; }
  };
  using Home = BufferHome<StaticBuffers<Limits>::value>;
  static Buffers static_buffers_;  // defined (and in RAM) only when a static home uses it
  using Entry = CacheEntry<Limits::kReplyCacheBytes>;
  static_assert(offsetof(Entry, bytes) == sizeof(CacheHead), "an entry's answer follows its head");
  // Out of line: one call site per entry point, its buffers on its own stack only while a frame is handled.
  __attribute__((noinline)) void handle_payload(ByteView payload, uint16_t fingerprint, Millis now) {
    Home home;
    const Cache cache{&cache_[0].head, sizeof(Entry), Limits::kDuplicateDepth};
    handle_frame(home.get(), cache, payload, fingerprint, now);
  }

  proxy::Decoder<Limits::kMaxPayload> decoder_;
  Entry cache_[Limits::kDuplicateDepth] = {};
  StreamSlot slot_table_[Limits::kStreams] = {};
  uint8_t request_table_[Limits::kStreams][Limits::kStreamRequestBytes] = {};
};

template <class Limits>
typename Device<Limits>::Buffers Device<Limits>::static_buffers_;

}  // namespace device
}  // namespace rpc
}  // namespace tether

