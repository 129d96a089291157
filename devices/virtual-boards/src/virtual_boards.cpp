// Virtual boards and rings of a rover configuration, on the simulator. Tether::virtual_uno: enable_virtual_boards()
// hands the opener to rover.cpp.
#include "tether/devices/virtual_boards.hpp"

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <variant>
#include <vector>

#include "tether/transports/fault_model.hpp"
#include "tether/transports/transport_error.hpp"
#include "tether/transports/virtual_uno.hpp"
#include "tether/transports/virtual_uno_clock.hpp"
#include "tether/transports/virtual_uno_stream.hpp"
#include "virtual_board_opener.hpp"

namespace tether::devices::detail {

namespace {

[[noreturn]] void fail(std::string path, std::string detail, error_code code) {
  throw ConfigError(std::move(path), std::move(detail), code);
}

std::shared_ptr<transports::VirtualUnoStream> open_virtual(const VirtualTransport& virt, const std::string& path,
                                                          const boost::asio::any_io_executor& executor) {
  error_code error;
  auto stream = transports::VirtualUnoStream::open(executor, virt.board, error);
  if (!error) return stream;
  if (error == transports::TransportError::boot_timeout) {
    fail(path, virt.board.firmware.string() + ": the firmware did not enable its UART receiver within " +
                   std::to_string(transports::VirtualUnoStream::kBootLimit.count()) + " ms",
         error);
  }
  // Everything else concerns the image: missing, unreadable, not an AVR ELF, too large.
  fail(path + ".firmware", virt.board.firmware.string() + ": " + error.message(), error);
}

// --- virtual rings ------------------------------------------------------------------------------------------

// The boards of a virtual ring and their lockstep group. The ring's stream holds aliasing pointers to it, so
// the boards outlive the stream (its destructor touches the last board); the rover stops the group when the
// device closes.
struct VirtualRing {
  std::vector<std::unique_ptr<transports::VirtualUno>> boards;
  std::unique_ptr<transports::VirtualUnoGroup> group;
  VirtualRing() = default;
  VirtualRing(const VirtualRing&) = delete;
  VirtualRing& operator=(const VirtualRing&) = delete;
  ~VirtualRing() {
    if (group) group->stop();
    group.reset();  // as the interop ring harness: the group goes first, then its (stopped) members
  }
};

std::shared_ptr<transports::ByteStream> open_virtual_ring(const VirtualRingTransport& ring, const std::string& device_name,
                                                          const std::string& path,
                                                          const boost::asio::any_io_executor& executor,
                                                          std::function<void()>& stop,
                                                          std::vector<std::shared_ptr<transports::VirtualUno>>& boards) {
  auto owned = std::make_shared<VirtualRing>();
  owned->group = std::make_unique<transports::VirtualUnoGroup>(ring.pacing);
  for (std::size_t i = 0; i < ring.boards.size(); ++i) {
    const RingBoardConfig& board = ring.boards[i];
    const std::string board_path = path + ".boards[" + std::to_string(i) + "]";
    transports::VirtualUnoOptions board_options;
    board_options.firmware = board.firmware;
    board_options.pacing = ring.pacing;
    board_options.seed = transports::FaultRandom::mix(ring.seed, i);
    board_options.name = device_name + "[" + std::to_string(i) + "]";
    std::error_code created;
    auto uno = transports::VirtualUno::create(board_options, created);
    if (!uno) {
      fail(board_path + ".firmware", board.firmware.string() + ": " + created.message(),
           transports::to_boost_error(created));
    }
    if (board.eeprom.size() > transports::atmega328p::kEepromSize) {
      fail(board_path + ".eeprom", "expected at most " + std::to_string(transports::atmega328p::kEepromSize) +
                                       " bytes, got " + std::to_string(board.eeprom.size()),
           make_error_code(DevicesError::invalid_config));
    }
    if (!board.eeprom.empty()) uno->write_eeprom(0, board.eeprom);
    owned->group->add(*uno);
    owned->boards.push_back(std::move(uno));
  }
  for (std::size_t i = 0; i + 1 < owned->boards.size(); ++i) {
    owned->group->connect(*owned->boards[i], *owned->boards[i + 1]);
  }
  // Host TX -> first board, last board -> host RX (VirtualUnoStream::attach_ring, but owning the ring).
  std::shared_ptr<transports::VirtualUno> first(owned, owned->boards.front().get());
  std::shared_ptr<transports::VirtualUno> last(owned, owned->boards.back().get());
  auto stream = std::make_shared<transports::VirtualUnoStream>(executor, std::move(first), std::move(last), false);
  owned->group->start();
  // Ready when every firmware has enabled its receiver (bytes sent before are lost, as on real boards).
  const auto deadline = std::chrono::steady_clock::now() + transports::VirtualUnoStream::kBootLimit;
  for (std::size_t i = 0; i < owned->boards.size(); ++i) {
    while (!owned->boards[i]->uart().rx_enabled) {
      if (std::chrono::steady_clock::now() >= deadline) {
        stream->close();
        fail(path + ".boards[" + std::to_string(i) + "]",
             ring.boards[i].firmware.string() + ": the firmware did not enable its UART receiver within " +
                 std::to_string(transports::VirtualUnoStream::kBootLimit.count()) + " ms",
             make_error_code(transports::TransportError::boot_timeout));
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
  }
  for (const auto& board : owned->boards) boards.emplace_back(owned, board.get());  // share the ring's ownership
  stop = [ring_ref = std::weak_ptr<VirtualRing>(owned)] {
    if (auto held = ring_ref.lock()) held->group->stop();
  };
  return stream;
}

OpenedTransport open_virtual_device(const DeviceConfig& device, const std::string& transport_path,
                                    const boost::asio::any_io_executor& executor) {
  OpenedTransport opened;
  if (const auto* virt = std::get_if<VirtualTransport>(&device.transport)) {
    auto board_stream = open_virtual(*virt, transport_path + ".virtual", executor);
    opened.boards.emplace_back(board_stream, &board_stream->board());  // shares the stream's ownership
    opened.clock = transports::VirtualUnoClock::create(board_stream);
    opened.stream = std::move(board_stream);
  } else {
    opened.stream = open_virtual_ring(std::get<VirtualRingTransport>(device.transport), device.name,
                                      transport_path + ".virtual_ring", executor, opened.stop, opened.boards);
    // The group keeps its boards in lockstep, so any board's time is the ring's: the first, which the host
    // writes to (as VirtualUnoClock::create(stream) picks). It keeps the ring alive, as the stream does.
    opened.clock = transports::VirtualUnoClock::create(opened.boards.front());
  }
  return opened;
}

}  // namespace

}  // namespace tether::devices::detail

namespace tether::devices {

void enable_virtual_boards() noexcept { detail::register_virtual_board_opener(&detail::open_virtual_device); }

}  // namespace tether::devices
