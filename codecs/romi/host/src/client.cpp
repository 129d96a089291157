// Client: the session engine (romi::RequestTable) driven by the read loop and the timer of a
// client::ClientLink (which owns the strand, the write queue, close and the lifetime rules).
//
// Everything below `ClientImpl`'s public functions runs on the link's strand.
#include "tether/romi/client.hpp"

#include <boost/asio/error.hpp>
#include <boost/system/system_error.hpp>

#include <algorithm>
#include <cstdio>
#include <array>
#include <tuple>
#include <limits>
#include <mutex>
#include <stdexcept>
#include <random>
#include <utility>

#include "tether/core/time.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/romi/decoder.hpp"
#include "tether/client/client_link.hpp"
#include "tether/client/pending_operations.hpp"

namespace tether::romi {

namespace asio = boost::asio;
using transports::ByteStream;

// ---------------------------------------------------------------------------------------------------------
// Command

Command::Command(std::string_view text) : payload_(text) {
  std::size_t offset = 0;
  const Error code = validate_request_payload(ByteView::from_chars(text.data(), text.size()), offset);
  if (code == Error::no_error) return;
  error_ = make_error_code(code);
  if (code != Error::client_empty_request && code != Error::client_request_too_long) error_offset_ = offset;
}

std::string Command::error_text() const {
  if (!error_) return "";
  std::string text = romi::describe(static_cast<std::int16_t>(error_.value()));
  if (!error_offset_) return text;
  if (*error_offset_ >= payload_.size()) return text + " at the end (the command is incomplete)";
  const auto c = static_cast<unsigned char>(payload_[*error_offset_]);
  char shown[8];
  if (c >= 0x20 && c < 0x7f) {
    std::snprintf(shown, sizeof shown, "'%c'", static_cast<char>(c));
  } else {
    std::snprintf(shown, sizeof shown, "\\x%02x", c);
  }
  return text + " at character " + std::to_string(*error_offset_ + 1) + " (" + shown + ")";
}

Command::Command(char opcode, const std::vector<std::int32_t>& ints, std::optional<std::string_view> text) {
  RequestBuilder builder(opcode);
  for (const std::int32_t value : ints) builder.add_int(value);
  if (text) builder.add_string(ByteView::from_chars(text->data(), text->size()));
  if (builder.error() != Error::no_error) {
    error_ = make_error_code(builder.error());
    payload_.assign(1, opcode);  // keeps opcode() meaningful for the failure's response
    return;
  }
  const ByteView payload = builder.payload();
  payload_.assign(reinterpret_cast<const char*>(payload.data()), payload.size());
}

namespace {

// ---------------------------------------------------------------------------------------------------------
// Responses

RomiResponse failure(std::int16_t code, char opcode) {
  RomiResponse response;
  response.opcode = opcode;
  describe_failure(response, code, romi::describe(code));
  return response;
}

// What a timed-out call says: how long it waited for an answer from its first send (to the deadline
// that ended it, so a late timer does not change the figure), and the sends when there were several.
std::string timeout_message(Duration waited, std::uint8_t sends) {
  std::string text = "client: no reply from the device within " + std::to_string(waited) + " ms";
  if (sends > 1) text += " (" + std::to_string(sends) + " sends)";
  return text;
}

// Whether an answer carrying `answer_opcode` and `code` may belong to a call with `call_opcode`: success
// and application answers mirror the opcode; error answers may echo another one (rule 6 of the header).
bool opcode_matches(char call_opcode, char answer_opcode, std::int16_t code) {
  return code < 0 || answer_opcode == call_opcode;
}

}  // namespace

// Romi codes keep theirs, anything else is -33.
RomiResponse failed_response(const error_code& error, char opcode) {
  if (error.category() == romi_category()) return failure(static_cast<std::int16_t>(error.value()), opcode);
  RomiResponse response;
  response.opcode = opcode;
  const auto code = static_cast<std::int16_t>(Error::transport_error);
  describe_failure(response, code, std::string(romi::describe(code)) + ": " + error.message());
  return response;
}

RomiResponse failed_response(const Command& command) {
  RomiResponse response = failed_response(command.error(), command.opcode());
  if (!command.valid()) describe_failure(response, response.code, command.error_text());
  return response;
}

// ---------------------------------------------------------------------------------------------------------
// The implementation

namespace detail {

class ClientImpl final : public client::ClientLink {
 public:
  ClientImpl(std::shared_ptr<ByteStream> stream, const Options& options)
      : ClientLink(std::move(stream), options.clock),
        decoder_(counters_),
        table_(options.timing, options.last_id, counters_),
        calls_(executor(), [this] { publish(); }) {}

  // Starts the read loop (after construction: it needs shared_from_this).
  void start() {
    post_to_strand([this] { start_reading(); });
  }

