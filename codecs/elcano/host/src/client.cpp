// RingClient: the portable RingNode and the Elcano session engine (elcano::RequestTable) driven by the read
// loop, the write queue and the timer of a client::ClientLink, like romi::Client and
// proxy::Client (the link owns the strand, close and the lifetime rules).
//
// Everything below `RingClientImpl`'s public functions runs on the link's strand. All timed work goes
// through `pump(now)`: the node's deadlines (partial message, origin records), the engine's (re-sends,
// timeouts), the send and receive deadlines, originating what waits for room, and handing paced output to
// the stream; the one timer is re-armed at the earliest deadline after every pump. One write is on the
// stream at a time: the bytes of the next one are taken from the node when it completes, so a stream that
// does not take bytes fills the node's queue (forwarding then drops and reports, sends wait) instead of an
// unbounded write queue.
#include "tether/elcano/client.hpp"

#include <boost/asio/error.hpp>
#include <boost/system/system_error.hpp>

#include <algorithm>
#include <array>
#include <deque>
#include <map>
#include <mutex>
#include <stdexcept>
#include <string>
#include <tuple>
#include <utility>
#include <vector>

#include "tether/client/client_link.hpp"
#include "tether/client/pending_operations.hpp"
#include "tether/core/wakeup.hpp"

namespace tether::elcano {

namespace asio = boost::asio;
using transports::ByteStream;

namespace detail {
namespace {

using Node = RingNode<kMaxMessageBytes, kOutputQueueBytes, kOriginRecords>;
using Table = RequestTable;

bool known_type(Type type) {
  switch (type) {
    case Type::drive:
    case Type::sensor:
    case Type::goal:
    case Type::segment:
      return true;
  }
  return false;
}

// The bytes the node writes for `message` (empty when it cannot be written): what a request is recognised
// by when it comes back.
std::string encode(const Message& message, Generation generation) {
  std::array<std::uint8_t, kMaxMessageBytes> buffer{};
  const Result<size_t> size = encode_message(message, generation, MutableByteView(buffer.data(), buffer.size()));
  if (!size.ok()) return std::string();
  return std::string(reinterpret_cast<const char*>(buffer.data()), size.value());
}

}  // namespace

// ---------------------------------------------------------------------------------------------------------
// The implementation

class RingClientImpl final : public client::ClientLink {
 public:
  RingClientImpl(std::shared_ptr<ByteStream> stream, const Options& options)
      : ClientLink(std::move(stream), options.clock),
        options_(options),
        node_(options.node, now(), counters_.link, counters_.ring),
        table_(options.timing, 0, counters_.link),
        capture_(options.node.capture),
        pending_(executor(), [this] { publish(); }) {
    published_capture_.set(capture_);
  }

  // Starts the read loop (after construction: it needs shared_from_this).
  void start() {
    post_to_strand([this] {
      start_reading();
      pump(now());
    });
  }

  // --- submissions (any thread) ----------------------------------------------------------------------

  void submit_send(OperationId operation, const Message& message, SendHandler handler) {
    std::string bytes = encode(message, options_.node.generation);
    if (bytes.empty()) {
      post_completion(std::move(handler), error_code(RingError::invalid_message));
      return;
    }
    if (!is_open()) {
      post_completion(std::move(handler), error_code(asio::error::operation_aborted));
      return;
    }
    RingOperation send;
    send.kind = Kind::send;
    send.message = message;
    // One queue for every operation: a send's handler takes the message argument and drops it.
    MessageHandler completion = [handler = std::move(handler)](error_code error, Message) mutable { handler(error); };
    post_to_strand([this, operation, completion = std::move(completion), send = std::move(send)]() mutable {
      accept_send(operation, std::move(completion), std::move(send));
    });
  }

