// The rpc host client: see tether/rpc/client.hpp for the protocol.
//
// Everything below the public functions runs on the link's strand. Calls, stream opens and stream closes
// are entries of one pending-operation queue from acceptance to completion (opens and closes are the
// client's own: no caller); the session engine's RequestTable keeps their ids, attempt windows and budgets.
// `pump(now)` runs the engine's deadlines, the session monitor, the heartbeat and queue deadlines, starts
// what can start and re-arms the one timer.
#include "tether/rpc/client.hpp"

#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/message.h>
#include <google/protobuf/util/json_util.h>

#include <boost/asio/error.hpp>

#include <algorithm>
#include <array>
#include <atomic>
#include <future>
#include <map>
#include <mutex>
#include <optional>
#include <set>
#include <random>
#include <ranges>
#include <stdexcept>
#include <tuple>
#include <utility>
#include <vector>

#include "tether/core/session/heartbeat.hpp"
#include "tether/core/session/request_table.hpp"
#include "tether/client/message_ids.hpp"
#include "tether/core/wakeup.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/device_message.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/proxy/session_policy.hpp"
#include "tether/rpc/envelope.hpp"
#include "tether/rpc/errors.hpp"
#include "tether/rpc/json_mapping.hpp"
#include "tether/client/client_link.hpp"
#include "tether/client/pending_operations.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::rpc {

namespace {
namespace pb = google::protobuf;
namespace asio = boost::asio;

// The largest answer a device sends (a Reply or DeviceError of `device::DefaultLimits::kMaxOutPayload` bytes,
// framed): the attempt window waits for it as well as for the ack.
constexpr std::size_t kAnswerFrameBytes = proxy::max_frame_size(72);

proxy::AckTiming ack_timing(const RpcTiming& timing) {
  proxy::AckTiming ack;
  ack.baud = timing.baud;
  ack.bits_per_byte = timing.bits_per_byte;
  ack.processing_margin = timing.processing_margin;
  ack.send_budget = timing.call_budget;
  ack.max_sends = timing.max_sends;
  return ack;
}

}  // namespace

std::string mismatch_text(const Schema& schema, std::uint64_t device_hash) {
  return schema.file().string() + ": the device was built from another schema (its hash " + format_hash(device_hash) +
         ", this schema's " + format_hash(schema.hash()) + ")";
}

Duration RpcTiming::attempt_window(std::size_t frame_bytes) const {
  return proxy::ack_timeout(ack_timing(*this), frame_bytes + kAnswerFrameBytes);
}

std::string_view refusal_hint(std::uint16_t code) {
  // The device cannot tell a malformed request from one over a bound (nanopb refuses both alike).
  return code == static_cast<std::uint16_t>(DeviceErrorCode::bad_request) ? " (a field over its .options bound?)" : "";
}

CallError::CallError(error_code code, const std::string& method, DeviceError device_error)
    : boost::system::system_error(code),
      device_error_(std::move(device_error)),
      what_(method + ": " + (code == RpcError::refused ? "refused " : "device error ") +
            std::to_string(device_error_.code) + ": " + device_error_.text +
            std::string(code == RpcError::refused ? refusal_hint(device_error_.code) : "")) {}

namespace detail {

// What an Ack tells the request table.
struct Policy {
  using Id = std::uint32_t;
  using Code = std::uint8_t;
  static constexpr Code kAnswered = 0;            // a call's answer came before its ack
  static constexpr Code kAcked = 1;               // an open or close: the ack is all
  static constexpr Code kAckedWithoutAnswer = 2;  // a call's answer was lost: re-send, the device answers again
  static constexpr Code kRefused = 3;
  static bool is_success(Code code) { return code == kAnswered || code == kAcked; }
  static bool is_retryable(Code code) { return code == kAckedWithoutAnswer; }
};
using Table = session::RequestTable<Policy, kMaxInFlight>;
using Monitor = session::SessionMonitor<std::uint32_t, 1>;

// The schema and the factory of its messages, shared by every message the client hands out (a reply
// outlives the client safely). A compiled-in schema's messages are the program's generated classes (a
// typed client takes its reply by a downcast); a schema read from a file makes dynamic messages.
class Messages : public std::enable_shared_from_this<Messages> {
 public:
  explicit Messages(Schema schema)
      : schema_(std::move(schema)),
        dynamic_(&schema_.pool()),
        factory_(schema_.compiled_in() ? pb::MessageFactory::generated_factory() : &dynamic_) {
    // The methods' prototypes, looked up once: a factory's lookup takes a lock and a hash map.
    for (const Method& method : schema_.methods()) {
      for (const pb::Descriptor* type : {method.input, method.output}) {
        const bool known = std::ranges::any_of(prototypes_, [&](const auto& entry) { return entry.type == type; });
        if (!known) prototypes_.push_back(Prototype{type, factory_->GetPrototype(type), plain(type)});
      }
    }
  }
  const Schema& schema() const { return schema_; }
  const JsonMapping& json() const { return json_; }
  std::shared_ptr<pb::Message> make(const pb::Descriptor* type) {
    const Prototype* found = find(type);
    const pb::Message* prototype = found != nullptr ? found->prototype : factory_->GetPrototype(type);
    return std::shared_ptr<pb::Message>(prototype->New(), [keep = shared_from_this()](pb::Message* m) { delete m; });
  }
  // Parses what the device sent into `message` (cleared first), as proxy::parse_device_message; a type
  // without strings cannot fail for its text, so libprotobuf's parser alone (no log silencer: it locks).
  bool parse(pb::Message& message, ByteView bytes) const {
    const Prototype* found = find(message.GetDescriptor());
    if (found != nullptr && found->plain) return message.ParseFromArray(bytes.data(), static_cast<int>(bytes.size()));
    return proxy::parse_device_message(message, bytes);
  }