  void submit(OperationId operation, Command command, bool manual, CallHandler handler) {
    const char opcode = command.opcode();
    // Off the strand: these completions touch no state (and must not publish the counters).
    if (!command.valid()) {
      post_completion(std::move(handler), command.error(), failed_response(command));
      return;
    }
    if (!is_open()) {
      const error_code aborted = asio::error::operation_aborted;
      post_completion(std::move(handler), aborted, failed_response(aborted, opcode));
      return;
    }
    Call call;
    call.payload = command.payload();
    call.opcode = opcode;
    call.manual = manual;
    post_to_strand([this, operation, call = std::move(call), handler = std::move(handler)]() mutable {
      calls_.add(operation, std::move(handler), std::move(call));
      start_next();
      publish();
    });
  }

  client::EventHandlers<Event>& event_handlers() { return events_; }

  void set_timing(const session::CallTiming& timing) {
    post_to_strand([this, timing] { table_.set_timing(timing); });
  }

  LinkCounters counters() const { return published_.get(); }

 private:
  // A call from acceptance to completion; the oldest is in flight once `started`.
  struct Call {
    std::string payload;
    char opcode = '\0';
    bool manual = false;
    bool started = false;
    std::shared_ptr<const std::string> frame;  // the encoded bytes, re-sent as they are
    std::uint8_t id = 0;
    Millis sent_at = 0;     // first send: a timeout says how long the call waited from here
    Millis budget_end = 0;  // where the call budget ends (the engine's, fixed at the first send)
    // The last failure reported to the engine was no answer of this request (our decoder found a frame
    // damaged, or the device reported a damaged envelope under another id): if it ends the call, it is an
    // error_code, not an answer.
    bool failed_without_answer = false;
    RomiResponse answer;  // the intact answer that completed the call
  };
  using Table = RequestTable;
  using Calls = client::PendingOperations<CallSignature, Call>;

  // The call in flight (the oldest, once started), or null.
  Call* current() { return !calls_.empty() && calls_.begin()->state.started ? &calls_.begin()->state : nullptr; }

  // --- calls -----------------------------------------------------------------------------------------

  void start_next() {
    while (!calls_.empty() && !calls_.begin()->state.started) {
      Call* const call = &calls_.begin()->state;
      if (!is_open() || link_error()) {
        const error_code error = link_error() ? link_error() : error_code(asio::error::operation_aborted);
        calls_.complete(calls_.begin(), error, failed_response(error, call->opcode));
        continue;
      }
      const Millis started = now();
      if (call->manual) {
        // The answer carries id 00: the call occupies id 0 in the table (the sequence is not advanced).
        const Result<std::uint8_t> id = table_.begin_with(0, started);
        call->id = id.ok() ? id.value() : 0;
        skip_id_zero_ = true;
      } else {
        Result<std::uint8_t> id = table_.begin(started);
        if (id.ok() && id.value() == 0 && skip_id_zero_) {
          // Defect B6: the reference firmware remembers the manual call's id 0 as its last id.
          (void)table_.cancel(0);
          id = table_.begin(started);
        }
        skip_id_zero_ = false;
        call->id = id.ok() ? id.value() : 0;
      }
      std::array<std::uint8_t, kMaxRequestFrame> buffer{};
      const ByteView payload = ByteView::from_chars(call->payload.data(), call->payload.size());
      const MutableByteView out(buffer.data(), buffer.size());
      const Result<size_t> size =
          call->manual ? encode_manual_request(payload, out) : encode_request(payload, call->id, out);
      // Validation bounds the payload to 56 characters, so the frame always fits 64 bytes.
      call->frame = std::make_shared<const std::string>(reinterpret_cast<const char*>(buffer.data()),
                                                        size.ok() ? size.value() : 0);
      call->sent_at = started;
      call->budget_end = static_cast<Millis>(started + table_.timing().call_budget);
      call->started = true;
      write(call->frame);
      arm_timer();
    }
  }

  // Ends the current call with the engine's verdict; `waited` is how long a timed-out call waited.
  void finish(const Table::Completion& completion, Duration waited = 0) {
    Call* const call = current();
    error_code error;
    RomiResponse response;
    switch (completion.outcome) {
      case session::CallOutcome::ok:
        response = std::move(call->answer);
        break;
      case session::CallOutcome::remote_error:
        if (call->failed_without_answer) {
          error = make_romi_error_code(completion.code);  // every answer arrived damaged
          response = failed_response(error, call->opcode);
        } else {
          response = std::move(call->answer);
        }
        break;
      case session::CallOutcome::timeout:
        error = make_error_code(Error::client_timeout);
        response = failed_response(error, call->opcode);
        describe_failure(response, response.code, timeout_message(waited, completion.attempts));
        break;
      case session::CallOutcome::cancelled:
        error = asio::error::operation_aborted;
        response = failed_response(error, call->opcode);
        break;
    }
    response.id = call->id;
    response.attempts = completion.attempts;
    calls_.complete(calls_.begin(), error, std::move(response));
    start_next();
    arm_timer();
  }