  void submit_request(OperationId operation, const Message& message, Type reply_type, MessageHandler handler) {
    std::string bytes = encode(message, options_.node.generation);
    if (bytes.empty()) {
      post_completion(std::move(handler), error_code(RingError::invalid_message), Message());
      return;
    }
    if (!known_type(reply_type)) {
      post_completion(std::move(handler), error_code(RingError::invalid_reply_type), Message());
      return;
    }
    if (!is_open()) {
      post_completion(std::move(handler), error_code(asio::error::operation_aborted), Message());
      return;
    }
    RingOperation call;
    call.kind = Kind::request;
    call.reply = reply_type;
    call.message = message;
    call.bytes = std::move(bytes);
    post_to_strand([this, operation, handler = std::move(handler), call = std::move(call)]() mutable {
      accept_request(operation, std::move(handler), std::move(call));
    });
  }

  void submit_receive(OperationId operation, std::optional<Duration> timeout, MessageHandler handler) {
    if (!is_open()) {
      post_completion(std::move(handler), error_code(asio::error::operation_aborted), Message());
      return;
    }
    post_to_strand([this, operation, timeout, handler = std::move(handler)]() mutable {
      accept_receive(operation, timeout, std::move(handler));
    });
  }

  void set_capture(TypeSet capture) {
    published_capture_.set(capture);
    post_to_strand([this, capture] {
      capture_ = capture;
      refresh_capture();
    });
  }

  TypeSet capture() const { return published_capture_.get(); }

  client::EventHandlers<Event>& event_handlers() { return events_; }

  Counters counters() const { return published_.get(); }

 private:
  enum class Kind : std::uint8_t { send, request, receive };
  // A send, a request or a receive from acceptance to completion (sends and receives may have a deadline:
  // `send_timeout` after acceptance, the receive's timeout).
  struct RingOperation {
    Kind kind = Kind::send;
    Message message;              // sends and requests
    // Sends and requests: handed to the node (else it waits for room in its output queue, in submission
    // order); `end` is the output offset after that origination's last byte. A send completes once the
    // stream took it; a request's reply type is captured from then on.
    bool originated = false;
    std::uint64_t end = 0;
    // Requests.
    Type reply = Type::segment;
    std::string bytes;            // as written: recognises the request when it comes back
    bool resend_pending = false;  // the engine asked for a re-send that found no room yet
  };
  using Operations = client::PendingOperations<MessageSignature, RingOperation>;
  using Entry = Operations::iterator;

  static bool waits_for_room(const RingOperation& operation) {
    return operation.kind != Kind::receive && !operation.originated;
  }

  // --- accepting operations ----------------------------------------------------------------------------

  // The link's state as an error for new operations (empty while it works).
  error_code unusable() const {
    if (link_error()) return link_error();
    if (!is_open()) return asio::error::operation_aborted;
    return error_code();
  }

  void accept_send(OperationId operation, MessageHandler handler, RingOperation send) {
    const Entry entry = pending_.add(operation, std::move(handler), std::move(send));
    if (const error_code error = unusable()) {
      pending_.complete(entry, error, Message());
      return;
    }
    const Millis now = this->now();
    entry->deadline.arm(now, options_.send_timeout);
    enqueue(entry, now);
    pump(now);
  }

  void accept_request(OperationId operation, MessageHandler handler, RingOperation call) {
    const Entry entry = pending_.add(operation, std::move(handler), std::move(call));
    if (const error_code error = unusable()) {
      pending_.complete(entry, error, Message());
      return;
    }
    const std::uint8_t id = call_id(entry->state.reply);
    const Millis now = this->now();
    if (calls_.count(id) != 0 || !table_.begin_with(id, now).ok()) {
      pending_.complete(entry, RingError::reply_type_busy, Message());
      return;
    }
    calls_.emplace(id, entry);
    enqueue(entry, now);
    pump(now);
  }

