/// @file pending_operations.hpp
/// The operations a host codec client has accepted and not yet completed, kept the same way by every
/// client (`romi::Client`, `proxy::Client`, `elcano::RingClient`): one list in acceptance order whose
/// entries carry the caller's handler, the operation id its cancellation names, an optional deadline and
/// the client's own state of the operation (queued, in flight, its message id, ...). Completing, failing
/// everything, cancelling one operation and expiring deadlines are written here once; what an operation
/// means on the wire stays the client's.
///
/// Rules every client relies on:
///   - A completion is posted to the executor (never run inside the call that completes it); the hook
///     given at construction runs first, so a caller reading the client's counters after its completion
///     sees what led to it.
///   - An entry without a handler is the client's own work (a proxy init replayed by the session): it is
///     kept, ordered and cancelled like the others, and completing it only removes it.
///   - Entries are never moved: an iterator stays valid until its entry is completed or erased.
///   - Destroyed with entries left (a client dropped while its io_context no longer runs), their handlers
///     are destroyed without being called, as asio destroys the operations of a destroyed io_context.
///
/// Not thread-safe: a client uses it on its strand only.
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/post.hpp>
#include <boost/system/error_code.hpp>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <list>
#include <tuple>
#include <utility>

#include "tether/core/time.hpp"
#include "tether/core/wakeup.hpp"
#include "tether/transports/unique_function.hpp"

namespace tether::client {

/// Spelled as in the transports, whose streams the client runtime drives.
namespace asio = boost::asio;
/// The error type of every completion (the streams' and the link's).
using boost::system::error_code;

template <typename Signature, typename State>
class PendingOperations;

/// Pending operations completing with `void(Results...)`, each with the client's `State` (file overview).
template <typename State, typename... Results>
class PendingOperations<void(Results...), State> {
 public:
  /// The caller's completion handler (empty for the client's own work).
  using Handler = transports::UniqueFunction<void(Results...)>;
  /// Names an operation for its cancellation (`ClientLink::OperationId`); 0 is the client's own work.
  using OperationId = std::uint64_t;

  /// One accepted operation.
  struct Operation {
    OperationId id = 0;  ///< The caller's operation (its cancellation slot names it); 0: the client's own.
    Handler handler;     ///< Receives the results; empty for the client's own work.
    Deadline deadline;   ///< When armed, `expire` completes the operation once it passes.
    State state;         ///< The client's state of the operation.
  };
  /// Position of an entry (stable until the entry leaves).
  using iterator = typename std::list<Operation>::iterator;
  /// Read-only position of an entry.
  using const_iterator = typename std::list<Operation>::const_iterator;
  /// Runs before each completion is posted (clients publish their counters there).
  using BeforeCompletion = std::function<void()>;

  /// Operations whose completions are posted to `executor`, each after `before_completion` (may be empty).
  explicit PendingOperations(boost::asio::any_io_executor executor, BeforeCompletion before_completion = {})
      : executor_(std::move(executor)), before_completion_(std::move(before_completion)) {}
  PendingOperations(const PendingOperations&) = delete;
  PendingOperations& operator=(const PendingOperations&) = delete;

  /// Accepts an operation at the back (acceptance order); its deadline is disarmed unless given.
  iterator add(OperationId id, Handler handler, State state, Deadline deadline = Deadline()) {
    operations_.push_back(Operation{id, std::move(handler), deadline, std::move(state)});
    return std::prev(operations_.end());
  }

  /// The first entry, in acceptance order.
  iterator begin() { return operations_.begin(); }
  /// Past the last entry.
  iterator end() { return operations_.end(); }
  /// The first entry, read-only.
  const_iterator begin() const { return operations_.begin(); }
  /// Past the last entry, read-only.
  const_iterator end() const { return operations_.end(); }
  /// True when nothing is pending.
  bool empty() const { return operations_.empty(); }
  /// Entries pending, the client's own work included.
  std::size_t size() const { return operations_.size(); }

  /// The caller's operation `id` (never the client's own work, id 0), or `end()`.
  iterator find(OperationId id) {
    if (id == 0) return end();
    for (auto it = operations_.begin(); it != operations_.end(); ++it) {
      if (it->id == id) return it;
    }
    return end();
  }

  /// Removes the entry at `at` and posts its handler with `results` (nothing to post for the client's own
  /// work). Returns the entry that followed it.
  iterator complete(iterator at, Results... results) {
    Handler handler = std::move(at->handler);
    const iterator next = operations_.erase(at);
    post(std::move(handler), std::move(results)...);
    return next;
  }

  /// Removes the entry at `at` without completing it: only for the client's own work (a replay the
  /// session drops). Returns the entry that followed it.
  iterator erase(iterator at) { return operations_.erase(at); }

  /// Cancels the caller's operation `id` if it is pending: `finish(operation)` does the client's part (out
  /// of its session engine, ...) and returns the results as a `std::tuple<Results...>`; the entry is then
  /// completed with them. True when it was pending. The client checks beforehand whether an operation in
  /// its current stage may still be cancelled (a frame already handed to the stream may not).
  template <typename Finish>
  bool cancel(OperationId id, Finish&& finish) {
    const iterator found = find(id);
    if (found == end()) return false;
    complete_with(found, finish(*found));
    return true;
  }

  /// Completes every entry, in acceptance order, with `finish(operation)`'s tuple (the client's own work is
  /// only dropped, after `finish` did its part). Entries added meanwhile stay pending.
  template <typename Finish>
  void fail_all(Finish&& finish) {
    std::list<Operation> failing;
    failing.splice(failing.end(), operations_);
    while (!failing.empty()) {
      Operation operation = std::move(failing.front());
      failing.pop_front();
      std::tuple<Results...> results = finish(operation);
      std::apply([&](auto&&... values) { post(std::move(operation.handler), std::move(values)...); },
                 std::move(results));
    }
  }

  /// Completes, in acceptance order, every entry whose armed deadline `now` reached, with
  /// `finish(operation)`'s tuple (wrap-safe milliseconds). The others stay.
  template <typename Finish>
  void expire(Millis now, Finish&& finish) {
    expire_if(now, [](const Operation&) { return true; }, std::forward<Finish>(finish));
  }

  /// `expire` for the entries `which(operation)` selects: a client whose operations expire in an order
  /// of their kinds (sends still queued before sends already written) calls it once per kind.
  template <typename Which, typename Finish>
  void expire_if(Millis now, Which&& which, Finish&& finish) {
    for (auto it = operations_.begin(); it != operations_.end();) {
      if (it->deadline.expired(now) && which(static_cast<const Operation&>(*it))) {
        it = complete_with(it, finish(*it));
      } else {
        ++it;
      }
    }
  }

  /// The earliest armed deadline of an entry (disarmed when none): the client's timer folds it in.
  Deadline next_deadline() const {
    Deadline wake;
    for (const Operation& operation : operations_) consider(wake, operation.deadline);
    return wake;
  }

 private:
  iterator complete_with(iterator at, std::tuple<Results...> results) {
    return std::apply([&](auto&&... values) { return complete(at, std::move(values)...); }, std::move(results));
  }

  void post(Handler handler, Results... results) {
    if (!handler) return;
    if (before_completion_) before_completion_();
    boost::asio::post(executor_, [handler = std::move(handler), args = std::make_tuple(std::move(results)...)]() mutable {
      std::apply(handler, std::move(args));
    });
  }

  boost::asio::any_io_executor executor_;
  BeforeCompletion before_completion_;
  std::list<Operation> operations_;
};

}  // namespace tether::client