 private:
  struct Prototype {
    const pb::Descriptor* type;
    const pb::Message* prototype;
    bool plain;  // no string and no required field at any depth: a failed parse logs nothing
  };
  const Prototype* find(const pb::Descriptor* type) const {
    const auto found = std::ranges::find_if(prototypes_, [&](const Prototype& entry) { return entry.type == type; });
    return found != prototypes_.end() ? &*found : nullptr;
  }
  static bool plain(const pb::Descriptor* type) {
    std::vector<const pb::Descriptor*> seen;
    return plain(type, seen);
  }
  static bool plain(const pb::Descriptor* type, std::vector<const pb::Descriptor*>& seen) {
    if (std::ranges::find(seen, type) != seen.end()) return true;
    seen.push_back(type);
    for (int i = 0; i < type->field_count(); ++i) {
      const pb::FieldDescriptor* field = type->field(i);
      if (field->type() == pb::FieldDescriptor::TYPE_STRING || field->is_required()) return false;
      if (field->message_type() != nullptr && !plain(field->message_type(), seen)) return false;
    }
    return type->extension_range_count() == 0;
  }

  Schema schema_;
  pb::DynamicMessageFactory dynamic_;
  pb::MessageFactory* factory_;
  std::vector<Prototype> prototypes_;
  JsonMapping json_{schema_.pool()};
};

CallRequest make_call_request(std::string_view method, const pb::Message& request, TypedReply reply,
                              const pb::Descriptor* type) {
  CallRequest call;
  call.reply = reply;
  call.method = std::string(method);
  call.type = type != nullptr ? type : request.GetDescriptor();
  call.encoded = request.SerializeToString(&call.request);
  return call;
}

std::shared_ptr<pb::Message> TypedReplies::take(const TypedReply& typed) {
  Slot* free = nullptr;
  for (Slot& slot : slots_) {
    if (slot.type == typed.type && slot.message.use_count() == 1) {
      // The caller's release (another thread's decrement) happens before the reuse: what it did to the
      // reply is done before the parse writes it.
      std::atomic_thread_fence(std::memory_order_acquire);
      return slot.message;
    }
    if (free == nullptr && !slot.message) free = &slot;
  }
  std::shared_ptr<pb::Message> made = typed.make();
  if (free != nullptr) *free = Slot{typed.type, made};
  return made;
}

void copy_through_bytes(const pb::Message& from, pb::Message& to) {
  std::string bytes;
  (void)from.SerializeToString(&bytes);  // messages of the client: every field set is valid proto3
  (void)to.ParseFromString(bytes);
}

// One message of the client on its way, as the pending-operation queue holds it.
struct Op {
  enum class Kind : std::uint8_t { call, open, close };
  enum class Stage : std::uint8_t { queued, in_flight };
  Kind kind = Kind::call;
  Stage stage = Stage::queued;
  const Method* method = nullptr;
  std::string request;  // the encoded request (call, open)
  TypedReply typed;     // a call: the class its caller takes the reply as
  std::uint32_t period = 0;
  std::uint64_t stream = 0;        // open: the stream's key
  std::uint32_t close_target = 0;  // close: the device's stream id
  std::uint32_t id = 0;            // message id on the wire
  std::uint32_t anchor = 0;        // the oldest id in flight when it was first sent
  std::shared_ptr<const std::string> frame;
  bool answered = false;  // a call: its Reply or DeviceError arrived
  bool failed = false;    // ... and it was a DeviceError
  std::string reply;
  DeviceError error;
};
using Ops = client::PendingOperations<CallSignature, Op>;

// A stream the application opened.
struct StreamEntry {
  const Method* method = nullptr;
  std::string request;
  std::uint32_t period = 0;
  StreamHandler handler;
  std::uint32_t wire_id = 0;  // the OpenStream's id in this session (0: not open on the device)
  bool opening = false;       // an OpenStream is queued or in flight
};

class ClientImpl final : public client::ClientLink {
 public:
  ClientImpl(std::shared_ptr<transports::ByteStream> stream, Schema schema, const Options& options)
      : ClientLink(std::move(stream), options.clock),
        options_(options),
        messages_(std::make_shared<Messages>(std::move(schema))),
        ops_(executor(), [this] { publish(); }),
        ready_(executor(), [this] { publish(); }),
        decoder_(counters_.link),
        table_(session::CallTiming(), 0, counters_.link),
        heartbeat_(options.timing.ping_period),
        monitor_(hello_timing(options.timing), counters_.link),
        ids_(options.first_message_id ? *options.first_message_id : std::random_device()(), kIdWindow) {}

  void start() {
    post_to_strand([this] {
      start_reading();
      const Millis now = this->now();
      monitor_.start(now);
      if (options_.timing.ping_period > 0) heartbeat_.start(now);
      pump(now);
    });
  }

  const std::shared_ptr<Messages>& messages() const { return messages_; }
  client::EventHandlers<Event>& event_handlers() { return events_; }
  Counters counters() const { return published_.get(); }
  SessionStatus session() const { return published_session_.get(); }

  // Any thread.
  void submit_call(OperationId operation, CallRequest call, CallHandler handler) {
    Op op;
    const error_code error = build(call, false, op);
    if (error) {
      post_completion(std::move(handler), error, CallResult());
      return;
    }
    post_to_strand([this, operation, handler = std::move(handler), op = std::move(op)]() mutable {
      if (!is_open() || link_error()) {
        post_completion(std::move(handler), closed_error(), CallResult());
        return;
      }
      if (mismatch_) {
        post_completion(std::move(handler), make_error_code(RpcError::schema_mismatch), CallResult());
        return;
      }
      const Millis now = this->now();
      ops_.add(operation, std::move(handler), std::move(op), deadline_after(now, options_.timing.queue_timeout));
      pump(now);
    });
  }

  void submit_ready(OperationId operation, transports::UniqueFunction<ReadySignature> handler) {
    post_to_strand([this, operation, handler = std::move(handler)]() mutable {
      if (!is_open() || link_error()) {
        post_completion(std::move(handler), closed_error(), std::uint32_t(0));
        return;
      }
      if (established_) {
        post_completion(std::move(handler), error_code(), monitor_.session_id());
        return;
      }
      if (mismatch_) {
        post_completion(std::move(handler), make_error_code(RpcError::schema_mismatch), std::uint32_t(0));
        return;
      }
      const Millis now = this->now();
      ready_.add(operation, std::move(handler), Empty(), deadline_after(now, options_.timing.queue_timeout));
      pump(now);
    });
  }

