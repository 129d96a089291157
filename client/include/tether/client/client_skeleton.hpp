/// @file client_skeleton.hpp
/// The parts every host codec client is made of besides its protocol, written once: the public front over
/// a `ClientLink` implementation (`ClientFront`), the asio initiation with per-operation cancellation
/// (`ClientFront::initiate`), the blocking-or-throw form of a call (`require`) and the list of event
/// handlers (`EventHandlers`, registered with `ClientFront::on_event`). `romi::Client`, `proxy::Client` and `elcano::RingClient` are built from them,
/// so what differs between those files is protocol.
#pragma once

#include <boost/asio/associated_executor.hpp>
#include <boost/asio/async_result.hpp>
#include <boost/system/system_error.hpp>

#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "tether/client/client_link.hpp"
#include "tether/transports/byte_stream.hpp"

namespace tether::client {

/// The stream a client is built on; throws `std::invalid_argument` naming `client` when it is null.
inline std::shared_ptr<transports::ByteStream> require_stream(std::shared_ptr<transports::ByteStream> stream,
                                                              const char* client) {
  if (!stream) throw std::invalid_argument(std::string(client) + " needs a stream");
  return stream;
}

/// The throwing form of a blocking call: runs `call(error)` (the error_code form) and returns its result,
/// or throws `boost::system::system_error(error, what)` when it set `error`. `call` may return void.
template <typename Call>
auto require(Call&& call, const std::string& what) {
  error_code error;
  if constexpr (std::is_void_v<decltype(call(error))>) {
    call(error);
    if (error) throw boost::system::system_error(error, what);
  } else {
    auto result = call(error);
    if (error) throw boost::system::system_error(error, what);
    return result;
  }
}

/// The event handlers of a client, `Event` being its `std::variant` of event structs. Contract of a handler:
///   1. Called on the client's strand, one event at a time, in the order the events happened, with every
///      handler in the order they were added; a view valid only during the call.
///   2. Must not block for long (it delays decoding) and must not call the blocking forms of the same
///      client (they fail with `transports::TransportError::would_deadlock`); asynchronous calls are fine.
///   3. An exception escaping a handler is caught and dropped: the event still reaches the other handlers,
///      the client goes on, and the handler stays registered. (A handler is the application's code; an
///      exception leaving `io_context::run()` would stop every client on that context.)
///   4. A handler removed while an event is being delivered on another thread may still receive that one.
template <typename Event>
class EventHandlers {
 public:
  /// A handler (contract above).
  using Handler = std::function<void(const Event& event)>;
  /// What `add` returns: `remove` takes it. Never 0.
  using Id = std::uint64_t;

  /// Adds `handler` (an empty one is not added and gets 0). Any thread.
  Id add(Handler handler) {
    if (!handler) return 0;
    auto shared = std::make_shared<Handler>(std::move(handler));
    std::lock_guard lock(mutex_);
    handlers_.emplace_back(++last_id_, std::move(shared));
    return last_id_;
  }
  /// Removes the handler `id` (unknown ids are ignored). Any thread.
  void remove(Id id) {
    std::lock_guard lock(mutex_);
    std::erase_if(handlers_, [id](const auto& entry) { return entry.first == id; });
  }
  /// Delivers `event` to every handler (rule 3 of the contract for exceptions). The client's strand.
  void emit(const Event& event) const {
    std::vector<std::shared_ptr<Handler>> handlers;
    {
      std::lock_guard lock(mutex_);
      handlers.reserve(handlers_.size());
      for (const auto& entry : handlers_) handlers.push_back(entry.second);
    }
    for (const auto& handler : handlers) {
      try {
        (*handler)(event);
      } catch (...) {  // NOLINT(bugprone-empty-catch): rule 3, the client goes on
      }
    }
  }
  /// True when no handler is registered. Any thread.
  bool empty() const {
    std::lock_guard lock(mutex_);
    return handlers_.empty();
  }

 private:
  mutable std::mutex mutex_;
  Id last_id_ = 0;
  std::vector<std::pair<Id, std::shared_ptr<Handler>>> handlers_;
};

/// Cancels single operations of a client: emitting it cancels the operation started with a handler bound
/// to it (`bind_cancellation`), and only that one. Copies share the same signal. Thread-safe.
class CancellationSignal {
 public:
  /// Cancels the operation connected last (nothing when none is, or it already completed). Any thread.
  void emit() const {
    std::function<void()> target;
    {
      std::lock_guard lock(state_->mutex);
      target = state_->target;
    }
    if (target) target();
  }
  /// Connects `target` (what `emit` runs), replacing the previous one. Any thread.
  void connect(std::function<void()> target) const {
    std::lock_guard lock(state_->mutex);
    state_->target = std::move(target);
  }