  void accept_receive(OperationId operation, std::optional<Duration> timeout, MessageHandler handler) {
    RingOperation receive;
    receive.kind = Kind::receive;
    const Entry entry = pending_.add(operation, std::move(handler), std::move(receive));
    if (const error_code error = unusable()) {
      pending_.complete(entry, error, Message());
      return;
    }
    if (!received_.empty() && first_receiver() == entry) {  // no receiver waits before it
      Message message = received_.front();
      received_.pop_front();
      pending_.complete(entry, error_code(), message);
      return;
    }
    if (timeout && *timeout == 0) {
      pending_.complete(entry, RingError::receive_timed_out, Message());
      return;
    }
    const Millis now = this->now();
    if (timeout) entry->deadline.arm(now, *timeout);
    pump(now);
  }

  Entry first_receiver() {
    return std::find_if(pending_.begin(), pending_.end(),
                        [](const Operations::Operation& operation) { return operation.state.kind == Kind::receive; });
  }

  // Originates `entry` now if nothing waits before it and there is room; else it waits within the bound.
  void enqueue(Entry entry, Millis now) {
    std::size_t waiting = 0;  // others waiting for room
    for (const auto& operation : pending_) {
      if (waits_for_room(operation.state)) ++waiting;
    }
    --waiting;  // `entry` itself
    if (waiting == 0 && !resend_waiting() && originate(entry, now)) return;
    if (waiting >= options_.send_queue_bound) {
      if (entry->state.kind == Kind::request) {
        (void)table_.cancel(call_id(entry->state.reply));
        calls_.erase(call_id(entry->state.reply));
      }
      pending_.complete(entry, RingError::send_queue_full, Message());
    }
  }

  // --- originating ---------------------------------------------------------------------------------------

  bool resend_waiting() const {
    return std::any_of(calls_.begin(), calls_.end(), [](const auto& entry) { return entry.second->state.resend_pending; });
  }

  // Hands `entry` to the node. False when the output queue has no room (it keeps waiting); true when it
  // was originated, or failed and completed (the entry is gone then).
  bool originate(Entry entry, Millis now) {
    RingOperation& operation = entry->state;
    const Status status = node_.originate(operation.message, now);
    if (status == Status::busy) return false;
    if (status != Status::ok) {  // not reached: validated on submission
      if (operation.kind == Kind::request) {
        (void)table_.cancel(call_id(operation.reply));
        calls_.erase(call_id(operation.reply));
      }
      pending_.complete(entry, RingError::invalid_message, Message());
      return true;
    }
    operation.originated = true;
    operation.end = taken_ + node_.pending_output();
    if (operation.kind == Kind::request) refresh_capture();
    return true;
  }

  // Re-sends first, then waiting messages in order, while the node has room.
  void originate_waiting(Millis now) {
    for (auto& [id, call] : calls_) {
      if (!call->state.resend_pending) continue;
      if (node_.originate(call->state.message, now) != Status::ok) return;
      call->state.resend_pending = false;
    }
    for (auto it = pending_.begin(); it != pending_.end();) {
      const Entry next = std::next(it);
      if (waits_for_room(it->state) && !originate(it, now)) return;
      it = next;
    }
  }

  // The node captures the configured set plus the reply types of requests sent and not completed.
  void refresh_capture() {
    TypeSet effective = capture_;
    for (const auto& [id, call] : calls_) {
      if (call->state.originated) effective = effective.with(call->state.reply);
    }
    node_.set_capture(effective);
  }

  // --- writing -------------------------------------------------------------------------------------------

  // Hands what the pacer allows to the stream, one write at a time.
  void flush(Millis now) {
    if (writing_ || unusable()) return;
    std::array<std::uint8_t, kOutputQueueBytes> buffer{};
    const std::size_t size = node_.take_output(MutableByteView(buffer.data(), buffer.size()), now);
    if (size == 0) return;
    taken_ += size;
    writing_ = true;
    write(std::make_shared<const std::string>(reinterpret_cast<const char*>(buffer.data()), size),
          [this, size](error_code error) { on_flushed(error, size); });
  }