  // Any thread. Throws system_error for what the schema refuses.
  std::uint64_t open_stream(std::string_view method, const pb::Message& request, std::chrono::milliseconds period,
                            StreamHandler handler) {
    Op op;
    CallRequest call = make_call_request(method, request);
    const error_code error = build(call, true, op);
    if (error) throw boost::system::system_error(error, "open_stream " + std::string(method));
    if (period.count() < 1 || period.count() > 0xFFFF) {  // the request is fine: the period has its own words
      throw boost::system::system_error(
          boost::system::errc::make_error_code(boost::system::errc::invalid_argument),
          "open_stream " + std::string(method) + ": the period, " + std::to_string(period.count()) +
              " ms, is outside 1..65535 ms");
    }
    const std::uint64_t key = ++stream_keys_;
    {
      const std::lock_guard<std::mutex> lock(stream_mutex_);
      pending_keys_.emplace(key, false);  // open for the caller from now on, until the strand takes it
    }
    StreamEntry entry;
    entry.method = op.method;
    entry.request = std::move(op.request);
    entry.period = static_cast<std::uint32_t>(period.count());
    entry.handler = std::move(handler);
    post_to_strand([this, key, entry = std::move(entry)]() mutable {
      {
        // Taken in one step: a close() before it finds the key pending and marks it (it never starts), a
        // close() after it finds it open and posts its close here.
        const std::lock_guard<std::mutex> lock(stream_mutex_);
        const auto pending = pending_keys_.find(key);
        if (pending == pending_keys_.end()) return;
        const bool closed = pending->second;
        pending_keys_.erase(pending);
        if (closed) return;
        open_keys_.insert(key);
      }
      if (!is_open() || link_error()) {
        publish_streams();
        call_stream_handler(entry.handler, closed_error(), StreamMessage());
        return;
      }
      // One stream per method (the device's rule): the older one stops here.
      for (auto it = streams_.begin(); it != streams_.end();) {
        it = it->second.method == entry.method ? streams_.erase(it) : std::next(it);
      }
      streams_.emplace(key, std::move(entry));
      publish_streams();
      if (mismatch_) {
        end_stream(key, make_error_code(RpcError::schema_mismatch), DeviceError());
        return;
      }
      queue_open(key);
      pump(now());
    });
    return key;
  }

  // Any thread. `done` (may be empty) completes once the device no longer runs the stream as far as the
  // client can tell: its close acked, or nothing to tell it (never opened there, its session gone); with the
  // close's error otherwise (timed_out, queue_timeout, the link's).
  void close_stream(std::uint64_t key, CallHandler done = CallHandler()) {
    {
      const std::lock_guard<std::mutex> lock(stream_mutex_);
      const auto pending = pending_keys_.find(key);
      if (pending != pending_keys_.end()) {  // the strand has not taken it: it never starts
        pending->second = true;
        if (done) post_completion(std::move(done), error_code(), CallResult());
        return;
      }
      open_keys_.erase(key);
      closing_keys_.insert(key);  // no delivery from now on, until the strand has removed it
    }
    post_to_strand([this, key, done = std::move(done)]() mutable {
      {
        const std::lock_guard<std::mutex> lock(stream_mutex_);
        closing_keys_.erase(key);
      }
      const auto found = streams_.find(key);
      if (found == streams_.end()) {  // ended already (a device error, the link): nothing runs on the device
        if (done) post_completion(std::move(done), error_code(), CallResult());
        return;
      }
      const std::uint32_t wire_id = found->second.wire_id;
      const bool opening = found->second.opening;
      streams_.erase(found);
      if (!is_open() || link_error()) {
        if (done) post_completion(std::move(done), closed_error(), CallResult());
        return;
      }
      const Millis now = this->now();
      if (wire_id != 0) {
        Op close;
        close.kind = Op::Kind::close;
        close.close_target = wire_id;
        // A waiter's close does not wait for a session for ever (the device may be gone).
        ops_.add(0, std::move(done), std::move(close), done ? deadline_after(now, options_.timing.call_budget) : Deadline());
        pump(now);
        return;
      }
      if (opening && done) {
        // Its open is on its way: finish_open sends the close once it is acked, and completes `done` then.
        for (auto it = ops_.begin(); it != ops_.end(); ++it) {
          if (it->state.kind != Op::Kind::open || it->state.stream != key) continue;
          if (it->state.stage == Op::Stage::queued) {  // never sent: the device never ran it
            ops_.complete(it, error_code(), CallResult());
          } else {
            it->handler = std::move(done);
          }
          pump(now);
          return;
        }
      }
      if (done) post_completion(std::move(done), error_code(), CallResult());
    });
  }

  bool stream_open(std::uint64_t key) const {
    const std::lock_guard<std::mutex> lock(stream_mutex_);
    const auto pending = pending_keys_.find(key);
    return (pending != pending_keys_.end() && !pending->second) || open_keys_.count(key) != 0;
  }

 private:
  struct Empty {};
  using ReadyWaiters = client::PendingOperations<ReadySignature, Empty>;
  enum class Untracked : std::uint8_t { ping, hello };
  struct UntrackedId {
    std::uint32_t id = 0;
    Untracked kind = Untracked::ping;
    bool used = false;
  };

  static session::SessionTiming hello_timing(const RpcTiming& timing) {
    session::SessionTiming session;
    session.reset_timeout = timing.hello_timeout;  // here "Reset" is the Hello: nothing restarts
    return session;
  }
  static Deadline deadline_after(Millis now, Duration duration) {
    Deadline deadline;
    deadline.arm(now, duration);
    return deadline;
  }
  error_code closed_error() const { return link_error() ? link_error() : error_code(asio::error::operation_aborted); }

  // The request checked against the schema and encoded (any thread: the schema does not change).
  error_code build(CallRequest& call, bool stream, Op& op) const {
    const Method* method = messages_->schema().find(call.method);
    if (method == nullptr) return RpcError::unknown_method;
    if (method->streaming != stream) return RpcError::wrong_kind;
    if (call.type != method->input && call.type->full_name() != method->input->full_name()) {
      return RpcError::invalid_request;
    }
    if (!call.encoded) return RpcError::invalid_request;
    if (call.type != method->input) {  // the same type from another pool (a generated class): its bytes checked
      std::shared_ptr<pb::Message> own = messages_->make(method->input);
      if (!own->ParseFromString(call.request)) return RpcError::invalid_request;
    }
    if (call.request.size() > kMaxRequestBytes) return RpcError::request_too_large;
    op.kind = stream ? Op::Kind::open : Op::Kind::call;
    op.method = method;
    op.request = std::move(call.request);
    op.typed = call.reply;
    return error_code();
  }