 private:
  struct State {
    std::mutex mutex;
    std::function<void()> target;
  };
  std::shared_ptr<State> state_ = std::make_shared<State>();
};

/// A completion handler with a `CancellationSignal`; made by `bind_cancellation`.
template <typename Handler>
struct CancellableHandler {
  CancellationSignal signal;  ///< What cancels the operation.
  Handler handler;            ///< The handler itself (its associated executor is kept).
  /// Completes: calls the handler.
  template <typename... Results>
  void operator()(Results&&... results) {
    handler(std::forward<Results>(results)...);
  }
};

/// `handler` cancelled by `signal.emit()` (an operation started with it completes with
/// `operation_aborted` if still pending); the handler's associated executor is kept.
template <typename Handler>
CancellableHandler<std::decay_t<Handler>> bind_cancellation(CancellationSignal signal, Handler&& handler) {
  return CancellableHandler<std::decay_t<Handler>>{std::move(signal), std::forward<Handler>(handler)};
}

/// Connects the signal of a handler made by `bind_cancellation` to operation `operation` of `link`
/// (other handlers have none: nothing to do).
template <typename Handler>
void connect_cancellation(const Handler& handler, const std::shared_ptr<ClientLink>& link,
                          ClientLink::OperationId operation) {
  (void)handler, (void)link, (void)operation;
}
/// `connect_cancellation` for a cancellable handler.
template <typename Handler>
void connect_cancellation(const CancellableHandler<Handler>& handler, const std::shared_ptr<ClientLink>& link,
                          ClientLink::OperationId operation) {
  handler.signal.connect([weak = std::weak_ptr<ClientLink>(link), operation] {
    if (const auto locked = weak.lock()) locked->cancel(operation);
  });
}

/// What every client reports when its link fails (read or write error, EOF, unplugged device): one
/// alternative of each `<codec>::Event` (`romi::events::LinkFailed`, ...). Emitted once, after every pending
/// operation completed with `error`; never for `close()` (the application knows it closed).
struct LinkFailed {
  error_code error;  ///< The transport's error.
};

/// A shared reference to a client's implementation `Impl` (a `ClientLink`, complete only in the client's
/// .cpp): what the front (`ClientFront`) and a client's sub-handles (`proxy::ServoHandle`) start
/// asynchronous operations with. Cheap to copy; keeps the implementation alive.
template <typename Impl>
class ClientRef {
 public:
  /// No implementation (a moved-from front).
  ClientRef() = default;
  /// Reference to `impl` (not null); constructed where `Impl` is complete (the client's .cpp).
  explicit ClientRef(std::shared_ptr<Impl> impl) : impl_(impl), link_(std::move(impl)) {}

  /// The implementation.
  const std::shared_ptr<Impl>& impl() const { return impl_; }
  /// The implementation as its link (complete here: executor, close, blocking waits).
  const std::shared_ptr<ClientLink>& link() const { return link_; }

  /// Starts an asynchronous operation for any completion token with completion `Signature`:
  /// `start(impl, operation, handler, args...)` runs once the token initiates it (deferred tokens such
  /// as `use_awaitable` may do that after the front was moved: the initiation holds the implementation,
  /// not the front). `handler` completes on the token's associated executor (the stream's by default).
  /// A handler made by `bind_cancellation` cancels this one operation: the implementation's
  /// `on_cancel(operation)` runs on its strand, and the operation completes with `operation_aborted` if it
  /// was still pending (see `ClientLink::on_cancel`). (Boost 1.74 has no asio cancellation slots.)
  template <typename Signature, typename Token, typename Start, typename... Args>
  auto initiate(Token&& token, Start start, Args&&... args) const {
    return asio::async_initiate<Token, Signature>(
        [impl = impl_, link = link_, start = std::move(start)](auto handler, auto&&... arguments) mutable {
          const ClientLink::OperationId operation = link->new_operation();
          connect_cancellation(handler, link, operation);
          start(impl, operation,
                transports::bind_to_associated_executor<Signature>(std::move(handler), link->executor()),
                std::forward<decltype(arguments)>(arguments)...);
        },
        token, std::forward<Args>(args)...);
  }