  // Sends whose last byte the stream took complete.
  void on_flushed(const error_code& error, std::size_t size) {
    writing_ = false;
    if (error) return;  // closed or failed: on_closed / on_link_failed fail what waits
    written_total_ += size;
    counters_.bytes_written += static_cast<std::uint32_t>(size);
    for (auto it = pending_.begin(); it != pending_.end();) {
      const bool written = it->state.kind == Kind::send && it->state.originated && it->state.end <= written_total_;
      it = written ? pending_.complete(it, error_code(), Message()) : std::next(it);
    }
    pump(now());
  }

  // --- the ring ------------------------------------------------------------------------------------------

  // A received run goes to the node in one call up to each event (`RingNode::consume(bytes)`, the reader's
  // span loop): the same events as byte by byte, without a call and a copy of the message per byte (issue
  // 17). The message is copied only when there is an event.
  void on_bytes(const std::uint8_t* data, std::size_t size) override {
    const Millis now = this->now();
    std::size_t used = 0;
    while (used < size && !unusable()) {
      std::size_t consumed = 0;
      const RingEvent::Kind kind = node_.consume(ByteView(data + used, size - used), now, consumed);
      used += consumed;
      if (kind != RingEvent::Kind::none) on_ring_event(node_.event(kind), now);
      if (consumed == 0) break;  // cannot happen (a span always takes a byte); never spin on it
    }
    pump(now);
  }

  void on_ring_event(const RingEvent& event, Millis now) {
    switch (event.kind) {
      case RingEvent::Kind::none:
      case RingEvent::Kind::forwarded:
        return;
      case RingEvent::Kind::captured:
        on_captured(event.message, now);
        return;
      case RingEvent::Kind::undeliverable:
        on_undeliverable(event.message);
        return;
      case RingEvent::Kind::dropped:
        if (event.error == Error::queue_full) {
          emit(events::ForwardDropped{event.message});
        } else {
          emit(events::InputDropped{event.error});
        }
        return;
    }
  }

  void on_captured(const Message& message, Millis now) {
    const auto found = calls_.find(call_id(message.type));
    if (found != calls_.end() && found->second->state.originated) {
      const Table::ReplyResult result = table_.on_reply(found->first, 0, now);
      if (result.verdict == Table::Verdict::completed) {
        ++counters_.replies;
        finish(found->second, error_code(), message);
        return;
      }
    }
    const Entry receiver = first_receiver();
    if (receiver != pending_.end()) {
      pending_.complete(receiver, error_code(), message);
      return;
    }
    received_.push_back(message);
    if (received_.size() > options_.receive_queue_bound) {
      events::ReceiveOverflow report{received_.front()};
      received_.pop_front();
      ++counters_.receive_overflows;
      emit(report);
    }
  }

  // One of our messages came back: the request it belongs to (if any) fails at once; reported once.
  void on_undeliverable(const Message& message) {
    const std::string bytes = encode(message, options_.node.generation);
    events::Undeliverable report{message, false};
    for (const auto& [id, call] : calls_) {
      if (!call->state.originated || call->state.bytes != bytes) continue;
      const Entry failed = call;
      (void)table_.cancel(id);
      report.request_failed = true;
      finish(failed, RingError::undeliverable, Message());
      break;
    }
    emit(report);
  }

  // --- completions ---------------------------------------------------------------------------------------

  // Ends request `call` (already out of the engine) with `error` or `reply` (one still waiting for its
  // first origination leaves the queue with it).
  void finish(Entry call, error_code error, const Message& reply) {
    calls_.erase(call_id(call->state.reply));
    refresh_capture();
    pending_.complete(call, error, reply);
  }