  void queue_open(std::uint64_t key) {
    StreamEntry& entry = streams_.at(key);
    entry.opening = true;
    Op open;
    open.kind = Op::Kind::open;
    open.method = entry.method;
    open.request = entry.request;
    open.period = entry.period;
    open.stream = key;
    ops_.add(0, CallHandler(), std::move(open));
  }

  // --- the pump ----------------------------------------------------------------------------------------

  void pump(Millis now) {
    if (!is_open() || link_error()) return;
    for (;;) {
      const Table::Step step = table_.poll(now);
      if (step.action == Table::Action::idle) break;
      if (step.action == Table::Action::resend) {
        const auto found = in_flight_.find(step.id);
        if (found != in_flight_.end()) write(found->second->state.frame);
      } else {
        on_completion(step.completion);
      }
    }
    run_monitor(now);
    if (options_.timing.ping_period > 0 && heartbeat_.due(now) && id_window_open()) {
      send_untracked(Untracked::ping);
      heartbeat_.beat_sent(now);
    }
    ops_.expire_if(now, [](const Ops::Operation& op) { return op.state.stage == Op::Stage::queued; },
                   [](Ops::Operation&) { return std::tuple<error_code, CallResult>(RpcError::queue_timeout, CallResult()); });
    ready_.expire(now, [](ReadyWaiters::Operation&) {
      return std::tuple<error_code, std::uint32_t>(RpcError::queue_timeout, 0);
    });
    if (established_) start_queued(now);
    arm_timer();
    publish();
  }

  void run_monitor(Millis now) {
    for (;;) {
      const Monitor::Action action = monitor_.poll(now);
      switch (action.kind) {
        case Monitor::ActionKind::none:
          return;
        case Monitor::ActionKind::send_reset:  // the Hello
          send_untracked(Untracked::hello);
          break;
        case Monitor::ActionKind::reset_detected:
          lose_session();
          emit(events::ResetDetected{detected_.first, detected_.second});
          break;
        case Monitor::ActionKind::replay_init:
          break;  // no inits: streams are opened again below
        case Monitor::ActionKind::established:
          establish();
          break;
      }
    }
  }

  void establish() {
    established_ = true;
    std::size_t reopened = 0;
    for (auto& [key, entry] : streams_) {
      if (entry.wire_id != 0 || entry.opening) continue;
      queue_open(key);
      ++reopened;
    }
    emit(events::SessionEstablished{monitor_.session_id(), ever_established_ ? reopened : 0, !ever_established_});
    ever_established_ = true;
    for (auto it = ready_.begin(); it != ready_.end();) it = ready_.complete(it, error_code(), monitor_.session_id());
  }

  // The device's session ended: calls in flight fail with device_reset; opens and closes are dropped (the
  // streams are opened again in the next session; the device closed them all).
  void lose_session() {
    established_ = false;
    std::map<std::uint32_t, Ops::iterator> in_flight = std::move(in_flight_);
    in_flight_.clear();
    for (auto& [id, op] : in_flight) {
      const Result<Table::Completion> cancelled = table_.cancel(id);
      finish_dropped(op, RpcError::device_reset, cancelled.ok() ? cancelled.value().attempts : 0);
    }
    for (auto it = ops_.begin(); it != ops_.end();) {
      it = it->state.kind != Op::Kind::call ? ops_.complete(it, error_code(), CallResult()) : std::next(it);
    }
    for (auto& [key, entry] : streams_) {
      entry.wire_id = 0;
      entry.opening = false;
    }
    publish_streams();
    refresh_table_timing();
  }

  // An op that left the table without its completion (reset, cancel): a call completes with `error`.
  void finish_dropped(Ops::iterator op, const error_code& error, std::uint8_t attempts) {
    if (op->state.kind == Op::Kind::open) {
      const auto found = streams_.find(op->state.stream);
      if (found != streams_.end()) found->second.opening = false;
    }
    if (op->state.kind != Op::Kind::call) {
      ops_.complete(op, error_code(), CallResult());  // the device's session ended: its streams with it
      return;
    }
    CallResult result;
    result.message_id = op->state.id;
    result.attempts = attempts;
    ops_.complete(op, error, std::move(result));
  }

  // --- sending -----------------------------------------------------------------------------------------

  std::uint32_t next_id() {
    return ids_.next([this](std::uint32_t id) { return table_.contains(id); });
  }
  // The ids in flight and their anchors (message_ids.hpp: the device's duplicate filter keeps each unacked
  // message while every new id stays within kIdWindow of its anchor).
  auto in_flight_ids() const { return in_flight_ | std::views::keys; }
  bool id_window_open() const {
    return ids_.window_open(in_flight_ | std::views::transform([](const auto& entry) { return entry.second->state.anchor; }),
                            [this](std::uint32_t id) { return table_.contains(id); });
  }

  void start_queued(Millis now) {
    for (auto it = ops_.begin(); it != ops_.end(); ++it) {
      if (it->state.stage != Op::Stage::queued) continue;
      if (table_.in_flight() >= kMaxInFlight || !id_window_open()) return;
      begin_send(it, now);
    }
  }

