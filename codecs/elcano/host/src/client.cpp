// RingClient: the portable RingNode and the Elcano session engine (elcano::RequestTable) driven by the read
// loop, the write queue and the timer of a transports::ClientLink, like romi::Client and
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
#include <utility>
#include <vector>

#include "tether/core/wakeup.hpp"
#include "tether/transports/client_link.hpp"

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

class RingClientImpl final : public transports::ClientLink {
 public:
  RingClientImpl(std::shared_ptr<ByteStream> stream, const Options& options)
      : ClientLink(std::move(stream), options.clock),
        options_(options),
        node_(options.node, now(), counters_.link, counters_.ring),
        table_(options.timing, 0, counters_.link),
        capture_(options.node.capture) {
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
    auto item = std::make_unique<Outgoing>();
    item->message = message;
    item->send_handler = std::move(handler);
    item->operation = operation;
    post_to_strand([this, item = std::move(item)]() mutable { accept_send(std::move(item)); });
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
    auto call = std::make_shared<Call>();
    call->reply = reply_type;
    call->message = message;
    call->bytes = std::move(bytes);
    call->handler = std::move(handler);
    call->operation = operation;
    post_to_strand([this, call = std::move(call)]() mutable { accept_request(std::move(call)); });
  }

  void submit_receive(OperationId operation, std::optional<Duration> timeout, MessageHandler handler) {
    if (!is_open()) {
      post_completion(std::move(handler), error_code(asio::error::operation_aborted), Message());
      return;
    }
    auto receiver = std::make_unique<Receiver>();
    receiver->handler = std::move(handler);
    receiver->timeout = timeout;
    receiver->operation = operation;
    post_to_strand([this, receiver = std::move(receiver)]() mutable { accept_receive(std::move(receiver)); });
  }

  void set_capture(TypeSet capture) {
    published_capture_.set(capture);
    post_to_strand([this, capture] {
      capture_ = capture;
      refresh_capture();
    });
  }

  TypeSet capture() const { return published_capture_.get(); }

  transports::EventHandlers<Event>& event_handlers() { return events_; }

  Counters counters() const { return published_.get(); }

 private:
  // A request from acceptance to completion.
  struct Call {
    Type reply = Type::segment;
    Message message;
    std::string bytes;            // as written: recognises the request when it comes back
    MessageHandler handler;
    OperationId operation = 0;
    bool sent = false;            // first originated: its reply type is captured from then on
    bool resend_pending = false;  // the engine asked for a re-send that found no room yet
    std::uint64_t end = 0;        // output offset after its first origination's last byte
  };
  // A send or a request's first origination waiting for room in the node's output queue.
  struct Outgoing {
    std::shared_ptr<Call> call;  // a request; else a send:
    Message message;
    SendHandler send_handler;
    OperationId operation = 0;  // sends (a request's is its call's)
    Millis deadline = 0;        // sends: `send_timeout` after acceptance
  };
  // A send originated, completing once its last byte (at offset `end` of the output) was written, or
  // failing at its deadline when the stream did not take it by then (a device that stopped reading).
  struct Written {
    std::uint64_t end = 0;
    SendHandler handler;
    OperationId operation = 0;
    Millis deadline = 0;
  };
  struct Receiver {
    MessageHandler handler;
    OperationId operation = 0;
    std::optional<Duration> timeout;
    Millis deadline = 0;
  };

  // --- accepting operations ----------------------------------------------------------------------------

  // The link's state as an error for new operations (empty while it works).
  error_code unusable() const {
    if (link_error()) return link_error();
    if (!is_open()) return asio::error::operation_aborted;
    return error_code();
  }

  void accept_send(std::unique_ptr<Outgoing> item) {
    if (const error_code error = unusable()) {
      complete(std::move(item->send_handler), error);
      return;
    }
    const Millis now = this->now();
    item->deadline = static_cast<Millis>(now + options_.send_timeout);
    enqueue(std::move(item), now);
    pump(now);
  }