  // An engine completion (timeout; `ok` and `cancelled` are finished where they happen).
  void on_completion(const Table::Completion& completion) {
    const auto found = calls_.find(completion.id);
    if (found == calls_.end()) return;
    const RingOperation& call = found->second->state;
    error_code error;
    switch (completion.outcome) {
      case session::CallOutcome::timeout:
      case session::CallOutcome::remote_error:  // not produced: every reply of the type succeeds
      case session::CallOutcome::ok:            // not produced by poll
        // A request that never fully reached the stream did not go unanswered: it was never asked.
        error = (!call.originated || written_total_ < call.end) ? RingError::send_timed_out : RingError::timed_out;
        break;
      case session::CallOutcome::cancelled:
        error = asio::error::operation_aborted;
        break;
    }
    finish(found->second, error, Message());
  }

  void fail_all(const error_code& error) {
    pending_.fail_all([&](Operations::Operation& operation) {
      if (operation.state.kind == Kind::request) (void)table_.cancel(call_id(operation.state.reply));
      return std::tuple<error_code, Message>(error, Message());
    });
    calls_.clear();
    abort_writes(error);
    refresh_capture();
  }

  // --- events --------------------------------------------------------------------------------------------

  // The counters are published first, so a handler reading them sees what the event reports.
  void emit(const Event& event) {
    publish();
    events_.emit(event);
  }

  // --- the link's hooks ----------------------------------------------------------------------------------

  void on_link_failed(const error_code& error) override {
    fail_all(error);
    emit(events::LinkFailed{error});
  }

  void on_closed() override {
    fail_all(asio::error::operation_aborted);
    publish();
  }

  void on_timer() override { pump(now()); }

  // The application cancelled one operation (the header lists what that means for each kind). A send
  // already handed to the node is written all the same and completes then.
  void on_cancel(OperationId operation) override {
    const Entry found = pending_.find(operation);
    if (found == pending_.end() || (found->state.kind == Kind::send && found->state.originated)) return;
    pending_.cancel(operation, [&](Operations::Operation& cancelled) {
      if (cancelled.state.kind == Kind::request) {  // also drops its first origination still waiting for room
        (void)table_.cancel(call_id(cancelled.state.reply));
        calls_.erase(call_id(cancelled.state.reply));
        refresh_capture();
      }
      return std::tuple<error_code, Message>(asio::error::operation_aborted, Message());
    });
    pump(now());
  }

  // --- the pump ------------------------------------------------------------------------------------------

  void pump(Millis now) {
    if (unusable()) return;
    for (;;) {
      const RingEvent event = node_.poll(now);
      if (event.kind == RingEvent::Kind::none) break;
      on_ring_event(event, now);
    }
    for (;;) {
      const Table::Step step = table_.poll(now);
      if (step.action == Table::Action::idle) break;
      if (step.action == Table::Action::resend) {
        const auto found = calls_.find(step.id);
        // A request still waiting for its first origination needs no second copy.
        if (found != calls_.end() && found->second->state.originated) found->second->state.resend_pending = true;
      } else {
        on_completion(step.completion);
      }
    }
    // Sends that waited `send_timeout` for room or for the stream to take them (their bytes stay in the
    // output: the node cannot take them back), receives past their timeout; in that order.
    const auto failed_with = [](RingError error) {
      return [error](Operations::Operation&) { return std::tuple<error_code, Message>(error, Message()); };
    };
    const auto waiting_send = [](const Operations::Operation& send) {
      return send.state.kind == Kind::send && !send.state.originated;
    };
    const auto originated_send = [](const Operations::Operation& send) { return send.state.kind == Kind::send; };
    pending_.expire_if(now, waiting_send, failed_with(RingError::send_timed_out));
    pending_.expire_if(now, originated_send, failed_with(RingError::send_timed_out));
    pending_.expire(now, failed_with(RingError::receive_timed_out));  // only receives are left with a deadline
    originate_waiting(now);
    flush(now);
    arm_timer(now);
    publish();
  }

  void arm_timer(Millis now) {
    Deadline wake = table_.next_wakeup();
    // While a write is on the stream the pacer may already allow more: that is for the write's completion
    // to take (it pumps), not for the timer, which would fire at once again and again.
    consider(wake, node_.next_wakeup(now, !writing_));
    consider(wake, pending_.next_deadline());  // sends and receives with a timeout
    ClientLink::arm_timer(wake);
  }