  void begin_send(Ops::iterator op, Millis now) {
    const std::uint32_t id = next_id();
    envelope::HostMessage message;
    message.id = id;
    switch (op->state.kind) {
      case Op::Kind::call:
        message.body = envelope::HostBody::call;
        message.method = op->state.method->index;
        message.request = ByteView::from_chars(op->state.request.data(), op->state.request.size());
        break;
      case Op::Kind::open:
        message.body = envelope::HostBody::open;
        message.method = op->state.method->index;
        message.request = ByteView::from_chars(op->state.request.data(), op->state.request.size());
        message.period_ms = op->state.period;
        break;
      case Op::Kind::close:
        message.body = envelope::HostBody::close;
        message.stream = op->state.close_target;
        break;
    }
    op->state.stage = Op::Stage::in_flight;
    op->deadline.disarm();  // the engine's budget from now on
    op->state.id = id;
    op->state.anchor = ids_.anchor(id, in_flight_ids());
    op->state.frame = frame_of(message);
    op->state.request = std::string();  // sent once: re-sends are the frame's
    refresh_table_timing(op->state.frame->size());
    (void)table_.begin_with(id, now);  // a slot is free and the id is not in flight
    ++counters_.messages_sent;
    in_flight_.emplace(id, op);
    write(op->state.frame);
  }

  // The frame of `message`, in a string of an earlier frame nobody holds any more (its message ended and
  // its write completed) when there is one: no allocation per message once the client runs.
  std::shared_ptr<const std::string> frame_of(const envelope::HostMessage& message) {
    std::shared_ptr<std::string>* free = nullptr;
    for (std::shared_ptr<std::string>& spare : spare_frames_) {
      if (!spare || spare.use_count() == 1) {
        free = &spare;
        break;
      }
    }
    std::shared_ptr<std::string> frame;
    if (free == nullptr) {
      frame = std::make_shared<std::string>();
    } else {
      if (!*free) *free = std::make_shared<std::string>();
      frame = *free;
    }
    envelope::write_frame(message, *frame);
    return frame;
  }

  void refresh_table_timing(std::size_t starting_frame = 0) {
    std::size_t longest = starting_frame;
    for (const auto& entry : in_flight_) longest = std::max(longest, entry.second->state.frame->size());
    table_.set_timing(proxy::call_timing(ack_timing(options_.timing), longest + kAnswerFrameBytes));
  }

  void send_untracked(Untracked kind) {
    envelope::HostMessage message;
    const std::uint32_t id = next_id();
    message.id = id;
    if (kind == Untracked::ping) {
      message.body = envelope::HostBody::ping;
      ++counters_.pings_sent;
    } else {
      message.body = envelope::HostBody::hello;
      ++counters_.hellos_sent;
    }
    UntrackedId& slot = untracked_[untracked_next_++ % untracked_.size()];
    slot = UntrackedId{id, kind, true};
    write(frame_of(message));
  }

  // --- completions -------------------------------------------------------------------------------------

  void on_completion(const Table::Completion& completion) {
    const auto found = in_flight_.find(completion.id);
    if (found == in_flight_.end()) return;
    const Ops::iterator op = found->second;
    in_flight_.erase(found);
    refresh_table_timing();
    error_code error;
    switch (completion.outcome) {
      case session::CallOutcome::ok:
        break;
      case session::CallOutcome::cancelled:
        error = asio::error::operation_aborted;
        break;
      case session::CallOutcome::timeout:
        error = RpcError::timed_out;
        break;
      case session::CallOutcome::remote_error:
        error = RpcError::refused;
        break;
    }
    if (op->state.kind == Op::Kind::open) {
      finish_open(op, error);
      return;
    }
    if (op->state.kind == Op::Kind::close) {
      // Refused: the device runs no such stream (it ended there already), which is what closing wants.
      ops_.complete(op, error == RpcError::refused ? error_code() : error, CallResult());
      return;
    }
    CallResult result;
    result.message_id = completion.id;
    result.attempts = completion.attempts;
    if (!error && op->state.failed) {
      error = op->state.error.code >= 0xFF00 ? RpcError::refused : RpcError::device_error;
    }
    if (error == RpcError::refused || error == RpcError::device_error) {
      result.device_error = op->state.error;
      ++(error == RpcError::refused ? counters_.refusals : counters_.device_errors);
    }
    if (!error) {
      const TypedReply& typed = op->state.typed;
      result.reply = typed.make != nullptr && typed.type == op->state.method->output
                         ? typed_replies_.take(typed)
                         : messages_->make(op->state.method->output);
      if (!messages_->parse(*result.reply, ByteView::from_chars(op->state.reply.data(), op->state.reply.size()))) {
        result.reply.reset();
        error = RpcError::bad_reply;
      } else {
        ++counters_.replies;
      }
    }
    ops_.complete(op, error, std::move(result));
  }

  void finish_open(Ops::iterator op, const error_code& error) {
    const std::uint64_t key = op->state.stream;
    const std::uint32_t id = op->state.id;
    const DeviceError device_error = op->state.error;
    CallHandler closing = std::move(op->handler);  // a close_stream waiter, when it was closed meanwhile
    ops_.erase(op);
    const auto found = streams_.find(key);
    if (found == streams_.end()) {  // closed meanwhile: stop it on the device too
      if (!error) {
        Op close;
        close.kind = Op::Kind::close;
        close.close_target = id;
        ops_.add(0, std::move(closing), std::move(close));
      } else if (closing) {  // refused: the device never ran it; else whether it did is unknown
        post_completion(std::move(closing), error == RpcError::refused ? error_code() : error, CallResult());
      }
      return;
    }
    found->second.opening = false;
    if (error) {
      if (error == RpcError::refused) ++counters_.refusals;
      end_stream(key, error, device_error);
      return;
    }
    found->second.wire_id = id;
    publish_streams();
  }

  void end_stream(std::uint64_t key, const error_code& error, const DeviceError& device_error) {
    const auto found = streams_.find(key);
    if (found == streams_.end()) return;
    StreamHandler handler = std::move(found->second.handler);
    streams_.erase(found);
    publish_streams();
    StreamMessage end;
    end.device_error = device_error;
    if (delivering(key)) call_stream_handler(handler, error, end);
  }

  void call_stream_handler(const StreamHandler& handler, const error_code& error, const StreamMessage& message) {
    if (!handler) return;
    publish();
    try {
      handler(error, message);
    } catch (...) {  // the application's: as for event handlers, never out of the strand
    }
  }

  void fail_all(const error_code& error) {
    fail_waiting(error);
    std::map<std::uint64_t, StreamEntry> streams = std::move(streams_);
    streams_.clear();
    publish_streams();
    for (auto& [key, entry] : streams) {
      if (delivering(key)) call_stream_handler(entry.handler, error, StreamMessage());
    }
  }