  void accept_request(std::shared_ptr<Call> call) {
    if (const error_code error = unusable()) {
      complete(std::move(call->handler), error, Message());
      return;
    }
    const std::uint8_t id = call_id(call->reply);
    const Millis now = this->now();
    if (calls_.count(id) != 0 || !table_.begin_with(id, now).ok()) {
      complete(std::move(call->handler), RingError::reply_type_busy, Message());
      return;
    }
    calls_.emplace(id, call);
    auto item = std::make_unique<Outgoing>();
    item->call = std::move(call);
    enqueue(std::move(item), now);
    pump(now);
  }

  void accept_receive(std::unique_ptr<Receiver> receiver) {
    if (const error_code error = unusable()) {
      complete(std::move(receiver->handler), error, Message());
      return;
    }
    if (!received_.empty() && receivers_.empty()) {
      Message message = received_.front();
      received_.pop_front();
      complete(std::move(receiver->handler), error_code(), message);
      return;
    }
    if (receiver->timeout && *receiver->timeout == 0) {
      complete(std::move(receiver->handler), RingError::receive_timed_out, Message());
      return;
    }
    const Millis now = this->now();
    if (receiver->timeout) receiver->deadline = static_cast<Millis>(now + *receiver->timeout);
    receivers_.push_back(std::move(receiver));
    pump(now);
  }

  // Originates `item` now if nothing waits before it and there is room; else queues it within the bound.
  void enqueue(std::unique_ptr<Outgoing> item, Millis now) {
    if (outgoing_.empty() && !resend_waiting() && originate(*item, now)) return;
    if (outgoing_.size() >= options_.send_queue_bound) {
      if (item->call) {
        const std::shared_ptr<Call> call = item->call;
        (void)table_.cancel(call_id(call->reply));
        calls_.erase(call_id(call->reply));
        complete(std::move(call->handler), RingError::send_queue_full, Message());
      } else {
        complete(std::move(item->send_handler), RingError::send_queue_full);
      }
      return;
    }
    outgoing_.push_back(std::move(item));
  }

  // --- originating ---------------------------------------------------------------------------------------

  bool resend_waiting() const {
    return std::any_of(calls_.begin(), calls_.end(), [](const auto& entry) { return entry.second->resend_pending; });
  }

  // Hands `item` to the node. False when the output queue has no room (the item stays the caller's).
  bool originate(Outgoing& item, Millis now) {
    const Message& message = item.call ? item.call->message : item.message;
    const Status status = node_.originate(message, now);
    if (status == Status::busy) return false;
    if (status != Status::ok) {  // not reached: validated on submission. The caller drops the item.
      if (item.call) {
        (void)table_.cancel(call_id(item.call->reply));
        calls_.erase(call_id(item.call->reply));
        complete(std::move(item.call->handler), RingError::invalid_message, Message());
      } else {
        complete(std::move(item.send_handler), RingError::invalid_message);
      }
      return true;
    }
    if (item.call) {
      item.call->sent = true;
      item.call->end = taken_ + node_.pending_output();
      refresh_capture();
    } else {
      written_.push_back(
          Written{taken_ + node_.pending_output(), std::move(item.send_handler), item.operation, item.deadline});
    }
    return true;
  }

  // Re-sends first, then waiting messages in order, while the node has room.
  void originate_waiting(Millis now) {
    for (auto& [id, call] : calls_) {
      if (!call->resend_pending) continue;
      if (node_.originate(call->message, now) != Status::ok) return;
      call->resend_pending = false;
    }
    while (!outgoing_.empty()) {
      if (!originate(*outgoing_.front(), now)) return;
      outgoing_.pop_front();
    }
  }