  // What `call` completes with when it ends with `error` before its answer (cancelled, closed, failed
  // link); a call in flight leaves the engine (its late answer is stale).
  std::tuple<error_code, RomiResponse> aborted(Call& call, const error_code& error) {
    RomiResponse response = failed_response(error, call.opcode);
    if (call.started) {
      const Result<Table::Completion> cancelled = table_.cancel(call.id);
      response.id = call.id;
      response.attempts = cancelled.ok() ? cancelled.value().attempts : 0;
    }
    return {error, std::move(response)};
  }

  void fail_all(const error_code& error) {
    calls_.fail_all([&](Calls::Operation& call) { return aborted(call.state, error); });
  }

  // --- the link's hooks -----------------------------------------------------------------------------------

  // A received run goes to the decoder in one call up to each frame or error (its body loop).
  void on_bytes(const std::uint8_t* data, std::size_t size) override {
    for (std::size_t used = 0; used < size;) {
      const FeedResult fed = decoder_.feed(ByteView(data + used, size - used));
      used += fed.consumed;
      on_event(fed.status);
    }
    arm_timer();
    publish();
  }

  void on_link_failed(const error_code& error) override {
    fail_all(error);
    publish();
    events_.emit(events::LinkFailed{error});
  }

  void on_closed() override {
    fail_all(asio::error::operation_aborted);
    publish();
  }

  void on_cancel(OperationId operation) override {
    const bool in_flight = current() != nullptr && calls_.begin()->id == operation;
    const error_code error = asio::error::operation_aborted;
    if (!calls_.cancel(operation, [&](Calls::Operation& call) { return aborted(call.state, error); })) return;
    if (in_flight) {
      start_next();
      arm_timer();
    }
  }

  void on_event(DecodeStatus status) {
    switch (status) {
      case DecodeStatus::more:
        return;
      case DecodeStatus::frame:
        if (decoder_.frame().log) {
          deliver_log(decoder_.frame().payload);
          table_.on_activity(now());
          return;
        }
        on_frame(decoder_.frame());
        return;
      case DecodeStatus::error:
        on_damaged_frame(decoder_.error(), decoder_.frame());
        return;
    }
  }

  void on_frame(const Frame& event) {
    const Millis at = now();
    Call* const call = current();
    if (!event.has_id || !call) {
      // A frame with `xxxx` metadata (not a log line) or an answer nobody waits for.
      stale(at, event);
      return;
    }
    RomiResponse answer = parse_answer(event.payload, event.opcode);
    const bool matches = call->manual ? event.id == 0 && opcode_matches(call->opcode, event.opcode, answer.code)
                                      : event.id == call->id && opcode_matches(call->opcode, event.opcode, answer.code);
    if (!matches) {
      // An envelope error under another id (`#e[-2]:00..`: the device could not read our id) means the
      // device executed nothing, so the same bytes may go again. It never completes the call: only this
      // request's own answer does, so once the sends are used up it is stale like any other frame.
      if (is_envelope_error(answer.code) && table_.attempts(call->id) < table_.timing().max_attempts) {
        on_exchange_damaged(answer.code, at);
        return;
      }
      stale(at, event);
      return;
    }
    const Table::ReplyResult result = table_.on_reply(call->id, answer.code, at);
    switch (result.verdict) {
      case Table::Verdict::completed:
        call->failed_without_answer = false;
        call->answer = std::move(answer);
        finish(result.completion);
        return;
      case Table::Verdict::resend:
        write(call->frame);
        return;
      case Table::Verdict::stale:  // not reached: the call is in flight
        table_.on_activity(at);
        return;
    }
  }

  // A frame that is not the current call's answer: counted, dropped, and it re-arms the attempt window.
  void stale(Millis at, const Frame& event) {
    if (event.has_id && !table_.contains(event.id)) {
      (void)table_.on_reply(event.id, 0, at);  // the engine counts it
    } else {
      ++counters_.stale;  // an id in flight with the wrong opcode, or no id at all
    }
    table_.on_activity(at);
  }

