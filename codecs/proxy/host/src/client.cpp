// Client: the public front and the part of the implementation both protocols share (client_impl.hpp);
// the protocols themselves are primary_client.cpp and compat_client.cpp.
#include "tether/proxy/client.hpp"

#include <boost/asio/error.hpp>
#include <boost/system/system_error.hpp>

#include <stdexcept>
#include <utility>

#include "client_impl.hpp"

namespace tether::proxy {

namespace asio = boost::asio;
using transports::ByteStream;

AckTiming ProxyTiming::ack_timing() const {
  AckTiming timing;
  timing.baud = baud;
  timing.bits_per_byte = bits_per_byte;
  timing.processing_margin = processing_margin;
  timing.send_budget = send_budget;
  timing.max_sends = max_sends;
  return timing;
}

Duration ProxyTiming::ack_timeout(std::size_t frame_bytes) const { return proxy::ack_timeout(ack_timing(), frame_bytes); }

namespace detail {

std::shared_ptr<const std::string> frame_of(const std::string& payload, Integrity integrity) {
  std::string out(max_frame_size(payload.size()), '\0');
  const Result<size_t> size =
      encode_frame(ByteView::from_chars(payload.data(), payload.size()), integrity, true,
                   MutableByteView(reinterpret_cast<std::uint8_t*>(out.data()), out.size()));
  out.resize(size.ok() ? size.value() : 0);  // the buffer is sized for the worst case: always ok
  return std::make_shared<const std::string>(std::move(out));
}

std::string serialize(const AnyMessage& message) {
  if (const auto* in = std::get_if<ArduinoIn>(&message)) return in->SerializeAsString();
  if (const auto* compat = std::get_if<RocketryProto::ArduinoIn>(&message)) return compat->SerializeAsString();
  return std::string();
}

// ---------------------------------------------------------------------------------------------------------
// The shared part of the implementation

ClientImpl::ClientImpl(std::shared_ptr<ByteStream> stream, const Options& options, Integrity integrity)
    : ClientLink(std::move(stream), options.clock),
      options_(options),
      sends_(executor(), [this] { publish(); }),
      decoder_(integrity, counters_.link) {}

void ClientImpl::start() {
  post_to_strand([this] {
    start_reading();
    on_started(now());
    publish();
  });
}

void ClientImpl::submit(OperationId operation, Request request, SendHandler handler) {
  Built built = build(request);
  if (built.error) {
    post_completion(std::move(handler), built.error, SendResult());
    return;
  }
  if (!is_open()) {
    post_completion(std::move(handler), asio::error::operation_aborted, SendResult());
    return;
  }
  Send send;
  send.message = std::move(built.message);
  send.lane = built.lane;
  send.init = built.init;
  post_to_strand([this, operation, handler = std::move(handler), send = std::move(send)]() mutable {
    accept(operation, std::move(handler), std::move(send));
  });
}

void ClientImpl::accept(OperationId operation, SendHandler handler, Send send) {
  const Sends::iterator accepted = sends_.add(operation, std::move(handler), std::move(send));
  if (!is_open() || link_error()) {
    const error_code error = link_error() ? link_error() : error_code(asio::error::operation_aborted);
    sends_.complete(accepted, error, SendResult());
    return;
  }
  const Millis now = this->now();
  if (accepted->state.init && !register_init(accepted->state, now)) {
    sends_.complete(accepted, ProxyError::too_many_inits, SendResult());
    return;
  }
  on_accepted(accepted, now);
}

void ClientImpl::restart_session() {
  post_to_strand([this] {
    if (!is_open() || link_error()) return;
    restart(now());
    publish();
  });
}

std::optional<PinStatus> ClientImpl::pin_state(PinKind kind, std::uint32_t pin) const {
  std::lock_guard lock(mutex_);
  const auto found = pins_.find(PinKey(kind, pin));
  if (found == pins_.end()) return std::nullopt;
  return found->second.status;
}

std::vector<PinStatus> ClientImpl::pin_states() const {
  std::lock_guard lock(mutex_);
  std::vector<PinStatus> states;
  states.reserve(pins_.size());
  for (const auto& entry : pins_) states.push_back(entry.second.status);
  return states;
}

bool ClientImpl::register_init(const Send& send, Millis now) {
  const PinKey pin = *send.init;
  const auto known = init_keys_.find(pin);
  if (known != init_keys_.end()) {
    inits_.at(known->second).message = send.message;
    return true;
  }
  if (init_order_.size() >= kMaxInits) return false;
  const InitKey key = next_init_key_++;
  if (!admit_init(key)) return false;
  init_keys_.emplace(pin, key);
  inits_.emplace(key, InitEntry{pin, send.message});
  init_order_.push_back(key);
  std::lock_guard lock(mutex_);
  auto [it, inserted] = pins_.try_emplace(pin);
  if (inserted) {
    it->second.status.kind = pin.first;
    it->second.status.pin = pin.second;
    it->second.status.updated = now;  // the staleness rule counts from the init
  }
  return true;
}

bool ClientImpl::update_pin(PinKind kind, std::uint32_t pin, std::int32_t value, bool failsafe, Millis now) {
  std::lock_guard lock(mutex_);
  PinEntry& entry = pins_[PinKey(kind, pin)];
  const bool news = !entry.status.has_value || entry.status.value != value || entry.status.stale ||
                    entry.status.failsafe != failsafe;
  entry.status.kind = kind;
  entry.status.pin = pin;
  entry.status.has_value = true;
  entry.status.value = value;
  entry.status.failsafe = failsafe;
  entry.status.stale = false;
  entry.status.updated = now;
  return news;
}

void ClientImpl::undecodable(ByteView payload, bool malformed) {
  if (malformed) {
    ++counters_.undecodable;
  } else {
    ++counters_.unknown_messages;
  }
  events::UndecodableMessage event;
  event.payload.assign(reinterpret_cast<const char*>(payload.data()), payload.size());
  event.malformed = malformed;
  emit(event);
}

void ClientImpl::emit(const Event& event) {
  publish();
  events_.emit(event);
}

void ClientImpl::publish() {
  published_.set(counters_);
  published_session_.set(session_status());
}

void ClientImpl::on_bytes(const std::uint8_t* data, std::size_t size) {
  const Millis now = this->now();
  // A run of bytes per decoder call (its tight COBS + CRC loop) up to each frame; only a frame's handling
  // can close the client or fail the link, so they are checked after each one.
  std::size_t used = 0;
  while (used < size && is_open() && !link_error()) {
    const FeedResult fed = decoder_.feed(ByteView(data + used, size - used));
    used += fed.consumed;
    if (fed.status == DecodeStatus::frame) on_payload(decoder_.frame(), now);
  }
  pump(now);
}

void ClientImpl::on_link_failed(const error_code& error) {
  fail_all(error);
  emit(events::LinkFailed{error});
  publish();
}

void ClientImpl::on_link_restored() {
  on_restored(now());
  publish();
}

void ClientImpl::on_closed() {
  fail_all(asio::error::operation_aborted);
  publish();
}

void start_send(const std::shared_ptr<ClientImpl>& impl, client::ClientLink::OperationId operation,
                SendHandler handler, Request request) {
  impl->submit(operation, std::move(request), std::move(handler));
}

SendResult blocking_send(const ClientRef& client, Request request, error_code& error) {
  return client::wait_for_operation<SendResult>(
      *client.link(),
      [&](client::ClientLink::OperationId operation, SendHandler handler) {
        client.impl()->submit(operation, std::move(request), std::move(handler));
      },
      error);
}

SendResult blocking_send(const ClientRef& client, Request request) {
  return client::require([&](error_code& error) { return blocking_send(client, std::move(request), error); },
                             "proxy send");
}

std::optional<PinStatus> pin_state(const ClientRef& client, PinKind kind, std::uint32_t pin) {
  return client.impl()->pin_state(kind, pin);
}

}  // namespace detail

// ---------------------------------------------------------------------------------------------------------
// Client

namespace {
std::shared_ptr<ByteStream> checked_stream(std::shared_ptr<ByteStream> stream, const Options& options) {
  stream = client::require_stream(std::move(stream), "proxy::Client");
  const ProxyTiming& timing = options.timing;
  if (timing.baud == 0 || timing.bits_per_byte == 0 || timing.send_budget == 0 || timing.max_sends == 0) {
    throw std::invalid_argument("proxy::Client: baud, bits_per_byte, send_budget and max_sends must be > 0");
  }
  return stream;
}

// The one place the mode is read: each protocol is an implementation of its own.
std::shared_ptr<detail::ClientImpl> make_client_impl(std::shared_ptr<ByteStream> stream, const Options& options) {
  stream = checked_stream(std::move(stream), options);
  if (options.mode == Mode::primary) return detail::make_primary_client(std::move(stream), options);
  return detail::make_compat_client(std::move(stream), options);
}
}  // namespace

Client::Client(std::shared_ptr<ByteStream> stream, const Options& options, EventHandler handler)
    : ClientFront(make_client_impl(std::move(stream), options)) {
  on_event(std::move(handler));
  impl()->start();
}

Mode Client::mode() const { return impl()->mode(); }
void Client::restart_session() { impl()->restart_session(); }
Counters Client::counters() const { return impl()->counters(); }
SessionStatus Client::session() const { return impl()->session(); }
std::optional<PinStatus> Client::pin_state(PinKind kind, std::uint32_t pin) const {
  return impl()->pin_state(kind, pin);
}
std::vector<PinStatus> Client::pin_states() const { return impl()->pin_states(); }

}  // namespace tether::proxy