  // Every call, open, close and readiness wait fails with `error`; the streams stay (fail_all ends them).
  void fail_waiting(const error_code& error) {
    ops_.fail_all([&](Ops::Operation& op) {
      CallResult result;
      if (op.state.stage == Op::Stage::in_flight) {
        const Result<Table::Completion> cancelled = table_.cancel(op.state.id);
        result.message_id = op.state.id;
        result.attempts = cancelled.ok() ? cancelled.value().attempts : 0;
      }
      return std::tuple<error_code, CallResult>(error, result);
    });
    ready_.fail_all([&](ReadyWaiters::Operation&) { return std::tuple<error_code, std::uint32_t>(error, 0); });
    in_flight_.clear();
    abort_writes(error);
    established_ = false;
  }

  void on_cancel(OperationId operation) override {
    const bool cancelled = ops_.cancel(operation, [&](Ops::Operation& op) {
      CallResult result;
      if (op.state.stage == Op::Stage::in_flight) {
        const Result<Table::Completion> ended = table_.cancel(op.state.id);
        in_flight_.erase(op.state.id);
        refresh_table_timing();
        result.message_id = op.state.id;
        result.attempts = ended.ok() ? ended.value().attempts : 0;
      }
      return std::tuple<error_code, CallResult>(asio::error::operation_aborted, result);
    });
    const bool waiter = ready_.cancel(operation, [](ReadyWaiters::Operation&) {
      return std::tuple<error_code, std::uint32_t>(asio::error::operation_aborted, 0);
    });
    if (cancelled || waiter) pump(now());
  }

  // --- the device's messages ---------------------------------------------------------------------------

  void on_bytes(const std::uint8_t* data, std::size_t size) override {
    const Millis now = this->now();
    std::size_t used = 0;
    while (used < size && is_open() && !link_error()) {
      const FeedResult fed = decoder_.feed(ByteView(data + used, size - used));
      used += fed.consumed;
      if (fed.status == DecodeStatus::frame) on_payload(decoder_.frame(), now);
    }
    pump(now);
  }

  void on_payload(ByteView payload, Millis now) {
    envelope::DeviceMessage out;
    if (envelope::decode(payload, out) != envelope::DecodeError::none) {
      ++counters_.undecodable;
      return;
    }
    switch (out.body) {
      case envelope::DeviceBody::ack:
        on_ack(out.ack.id, out.ack.refused, now);
        return;
      case envelope::DeviceBody::reply:
        on_answer(out.reply.call, false, out.reply.reply, DeviceError());
        return;
      case envelope::DeviceBody::error:
        on_answer(out.error.call, true, ByteView(),
                  DeviceError{static_cast<std::uint16_t>(std::min<std::uint32_t>(out.error.code, 0xFFFF)),
                              envelope::device_text(out.error.text)});
        return;
      case envelope::DeviceBody::stream:
        on_stream_message(out.stream);
        return;
      case envelope::DeviceBody::hello:
        on_hello(out.hello, now);
        return;
      case envelope::DeviceBody::reset:
        // A boot announcement: adopted only through the Hello that follows (it carries the schema).
        tell_monitor(out.reset.session, [&] { monitor_.on_session_report(out.reset.session, now); });
        run_monitor(now);
        return;
      case envelope::DeviceBody::none:
        ++counters_.undecodable;
        return;
    }
  }

  void on_answer(std::uint32_t call, bool failed, ByteView reply, DeviceError error) {
    const auto found = in_flight_.find(call);
    if (found != in_flight_.end()) {
      Op& op = found->second->state;
      op.answered = true;
      op.failed = failed;
      op.reply.assign(reinterpret_cast<const char*>(reply.data()), reply.size());
      op.error = std::move(error);
      return;
    }
    if (failed) {
      for (auto& [key, entry] : streams_) {
        if (entry.wire_id == call && call != 0) {
          ++(error.code >= 0xFF00 ? counters_.refusals : counters_.device_errors);
          end_stream(key, error.code >= 0xFF00 ? RpcError::refused : RpcError::device_error, error);
          return;
        }
      }
      emit(events::DeviceErrorReport{std::move(error)});
    }
    // A late answer of a call that already ended: the ack that follows is counted stale.
  }

  void on_ack(std::uint32_t id, bool refused, Millis now) {
    const auto found = in_flight_.find(id);
    if (found != in_flight_.end() && table_.contains(id)) {
      const Op& op = found->second->state;
      Policy::Code code = Policy::kAcked;
      if (refused) {
        code = Policy::kRefused;
      } else if (op.kind == Op::Kind::call) {
        code = op.answered ? Policy::kAnswered : Policy::kAckedWithoutAnswer;
      }
      const Table::ReplyResult reply = table_.on_reply(id, code, now);
      if (reply.verdict == Table::Verdict::completed) {
        on_completion(reply.completion);
      } else if (reply.verdict == Table::Verdict::resend) {
        write(found->second->state.frame);
      }
      return;
    }
    for (const UntrackedId& slot : untracked_) {
      if (slot.used && slot.id == id) return;  // a ping's or a hello's
    }
    (void)table_.on_reply(id, 0, now);  // not in flight: the table counts it stale
  }

  void on_stream_message(const envelope::DeviceMessage::Stream& message) {
    for (auto& [key, entry] : streams_) {
      if (entry.wire_id != message.stream || message.stream == 0) continue;
      StreamMessage delivered;
      std::shared_ptr<pb::Message> decoded = messages_->make(entry.method->output);
      if (!messages_->parse(*decoded, message.message)) {
        ++counters_.undecodable;
        return;
      }
      delivered.message = std::move(decoded);
      delivered.seq = message.seq;
      ++counters_.stream_messages;
      if (!delivering(key)) return;
      const StreamHandler handler = entry.handler;  // the handler may close its own stream
      call_stream_handler(handler, error_code(), delivered);
      return;
    }
    ++counters_.stale_stream_messages;
  }