  // Our decoder rejected a frame (CRC mismatch, bad metadata, too long, ...) while a call waits: its
  // answer was probably lost, so the call fails retryably (same bytes again; Tether firmware answers a
  // repeated id from its cache). A damaged log line (`#!...`, or -7: bad `xxxx`, which only log lines
  // carry) is no lost answer: it only re-arms the window.
  void on_damaged_frame(Error error, const Frame& event) {
    const Millis at = now();
    if (current() == nullptr) return;
    const auto code = static_cast<std::int16_t>(error);
    if (!is_envelope_error(code) || event.log) {
      table_.on_activity(at);
      return;
    }
    on_exchange_damaged(code, at);
  }

  // The request or its answer was damaged on the way and no answer of this request is in hand: the same
  // bytes go again while the engine allows; otherwise the call fails with `code` as its error_code.
  void on_exchange_damaged(std::int16_t code, Millis at) {
    Call* const call = current();
    const Table::ReplyResult result = table_.on_reply(call->id, code, at);
    switch (result.verdict) {
      case Table::Verdict::completed:
        call->failed_without_answer = true;
        finish(result.completion);
        return;
      case Table::Verdict::resend:
        write(call->frame);
        return;
      case Table::Verdict::stale:
        return;
    }
  }

  void deliver_log(ByteView text) {
    if (events_.empty()) return;
    events_.emit(events::Log{std::string(reinterpret_cast<const char*>(text.data()), text.size())});
  }

  // --- deadlines -----------------------------------------------------------------------------------------

  void arm_timer() { ClientLink::arm_timer(table_.next_wakeup()); }

  void on_timer() override {
    for (;;) {
      const Millis at = now();
      const Deadline due = table_.next_wakeup();  // the deadline poll acts on, however late the timer fired
      const Table::Step step = table_.poll(at);
      if (step.action == Table::Action::idle) break;
      Call* const call = current();
      if (step.action == Table::Action::resend) {
        if (call) write(call->frame);
      } else if (call && call->id == step.id) {
        finish(step.completion, waited_until(due, at));
      }
    }
    arm_timer();
    publish();
  }

  // How long the current call waited when its deadline `due` passed, seen at `at`: to its budget's end
  // when that passed too (the engine checks the budget first), else to the attempt window's end.
  Duration waited_until(const Deadline& due, Millis at) {
    const Call* const call = current();
    const Millis end = tick_reached(at, call->budget_end) || !due.armed() ? call->budget_end : due.at();
    return static_cast<Duration>(std::max<std::int32_t>(tick_difference(end, call->sent_at), 0));
  }

  void publish() { published_.set(counters_); }

  // Strand only.
  LinkCounters counters_;
  Decoder<kHostDecoderCapacity> decoder_;
  Table table_;
  Calls calls_;  // in acceptance order; the first is in flight once started
  bool skip_id_zero_ = false;

  // Any thread.
  client::Published<LinkCounters> published_;
  client::EventHandlers<Event> events_;
};

void start_call(const std::shared_ptr<ClientImpl>& impl, client::ClientLink::OperationId operation,
                CallHandler handler, Command command, bool manual) {
  impl->submit(operation, std::move(command), manual, std::move(handler));
}

}  // namespace detail

// ---------------------------------------------------------------------------------------------------------
// Client

Client::Client(std::shared_ptr<transports::ByteStream> stream, const Options& options, EventHandler handler)
    : ClientFront(std::make_shared<detail::ClientImpl>(client::require_stream(std::move(stream), "romi::Client"),
                                                       options)) {
  on_event(std::move(handler));
  impl()->start();
}

RomiResponse Client::blocking_call(const Command& command, bool manual, error_code& error) {
  const RomiResponse response = client::wait_for_operation<RomiResponse>(
      link(), [&](client::ClientLink::OperationId operation, detail::CallHandler handler) {
        detail::start_call(impl(), operation, std::move(handler), command, manual);
      }, error);
  if (error == transports::TransportError::would_deadlock) return failed_response(error, command.opcode());
  return response;
}

RomiResponse Client::call(const Command& command, error_code& error) { return blocking_call(command, false, error); }

RomiResponse Client::call_manual(const Command& command, error_code& error) {
  return blocking_call(command, true, error);
}

RomiResponse Client::call(const Command& command) {
  return client::require([&](error_code& error) { return blocking_call(command, false, error); },
                             "romi call " + command.payload());
}

RomiResponse Client::call_manual(const Command& command) {
  return client::require([&](error_code& error) { return blocking_call(command, true, error); },
                             "romi manual call " + command.payload());
}

std::uint8_t random_first_id() {
  static std::mutex mutex;
  static std::mt19937 generator{std::random_device{}()};
  const std::lock_guard lock(mutex);
  return static_cast<std::uint8_t>(std::uniform_int_distribution<int>(0, 254)(generator));
}

void Client::set_timing(const session::CallTiming& timing) { impl()->set_timing(timing); }

Counters Client::counters() const { return Counters{impl()->counters()}; }

}  // namespace tether::romi