  // The node captures the configured set plus the reply types of requests sent and not completed.
  void refresh_capture() {
    TypeSet effective = capture_;
    for (const auto& [id, call] : calls_) {
      if (call->sent) effective = effective.with(call->reply);
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

  void on_flushed(const error_code& error, std::size_t size) {
    writing_ = false;
    if (error) return;  // closed or failed: on_closed / on_link_failed fail what waits
    written_total_ += size;
    counters_.bytes_written += static_cast<std::uint32_t>(size);
    while (!written_.empty() && written_.front().end <= written_total_) {
      complete(std::move(written_.front().handler), error_code());  // empty when it expired
      written_.pop_front();
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
    if (found != calls_.end() && found->second->sent) {
      const Table::ReplyResult result = table_.on_reply(found->first, 0, now);
      if (result.verdict == Table::Verdict::completed) {
        ++counters_.replies;
        finish(found->second, error_code(), message);
        return;
      }
    }
    if (!receivers_.empty()) {
      std::unique_ptr<Receiver> receiver = std::move(receivers_.front());
      receivers_.pop_front();
      complete(std::move(receiver->handler), error_code(), message);
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
      if (!call->sent || call->bytes != bytes) continue;
      (void)table_.cancel(id);
      report.request_failed = true;
      finish(call, RingError::undeliverable, Message());
      break;
    }
    emit(report);
  }

  // --- completions ---------------------------------------------------------------------------------------

  // Ends request `call` (already out of the engine) with `error` or `reply`.
  void finish(std::shared_ptr<Call> call, error_code error, const Message& reply) {
    calls_.erase(call_id(call->reply));
    if (!call->sent) {
      std::erase_if(outgoing_, [&](const auto& item) { return item->call == call; });
    }
    refresh_capture();
    complete(std::move(call->handler), error, reply);
  }

  // An engine completion (timeout; `ok` and `cancelled` are finished where they happen).
  void on_completion(const Table::Completion& completion) {
    const auto found = calls_.find(completion.id);
    if (found == calls_.end()) return;
    error_code error;
    switch (completion.outcome) {
      case session::CallOutcome::timeout:
      case session::CallOutcome::remote_error:  // not produced: every reply of the type succeeds
      case session::CallOutcome::ok:            // not produced by poll
        // A request that never fully reached the stream did not go unanswered: it was never asked.
        error = (!found->second->sent || written_total_ < found->second->end) ? RingError::send_timed_out
                                                                              : RingError::timed_out;
        break;
      case session::CallOutcome::cancelled:
        error = asio::error::operation_aborted;
        break;
    }
    finish(found->second, error, Message());
  }

  void fail_all(const error_code& error) {
    std::map<std::uint8_t, std::shared_ptr<Call>> calls = std::move(calls_);
    calls_.clear();
    for (auto& [id, call] : calls) {
      (void)table_.cancel(id);
      complete(std::move(call->handler), error, Message());
    }
    for (auto& item : outgoing_) {
      if (!item->call) complete(std::move(item->send_handler), error);
    }
    outgoing_.clear();
    for (auto& written : written_) complete(std::move(written.handler), error);
    written_.clear();
    for (auto& receiver : receivers_) complete(std::move(receiver->handler), error, Message());
    receivers_.clear();
    abort_writes(error);
    refresh_capture();
  }

  // Hands a result to its caller (posted, never on the strand); the counters are published first, so a
  // caller reading them after its completion sees what led to it.
  template <typename Handler, typename... Args>
  void complete(Handler handler, Args... args) {
    if (!handler) return;
    publish();
    post_completion(std::move(handler), std::move(args)...);
  }

  void complete(SendHandler handler, RingError error) { complete(std::move(handler), error_code(error)); }
  void complete(MessageHandler handler, RingError error, Message message) {
    complete(std::move(handler), error_code(error), std::move(message));
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

  // The application cancelled one operation (the header lists what that means for each kind).
  void on_cancel(OperationId operation) override {
    const error_code aborted = asio::error::operation_aborted;
    for (const auto& [id, call] : calls_) {
      if (call->operation != operation) continue;
      (void)table_.cancel(id);
      finish(call, aborted, Message());  // also drops its first origination still waiting for room
      pump(now());
      return;
    }
    const auto waiting = std::find_if(outgoing_.begin(), outgoing_.end(),
                                      [&](const auto& item) { return !item->call && item->operation == operation; });
    if (waiting != outgoing_.end()) {
      complete(std::move((*waiting)->send_handler), aborted);
      outgoing_.erase(waiting);
      pump(now());
      return;
    }
    const auto receiver = std::find_if(receivers_.begin(), receivers_.end(),
                                       [&](const auto& r) { return r->operation == operation; });
    if (receiver != receivers_.end()) {
      complete(std::move((*receiver)->handler), aborted, Message());
      receivers_.erase(receiver);
      pump(now());
    }
    // A send already handed to the node (`written_`) is written all the same and completes then.
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
        if (found != calls_.end() && found->second->sent) found->second->resend_pending = true;
      } else {
        on_completion(step.completion);
      }
    }
    expire(now);
    originate_waiting(now);
    flush(now);
    arm_timer(now);
    publish();
  }

  // Sends that waited `send_timeout` for room or for the stream to take them, receives past their timeout.
  void expire(Millis now) {
    for (auto it = outgoing_.begin(); it != outgoing_.end();) {
      if (!(*it)->call && tick_reached(now, (*it)->deadline)) {
        complete(std::move((*it)->send_handler), RingError::send_timed_out);
        it = outgoing_.erase(it);
      } else {
        ++it;
      }
    }
    // Its bytes stay in the output (the node cannot take them back): the entry keeps its place, so the
    // sends behind it still complete when the stream takes theirs.
    for (auto& written : written_) {
      if (written.handler && tick_reached(now, written.deadline)) {
        complete(std::move(written.handler), RingError::send_timed_out);  // leaves it empty
      }
    }
    for (auto it = receivers_.begin(); it != receivers_.end();) {
      if ((*it)->timeout && tick_reached(now, (*it)->deadline)) {
        complete(std::move((*it)->handler), RingError::receive_timed_out, Message());
        it = receivers_.erase(it);
      } else {
        ++it;
      }
    }
  }

  void arm_timer(Millis now) {
    Deadline wake = table_.next_wakeup();
    // While a write is on the stream the pacer may already allow more: that is for the write's completion
    // to take (it pumps), not for the timer, which would fire at once again and again.
    consider(wake, node_.next_wakeup(now, !writing_));
    for (const auto& item : outgoing_) {
      if (!item->call) consider(wake, deadline_at(item->deadline));
    }
    for (const auto& written : written_) {
      if (written.handler) consider(wake, deadline_at(written.deadline));
    }
    for (const auto& receiver : receivers_) {
      if (receiver->timeout) consider(wake, deadline_at(receiver->deadline));
    }
    ClientLink::arm_timer(wake);
  }

  void publish() { published_.set(counters_); }

  const Options options_;

  // Strand only.
  Counters counters_;
  Node node_;
  Table table_;
  TypeSet capture_;
  std::map<std::uint8_t, std::shared_ptr<Call>> calls_;  // by call id (the reply type)
  std::deque<std::unique_ptr<Outgoing>> outgoing_;
  std::deque<Written> written_;
  std::deque<std::unique_ptr<Receiver>> receivers_;
  std::deque<Message> received_;
  std::uint64_t taken_ = 0;          // bytes taken from the node's output queue
  std::uint64_t written_total_ = 0;  // of which written to the stream
  bool writing_ = false;

  // Any thread.
  transports::Published<Counters> published_;
  transports::Published<TypeSet> published_capture_;
  transports::EventHandlers<Event> events_;
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
  stream = transports::require_stream(std::move(stream), "elcano::RingClient");
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
  (void)transports::wait_for_operation<bool>(
      link(),
      [&](detail::OperationId operation, transports::UniqueFunction<void(error_code, bool)> done) {
        impl()->submit_send(operation, message, [done = std::move(done)](error_code e) mutable { done(e, !e); });
      },
      error);
}

void RingClient::send(const Message& message) {
  transports::require([&](error_code& error) { send(message, error); }, "elcano send");
}

Message RingClient::request(const Message& message, Type reply_type, error_code& error) {
  return transports::wait_for_operation<Message>(
      link(),
      [&](detail::OperationId operation, detail::MessageHandler done) {
        impl()->submit_request(operation, message, reply_type, std::move(done));
      },
      error);
}

Message RingClient::request(const Message& message, Type reply_type) {
  return transports::require([&](error_code& error) { return request(message, reply_type, error); },
                             "elcano request");
}

Message RingClient::receive(Duration timeout, error_code& error) {
  return transports::wait_for_operation<Message>(
      link(),
      [&](detail::OperationId operation, detail::MessageHandler done) {
        impl()->submit_receive(operation, timeout, std::move(done));
      },
      error);
}

Message RingClient::receive(Duration timeout) {
  return transports::require([&](error_code& error) { return receive(timeout, error); }, "elcano receive");
}

void RingClient::set_capture(TypeSet capture) { impl()->set_capture(capture); }
TypeSet RingClient::capture() const { return impl()->capture(); }
Counters RingClient::counters() const { return impl()->counters(); }

}  // namespace tether::elcano