  void on_hello(const envelope::DeviceMessage::Hello& hello, Millis now) {
    device_hash_ = hello.schema_hash;
    if (hello.schema_hash != messages_->schema().hash()) {
      if (!mismatch_) {
        mismatch_ = true;
        events::SchemaMismatch event;
        event.device_hash = hello.schema_hash;
        event.schema_hash = messages_->schema().hash();
        event.text = mismatch_text(messages_->schema(), hello.schema_hash);
        emit(event);
      }
      established_ = false;
      monitor_.start(now);  // Hello again until a device with this schema answers (a reflashed one)
      const error_code error = RpcError::schema_mismatch;
      ops_.fail_all([&](Ops::Operation& op) {
        if (op.state.stage == Op::Stage::in_flight) (void)table_.cancel(op.state.id);
        return std::tuple<error_code, CallResult>(error, CallResult());
      });
      in_flight_.clear();
      ready_.fail_all([&](ReadyWaiters::Operation&) { return std::tuple<error_code, std::uint32_t>(error, 0); });
      std::map<std::uint64_t, StreamEntry> streams = std::move(streams_);
      streams_.clear();
      publish_streams();
      for (auto& [key, entry] : streams) {
      if (delivering(key)) call_stream_handler(entry.handler, error, StreamMessage());
    }
      return;
    }
    mismatch_ = false;
    if (monitor_.state() == session::SessionState::awaiting_reset_event) {
      monitor_.on_reset_event(hello.session, now);
    } else {
      tell_monitor(hello.session, [&] { monitor_.on_session_report(hello.session, now); });
    }
    run_monitor(now);
  }


  template <typename Tell>
  void tell_monitor(std::uint32_t reported, Tell&& tell) {
    const bool was_in_session = monitor_.state() == session::SessionState::replaying ||
                                monitor_.state() == session::SessionState::established;
    const std::uint32_t stored = monitor_.session_id();
    tell();
    const bool in_session = monitor_.state() == session::SessionState::replaying ||
                            monitor_.state() == session::SessionState::established;
    if (was_in_session && !in_session) detected_ = {stored, reported};
  }

  // --- link hooks, timer, state ------------------------------------------------------------------------

  void on_timer() override { pump(now()); }
  void on_link_failed(const error_code& error) override {
    // A supervised port that vanished is away, not gone: what waits fails, but the streams stay the
    // application's and are opened again on the device once the port is back (on_link_restored).
    if (error == transports::TransportError::disconnected) {
      fail_waiting(error);
    } else {
      fail_all(error);
    }
    emit(events::LinkFailed{error});
    publish();
  }
  // The device may have lost power with its port (its streams closed, a new session whose Hello went
  // nowhere): the session starts again as at the open (Hello, then every stream opened again).
  void on_link_restored() override {
    const Millis now = this->now();
    lose_session();
    monitor_.start(now);
    pump(now);
  }
  void on_closed() override {
    fail_all(asio::error::operation_aborted);
    publish();
  }

  void arm_timer() {
    Deadline wakeup = ops_.next_deadline();
    consider(wakeup, ready_.next_deadline());
    consider(wakeup, table_.next_wakeup());
    consider(wakeup, monitor_.next_wakeup());
    if (options_.timing.ping_period > 0 && id_window_open()) consider(wakeup, heartbeat_.next());
    ClientLink::arm_timer(wakeup);
  }

  void emit(const Event& event) {
    publish();
    events_.emit(event);
  }

  void publish() {
    published_.set(counters_);
    SessionStatus session;
    session.established = established_;
    if (monitor_.has_session()) session.session_id = monitor_.session_id();
    if (device_hash_ != 0) session.device_hash = device_hash_;
    published_session_.set(session);
  }

  // What `stream_open` reads (streams being closed excluded).
  void publish_streams() {
    const std::lock_guard<std::mutex> lock(stream_mutex_);
    open_keys_.clear();
    for (const auto& [key, entry] : streams_) {
      if (closing_keys_.count(key) == 0) open_keys_.insert(key);
    }
  }
  // False once the application closed stream `key` (its close on its way here): no more deliveries.
  bool delivering(std::uint64_t key) const {
    const std::lock_guard<std::mutex> lock(stream_mutex_);
    return closing_keys_.count(key) == 0;
  }

  const Options options_;
  const std::shared_ptr<Messages> messages_;

  // Strand only.
  Counters counters_;
  Ops ops_;  // in acceptance order
  ReadyWaiters ready_;
  envelope::FrameReader<kMaxPayload> decoder_;
  Table table_;
  session::HeartbeatSchedule heartbeat_;
  Monitor monitor_;
  client::MessageIds ids_;
  std::array<UntrackedId, 8> untracked_{};
  std::array<std::shared_ptr<std::string>, kMaxInFlight + 4> spare_frames_;  // frame_of's strings
  TypedReplies typed_replies_;  // typed calls' replies
  std::size_t untracked_next_ = 0;
  std::map<std::uint32_t, Ops::iterator> in_flight_;  // by message id
  std::map<std::uint64_t, StreamEntry> streams_;     // by key
  bool established_ = false;
  bool ever_established_ = false;
  bool mismatch_ = false;
  std::uint64_t device_hash_ = 0;
  std::pair<std::uint32_t, std::uint32_t> detected_{0, 0};

  // Any thread.
  std::atomic<std::uint64_t> stream_keys_{0};
  mutable std::mutex stream_mutex_;
  std::map<std::uint64_t, bool> pending_keys_;  // opened by the caller, not yet taken by the strand (true: closed)
  std::set<std::uint64_t> open_keys_;           // the strand's streams, as last published
  std::set<std::uint64_t> closing_keys_;        // closed by the caller, not yet removed by the strand
  client::Published<Counters> published_;
  client::Published<SessionStatus> published_session_;
  client::EventHandlers<Event> events_;
};

void start_call(const std::shared_ptr<ClientImpl>& impl, client::ClientLink::OperationId operation,
                CallHandler handler, CallRequest call) {
  impl->submit_call(operation, std::move(call), std::move(handler));
}

}  // namespace detail

// ---------------------------------------------------------------------------------------------------------
// Stream

Stream::Stream(Stream&& other) noexcept : client_(std::move(other.client_)), key_(std::exchange(other.key_, 0)) {}

Stream& Stream::operator=(Stream&& other) noexcept {
  if (this != &other) {
    close();
    client_ = std::move(other.client_);
    key_ = std::exchange(other.key_, 0);
  }
  return *this;
}

