#include "fake_ring.hpp"

#include <array>

namespace tether::elcano::testing {

// --- FakeRing ----------------------------------------------------------------------------------------------

std::shared_ptr<FakeRing> FakeRing::start(std::shared_ptr<transports::ByteStream> end, Generation generation,
                                          Script script) {
  auto ring = std::make_shared<FakeRing>(std::move(end), generation, 0);
  ring->on_message(std::move(script));
  ring->ScriptedPeer::start();
  return ring;
}

FakeRing::FakeRing(std::shared_ptr<transports::ByteStream> end, Generation generation, int)
    : ScriptedDevice(std::move(end)), reader_(generation, counters_) {}

std::vector<Arrival> FakeRing::arrivals() const {
  std::vector<Arrival> snapshot;
  inspect([&] { snapshot = arrivals_; });
  return snapshot;
}

void FakeRing::on_bytes(const std::uint8_t* data, std::size_t size) {
  const auto now = std::chrono::steady_clock::now();
  record([&] { arrivals_.push_back(Arrival{clock_->now(), size}); });
  for (std::size_t i = 0; i < size; ++i) {
    wire_.push_back(static_cast<char>(data[i]));
    const DecodeStatus status = reader_.feed(data[i]);
    if (status == DecodeStatus::more) continue;
    RingRecord entry;
    entry.wire = std::move(wire_);
    wire_.clear();
    entry.ok = status == DecodeStatus::frame;
    if (entry.ok) {
      entry.message = reader_.frame();
    } else {
      entry.error = reader_.error();
    }
    entry.at = now;
    deliver(entry);
  }
}

// --- messages ----------------------------------------------------------------------------------------------

std::string wire(const Message& message, Generation generation) {
  std::array<std::uint8_t, kMaxMessageBytes> buffer{};
  const Result<size_t> size = encode_message(message, generation, MutableByteView(buffer.data(), buffer.size()));
  return std::string(reinterpret_cast<const char*>(buffer.data()), size.ok() ? size.value() : 0);
}

Message sensor(std::int32_t speed) { return Message::sensor(speed, -12, 432, 420, 90210); }

Message goal(std::int32_t number) { return Message::goal(number, 90, 100, 200); }

Message segment(std::int32_t number) { return Message::segment(number, 160, 80, 3200, -64000); }

Options test_options(Duration attempt_ms, Duration budget_ms, std::shared_ptr<client::LinkClock> clock) {
  Options options;
  options.clock = std::move(clock);
  options.timing.attempt_timeout = attempt_ms;
  options.timing.call_budget = budget_ms;
  options.timing.max_attempts = 3;
  options.timing.retry_on_timeout = true;
  options.node.pacing.baud = 115200;
  options.node.pacing.receiver_buffer = 64;
  options.node.pacing.receiver_poll_interval = 0;
  return options;
}

Options on_steady_clock(Options options) {
  options.clock = client::steady_link_clock();
  return options;
}

session::LinkPacing trickle() {
  session::LinkPacing pacing;
  pacing.baud = 10;
  pacing.receiver_buffer = 2;
  pacing.receiver_poll_interval = 0;
  return pacing;
}

// --- Completions -------------------------------------------------------------------------------------------

void Completions::store(std::size_t index, Outcome outcome) {
  {
    std::lock_guard lock(state_->mutex);
    if (state_->outcomes.size() <= index) state_->outcomes.resize(index + 1);
    state_->outcomes[index] = std::move(outcome);
    ++state_->calls;
  }
  state_->changed.notify_all();
}

std::function<void(error_code)> Completions::send_handler(std::size_t index) {
  return [self = *this, index](error_code error) mutable { self.store(index, Outcome{error, std::nullopt}); };
}

std::function<void(error_code, Message)> Completions::message_handler(std::size_t index) {
  return [self = *this, index](error_code error, Message message) mutable {
    self.store(index, Outcome{error, message});
  };
}

bool Completions::wait_for(std::size_t count, std::chrono::milliseconds timeout) const {
  std::unique_lock lock(state_->mutex);
  return state_->changed.wait_for(lock, timeout, [&] { return state_->calls >= count; });
}

std::size_t Completions::calls() const {
  std::lock_guard lock(state_->mutex);
  return state_->calls;
}

std::optional<Outcome> Completions::at(std::size_t index) const {
  std::lock_guard lock(state_->mutex);
  return index < state_->outcomes.size() ? state_->outcomes[index] : std::nullopt;
}

// --- Link --------------------------------------------------------------------------------------------------

Link::Link(boost::asio::any_io_executor executor, Options options, FakeRing::Script script,
           std::size_t stream_capacity)
    : clock(ManualClock::create()) {
  if (!options.clock) options.clock = clock;
  auto [host_end, ring_end] = transports::InMemoryStream::make_pair(executor, stream_capacity);
  ring = FakeRing::start(ring_end, options.node.generation, std::move(script));
  client.emplace(host_end, options, log.handler());
}

Link::~Link() {
  if (client) client->close();
  ring->close();
}

}  // namespace tether::elcano::testing
