#include "ring_harness.hpp"

#include <chrono>
#include <cstring>
#include <stdexcept>

#include "tether/transports/fault_model.hpp"

namespace tether::elcano::interop {

using namespace std::chrono_literals;
using transports::SimDuration;
using transports::VirtualUno;

std::filesystem::path node_image() { return std::filesystem::path(TETHER_FIRMWARE_DIR) / "elcano-node.elf"; }

node::NodeConfig node_config(std::uint8_t number, std::uint8_t capture_bits, std::uint8_t behaviour_bits,
                             Generation generation) {
  node::NodeConfig config;
  config.generation = generation;
  config.node_number = number;
  config.capture_bits = capture_bits;
  config.behaviour_bits = behaviour_bits;
  return config;
}

std::vector<node::NodeConfig> reference_ring(Generation generation) {
  return {
      node_config(1, kGoalBit, node::kAnswerGoalWithSegment, generation),
      node_config(2, kSensorBit | kSegmentBit, node::kAnswerSegmentWithDrive | node::kAnswerSensorWithDrive, generation),
      node_config(3, kDriveBit, node::kDriveServos | node::kReportDriveAsSensor, generation),
  };
}

std::string describe(const Message& message) {
  std::uint8_t text[128];
  const Result<std::size_t> written = encode_message(message, Generation::b, MutableByteView(text, sizeof text));
  if (!written.ok()) return std::string("<unwritable ") + static_cast<char>(message.type) + " message>";
  return std::string(reinterpret_cast<const char*>(text), written.value() - 1);  // without the '\n'
}

Ring::Ring(RingOptions options) : options_(std::move(options)), group_(transports::Pacing::fast, 64us) {
  if (options_.boards.empty()) throw std::invalid_argument("Ring: no boards");
  for (std::size_t i = 0; i < options_.boards.size(); ++i) {
    transports::VirtualUnoOptions board_options;
    const bool own_image = i < options_.images.size() && !options_.images[i].empty();
    board_options.firmware = own_image ? options_.images[i] : node_image();
    board_options.pacing = transports::Pacing::fast;
    board_options.seed = transports::FaultRandom::mix(options_.seed, 100 + i);
    board_options.name = "node" + std::to_string(i + 1);
    boards_.push_back(std::make_unique<VirtualUno>(board_options));
    if (options_.write_eeprom) {
      std::uint8_t block[node::kConfigBlockSize];
      node::encode_config(options_.boards[i], block);
      boards_.back()->write_eeprom(node::kConfigAddress, block);
    }
    group_.add(*boards_.back());
  }
  for (std::size_t i = 0; i + 1 < boards_.size(); ++i) group_.connect(*boards_[i], *boards_[i + 1]);
  // run_for() advances the group on this thread, so the handler runs here too: no locking.
  boards_.back()->set_output_handler([this](const std::uint8_t* data, std::size_t size) {
    inbox_.insert(inbox_.end(), data, data + size);
  });
  RingNodeConfig host_config;
  host_config.generation = options_.generation;
  host_config.capture = options_.host_capture;
  host_config.pacing = options_.host_pacing;
  host_ = std::make_unique<HostNode>(host_config, 0, host_link_, host_ring_);
}

Ring::~Ring() { boards_.back()->set_output_handler({}); }

Millis Ring::now() const {
  return static_cast<Millis>(std::chrono::duration_cast<std::chrono::milliseconds>(boards_.front()->simulated_time()).count());
}

void Ring::step(SimDuration duration) {
  group_.run_for(duration);
  const Millis at = now();
  while (!inbox_.empty()) {
    const std::uint8_t byte = inbox_.front();
    inbox_.pop_front();
    ++bytes_received_;
    dispatch(host_->feed(byte, at), at);
  }
  for (;;) {
    const RingEvent event = host_->poll(at);
    if (event.kind == RingEvent::Kind::none) break;
    dispatch(event, at);
  }
  pump(at);
}

void Ring::dispatch(const RingEvent& event, Millis at) {
  if (event.kind == RingEvent::Kind::none) return;
  events_.push_back(HostEvent{event, at});
  if (on_event) on_event(events_.back());
}

void Ring::pump(Millis at) {
  std::uint8_t chunk[256];
  const std::size_t count = host_->take_output(MutableByteView(chunk, sizeof chunk), at);
  if (count == 0) return;
  boards_.front()->write(std::span<const std::uint8_t>(chunk, count));
  bytes_sent_ += count;
}

void Ring::run(SimDuration duration, SimDuration step_size) {
  SimDuration done{0};
  while (done < duration) {
    const SimDuration slice = std::min(step_size, duration - done);
    step(slice);
    done += slice;
  }
}

bool Ring::run_until(const std::function<bool()>& done, SimDuration limit, SimDuration step_size) {
  SimDuration elapsed{0};
  while (!done()) {
    if (elapsed >= limit) return false;
    step(step_size);
    elapsed += step_size;
  }
  return true;
}

Status Ring::send(const Message& message) {
  const Millis at = now();
  const Status status = host_->originate(message, at);
  if (status == Status::ok) pump(at);
  return status;
}

std::size_t Ring::count(RingEvent::Kind kind, Type type) const {
  std::size_t total = 0;
  for (const HostEvent& entry : events_) {
    if (entry.event.kind == kind && entry.event.message.type == type) ++total;
  }
  return total;
}

std::size_t Ring::count(RingEvent::Kind kind) const {
  std::size_t total = 0;
  for (const HostEvent& entry : events_) total += entry.event.kind == kind ? 1 : 0;
  return total;
}

node::NodeStats Ring::stats(std::size_t index) {
  VirtualUno& uno = board(index);
  const auto symbol = uno.symbol(TETHER_ELCANO_NODE_STATS_SYMBOL);
  if (!symbol || symbol->space != transports::FirmwareSymbol::Space::data) {
    throw std::runtime_error("elcano-node.elf has no " TETHER_ELCANO_NODE_STATS_SYMBOL " in its data space");
  }
  if (symbol->size != sizeof(node::NodeStats)) {
    throw std::runtime_error("NodeStats layout differs between the image and the test (" + std::to_string(symbol->size) +
                             " vs " + std::to_string(sizeof(node::NodeStats)) + " bytes): rebuild both");
  }
  const auto address = static_cast<std::uint16_t>(symbol->address);
  for (int attempt = 0; attempt < 1000; ++attempt) {
    const std::vector<std::uint8_t> bytes = uno.read_memory(address, sizeof(node::NodeStats));
    node::NodeStats stats;
    std::memcpy(&stats, bytes.data(), sizeof stats);
    if (std::memcmp(stats.magic, node::kStatsMagic, sizeof stats.magic) != 0) {
      throw std::runtime_error("node " + std::to_string(index + 1) + " has not published its stats (not booted?)");
    }
    if ((stats.sequence & 1u) == 0) return stats;
    group_.run_for(10us);  // mid-update: let the main loop finish it (the host inbox keeps any bytes)
  }
  throw std::runtime_error("node " + std::to_string(index + 1) + ": stats never settled");
}

}  // namespace tether::elcano::interop