Stream::~Stream() { close(); }

void Stream::close() {
  if (key_ == 0) return;
  if (const auto client = client_.lock()) client->close_stream(key_);
  key_ = 0;
}

void Stream::close_and_wait(error_code& error) {
  error = error_code();
  const std::uint64_t key = std::exchange(key_, 0);
  if (key == 0) return;
  const auto impl = client_.lock();
  if (!impl) return;  // the client is gone, and its streams with it
  (void)client::wait_for_operation<CallResult>(
      *impl, [&](client::ClientLink::OperationId, detail::CallHandler handler) {
        impl->close_stream(key, std::move(handler));
      },
      error);
}

void Stream::close_and_wait(error_code& error, std::chrono::milliseconds limit) {
  error = error_code();
  const std::uint64_t key = std::exchange(key_, 0);
  if (key == 0) return;
  const auto impl = client_.lock();
  if (!impl) return;
  if (impl->on_strand()) {
    impl->close_stream(key);
    error = transports::TransportError::would_deadlock;
    return;
  }
  // Shared with the completion, which may come after the wait gave up.
  auto done = std::make_shared<std::promise<error_code>>();
  std::future<error_code> acked = done->get_future();
  impl->close_stream(key, detail::CallHandler([done](error_code e, CallResult) { done->set_value(e); }));
  error = acked.wait_for(limit) == std::future_status::ready ? acked.get() : make_error_code(RpcError::timed_out);
}

bool Stream::is_open() const {
  const auto client = client_.lock();
  return key_ != 0 && client && client->stream_open(key_);
}

// ---------------------------------------------------------------------------------------------------------
// Client

namespace {
std::shared_ptr<detail::ClientImpl> make_impl(std::shared_ptr<transports::ByteStream> stream, Schema schema,
                                              const Options& options) {
  stream = client::require_stream(std::move(stream), "rpc::Client");
  const RpcTiming& timing = options.timing;
  if (timing.baud == 0 || timing.bits_per_byte == 0 || timing.call_budget == 0 || timing.max_sends == 0 ||
      timing.hello_timeout == 0) {
    throw std::invalid_argument("rpc::Client: baud, bits_per_byte, call_budget, max_sends and hello_timeout must be > 0");
  }
  return std::make_shared<detail::ClientImpl>(std::move(stream), std::move(schema), options);
}
}  // namespace

Client::Client(std::shared_ptr<transports::ByteStream> stream, Schema schema, const Options& options,
               EventHandler handler)
    : ClientFront(make_impl(std::move(stream), std::move(schema), options)) {
  on_event(std::move(handler));
  impl()->start();
}

const Schema& Client::schema() const { return impl()->messages()->schema(); }

void Client::start_wait_ready(const std::shared_ptr<detail::ClientImpl>& impl,
                              client::ClientLink::OperationId operation,
                              transports::UniqueFunction<ReadySignature> handler) {
  impl->submit_ready(operation, std::move(handler));
}

void Client::wait_ready(error_code& error) {
  (void)client::wait_for_operation<std::uint32_t>(
      link(),
      [&](client::ClientLink::OperationId operation, transports::UniqueFunction<ReadySignature> handler) {
        impl()->submit_ready(operation, std::move(handler));
      },
      error);
}

void Client::wait_ready() {
  error_code error;
  wait_ready(error);
  if (!error) return;
  if (error == RpcError::schema_mismatch) {
    // A mismatch is only known from a DeviceHello, whose hash the session holds.
    throw boost::system::system_error(error, mismatch_text(schema(), session().device_hash.value_or(0)));
  }
  throw boost::system::system_error(error, "rpc wait_ready");
}

std::shared_ptr<google::protobuf::Message> Client::new_request(std::string_view method) const {
  const Method* found = schema().find(method);
  if (found == nullptr) throw std::invalid_argument("no method " + std::string(method) + " in " + schema().file().string());
  return impl()->messages()->make(found->input);
}

CallResult Client::call(std::string_view method, const google::protobuf::Message& request, error_code& error) {
  return call(detail::make_call_request(method, request), error);
}

CallResult Client::call(std::string_view method, const google::protobuf::Message& request) {
  return call(detail::make_call_request(method, request));
}

CallResult Client::call(detail::CallRequest call, error_code& error) {
  return client::wait_for_operation<CallResult>(
      link(),
      [&](client::ClientLink::OperationId operation, detail::CallHandler handler) {
        impl()->submit_call(operation, std::move(call), std::move(handler));
      },
      error);
}

CallResult Client::call(detail::CallRequest call) {
  const std::string method = call.method;
  error_code error;
  CallResult result = this->call(std::move(call), error);
  if (error == RpcError::device_error || error == RpcError::refused) {
    throw CallError(error, method, result.device_error);
  }
  if (error) throw boost::system::system_error(error, "rpc call " + method);
  return result;
}

std::string Client::call_json(std::string_view method, std::string_view json_request) {
  std::shared_ptr<google::protobuf::Message> request;
  try {
    request = new_request(method);
  } catch (const std::invalid_argument&) {
    throw boost::system::system_error(make_error_code(RpcError::unknown_method),
                                      "no method " + std::string(method) + " in " + schema().file().string());
  }
  const auto parsed = impl()->messages()->json().from_json(json_request, *request);
  if (!parsed.ok()) {
    throw boost::system::system_error(make_error_code(RpcError::invalid_request),
                                      std::string(method) + ": " + std::string(parsed.message()));
  }
  const CallResult result = call(method, *request);
  std::string json;
  google::protobuf::util::JsonPrintOptions options;
  options.always_print_primitive_fields = true;
  (void)impl()->messages()->json().to_json(*result.reply, json, options);
  return json;
}

Stream Client::open_stream(std::string_view method, const google::protobuf::Message& request,
                           std::chrono::milliseconds period, StreamHandler handler) {
  const std::uint64_t key = impl()->open_stream(method, request, period, std::move(handler));
  return Stream(impl(), key);
}

Counters Client::counters() const { return impl()->counters(); }
SessionStatus Client::session() const { return impl()->session(); }

}  // namespace tether::rpc