 private:
  std::shared_ptr<Impl> impl_;
  std::shared_ptr<ClientLink> link_;
};

/// The public front of a client over its implementation `Impl` (a `ClientLink`, complete only in the
/// client's .cpp) whose events are `Event` (a `std::variant` of event structs): owns the implementation,
/// closes it when destroyed or replaced by a move, starts its asynchronous operations (`initiate`) and
/// registers its event handlers (`on_event`, contract at `EventHandlers`). Movable, not copyable; a
/// moved-from client holds nothing (only destruction and assignment).
template <typename Impl, typename Event>
class ClientFront {
 public:
  /// An event handler (contract at `EventHandlers`).
  using EventHandler = typename EventHandlers<Event>::Handler;
  /// What `on_event` returns, for `remove_event_handler`. Never 0.
  using EventHandlerId = typename EventHandlers<Event>::Id;

  ClientFront(const ClientFront&) = delete;
  ClientFront& operator=(const ClientFront&) = delete;
  /// Takes `other`'s implementation.
  ClientFront(ClientFront&& other) noexcept = default;
  /// Closes the implementation it replaces, then takes `other`'s. Self-assignment keeps it open.
  ClientFront& operator=(ClientFront&& other) noexcept {
    if (this == &other) return *this;
    close();
    ref_ = std::move(other.ref_);
    events_ = std::move(other.events_);
    return *this;
  }
  /// Closes (`close()`).
  ~ClientFront() { close(); }

  /// Executor of the stream; completion handlers without an associated executor run on it.
  asio::any_io_executor get_executor() const { return ref_.link()->executor(); }
  /// Completes every pending operation with `operation_aborted`, closes the stream and stops reading;
  /// later operations complete with `operation_aborted` too. Idempotent, any thread, never waits for the
  /// device.
  void close() {
    if (ref_.link()) ref_.link()->close();
  }
  /// False after `close()`.
  bool is_open() const { return ref_.link() && ref_.link()->is_open(); }
  /// The client's clock (its `Options::clock`) in wrap-safe milliseconds: the time base of what it stamps
  /// (`proxy::PinStatus::updated`) and of its deadlines. Any thread.
  Millis now() const { return ref_.link()->now(); }

  /// Adds an event handler (an empty one is not added and gets 0); it receives every event from now on
  /// (events are not queued for handlers added later: the constructor's handler sees the first ones).
  /// Any thread.
  EventHandlerId on_event(EventHandler handler) { return events_->add(std::move(handler)); }
  /// Removes the handler `id` (unknown ids are ignored); it may still receive an event being delivered
  /// on another thread (rule 4 of `EventHandlers`). Any thread.
  void remove_event_handler(EventHandlerId id) { events_->remove(id); }

 protected:
  /// Front of `impl` (not null) whose `event_handlers()` are its `EventHandlers<Event>`; defined where
  /// `Impl` is complete (the client's .cpp).
  explicit ClientFront(const std::shared_ptr<Impl>& impl)
      : ref_(impl), events_(impl, &impl->event_handlers()) {}

  /// The implementation.
  const std::shared_ptr<Impl>& impl() const { return ref_.impl(); }
  /// The implementation as its link (complete here: for blocking waits).
  ClientLink& link() const { return *ref_.link(); }
  /// The shared reference (for sub-handles that start operations of their own).
  const ClientRef<Impl>& ref() const { return ref_; }

  /// `ClientRef::initiate` on this client's implementation.
  template <typename Signature, typename Token, typename Start, typename... Args>
  auto initiate(Token&& token, Start start, Args&&... args) {
    return ref_.template initiate<Signature>(std::forward<Token>(token), std::move(start), std::forward<Args>(args)...);
  }

 private:
  ClientRef<Impl> ref_;
  std::shared_ptr<EventHandlers<Event>> events_;  // aliases the implementation: no allocation of its own
};

/// Starts an operation with `start(operation, handler)` and waits for its `void(error_code, Result)`
/// completion: the body of every blocking call (`wait_for_completion` with a fresh operation id).
template <typename Result, typename Start>
Result wait_for_operation(ClientLink& link, Start&& start, error_code& error) {
  Result result{};
  (void)wait_for_completion(
      link,
      [&](transports::UniqueFunction<void(error_code, Result)> handler) {
        start(link.new_operation(), std::move(handler));
      },
      error, result);
  return result;
}

}  // namespace tether::client

/// A cancellable handler runs on its handler's associated executor.
template <typename Handler, typename Executor>
struct boost::asio::associated_executor<tether::client::CancellableHandler<Handler>, Executor> {
  /// The wrapped handler's.
  using type = typename boost::asio::associated_executor<Handler, Executor>::type;
  /// The wrapped handler's executor.
  static type get(const tether::client::CancellableHandler<Handler>& h, const Executor& e = Executor()) noexcept {
    return boost::asio::associated_executor<Handler, Executor>::get(h.handler, e);
  }
};