  void publish() { published_.set(counters_); }

  const Options options_;

  // Strand only.
  Counters counters_;
  Node node_;
  Table table_;
  TypeSet capture_;
  Operations pending_;                   // sends, requests and receives in acceptance order
  std::map<std::uint8_t, Entry> calls_;  // requests by call id (the reply type)
  std::deque<Message> received_;
  std::uint64_t taken_ = 0;          // bytes taken from the node's output queue
  std::uint64_t written_total_ = 0;  // of which written to the stream
  bool writing_ = false;

  // Any thread.
  client::Published<Counters> published_;
  client::Published<TypeSet> published_capture_;
  client::EventHandlers<Event> events_;
};

void start_send(const std::shared_ptr<RingClientImpl>& impl, OperationId operation, SendHandler handler,
                const Message& message) {
  impl->submit_send(operation, message, std::move(handler));
}

void start_request(const std::shared_ptr<RingClientImpl>& impl, OperationId operation, MessageHandler handler,
                   const Message& message, Type reply_type) {
  impl->submit_request(operation, message, reply_type, std::move(handler));
}

void start_receive(const std::shared_ptr<RingClientImpl>& impl, OperationId operation, MessageHandler handler,
                   std::optional<Duration> timeout) {
  impl->submit_receive(operation, timeout, std::move(handler));
}

}  // namespace detail

// ---------------------------------------------------------------------------------------------------------
// RingClient

namespace {

std::shared_ptr<ByteStream> checked_stream(std::shared_ptr<ByteStream> stream, const Options& options) {
  stream = client::require_stream(std::move(stream), "elcano::RingClient");
  if (options.timing.max_attempts == 0 || options.timing.call_budget == 0) {
    throw std::invalid_argument("elcano::RingClient: timing.max_attempts and timing.call_budget must be > 0");
  }
  if (options.receive_queue_bound == 0) {
    throw std::invalid_argument("elcano::RingClient: receive_queue_bound must be > 0");
  }
  return stream;
}

}  // namespace

RingClient::RingClient(std::shared_ptr<ByteStream> stream, const Options& options, EventHandler handler)
    : ClientFront(std::make_shared<detail::RingClientImpl>(checked_stream(std::move(stream), options), options)) {
  on_event(std::move(handler));
  impl()->start();
}

void RingClient::send(const Message& message, error_code& error) {
  (void)client::wait_for_operation<bool>(
      link(),
      [&](detail::OperationId operation, transports::UniqueFunction<void(error_code, bool)> done) {
        impl()->submit_send(operation, message, [done = std::move(done)](error_code e) mutable { done(e, !e); });
      },
      error);
}

void RingClient::send(const Message& message) {
  client::require([&](error_code& error) { send(message, error); }, "elcano send");
}

Message RingClient::request(const Message& message, Type reply_type, error_code& error) {
  return client::wait_for_operation<Message>(
      link(),
      [&](detail::OperationId operation, detail::MessageHandler done) {
        impl()->submit_request(operation, message, reply_type, std::move(done));
      },
      error);
}

Message RingClient::request(const Message& message, Type reply_type) {
  return client::require([&](error_code& error) { return request(message, reply_type, error); },
                             "elcano request");
}

Message RingClient::receive(Duration timeout, error_code& error) {
  return client::wait_for_operation<Message>(
      link(),
      [&](detail::OperationId operation, detail::MessageHandler done) {
        impl()->submit_receive(operation, timeout, std::move(done));
      },
      error);
}

Message RingClient::receive(Duration timeout) {
  return client::require([&](error_code& error) { return receive(timeout, error); }, "elcano receive");
}

void RingClient::set_capture(TypeSet capture) { impl()->set_capture(capture); }
TypeSet RingClient::capture() const { return impl()->capture(); }
Counters RingClient::counters() const { return impl()->counters(); }

}  // namespace tether::elcano
