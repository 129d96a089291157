// Supervision of a serial device, end to end: a virtual Uno (romi-rover image, with its execution witness)
// behind a pty named by a stable by-id symlink in a fake tree. The pty is unplugged (its master closed, the
// symlink removed) while the client calls, and comes back under another /dev/pts/N behind the same name.
// Calls in flight and during the outage fail with `disconnected`, the first call after the return succeeds,
// and the witness shows that nothing executed twice (nor anything that failed). No sleep decides anything:
// the test waits for the link events and the bytes it expects, with generous limits that only bound a hang.
#include <gtest/gtest.h>

#include <unistd.h>

#include <boost/asio/buffer.hpp>
#include <boost/asio/use_future.hpp>

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <mutex>
#include <set>
#include <stdexcept>
#include <system_error>
#include <span>
#include <string>
#include <vector>

#include "tether/core/execution_witness.hpp"
#include "tether/demo/exactly_once.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"
#include "tether/devices/virtual_boards.hpp"
#include "tether/romi/client.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether/transports/testing/fake_port_tree.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::devices {
namespace {

using namespace std::chrono_literals;
constexpr auto kHangLimit = 20s;  // only bounds a hang; nothing waits this long when it works
constexpr const char* kById = "usb-Tether_Virtual_Uno_4242-if00";

// Runs the board and bridges its UART to whichever pty is "plugged in"; can hold back what the host sends.
class UnpluggableBoard {
 public:
  UnpluggableBoard(transports::IoThread& io, transports::testing::FakePortTree& tree) : io_(io), tree_(tree) {
    transports::VirtualUnoOptions options;
    options.firmware = std::filesystem::path(TETHER_FIRMWARE_DIR) / "romi-rover.elf";
    options.pacing = transports::Pacing::real_time;
    std::error_code error;
    std::string message;
    board_ = transports::VirtualUno::create(options, error, &message);
    if (!board_) throw std::runtime_error("virtual Uno: " + message);
    board_->set_output_handler([this](const std::uint8_t* data, std::size_t size) {
      std::lock_guard lock(mutex_);
      if (pty_) (void)!::write(pty_->object().native_handle(), data, size);  // unplugged: lost, as on a wire
    });
    board_->start();
    plug();
  }
  ~UnpluggableBoard() {
    board_->stop();
    unplug(/*for_good=*/true);
    if (spare_) spare_->close();
  }

  transports::VirtualUno& board() { return *board_; }

  // A new pty behind the by-id name; returns its slave path.
  std::string plug() {
    auto pty = spare_ ? std::move(spare_) : transports::PtyStream::open(io_.executor());
    {
      std::lock_guard lock(mutex_);
      if (pty_) ADD_FAILURE() << "plugged twice";
      pty_ = pty;
      ++generation_;
    }
    read_loop(pty, generation_);
    tree_.add_by_id(kById, pty->slave_path());
    return pty->slave_path();
  }
  // Removes the by-id name and closes the pty's master: the host side reads EOF/EIO. The next plug's pty
  // is opened first, while this one's number is taken, so it comes back under another /dev/pts/N.
  void unplug(bool for_good = false) {
    if (!for_good) spare_ = transports::PtyStream::open(io_.executor());
    std::shared_ptr<transports::PtyStream> pty;
    {
      std::lock_guard lock(mutex_);
      pty = std::move(pty_);
    }
    tree_.remove_by_id(kById);
    if (pty) pty->close();
  }
  // While held, bytes from the host are kept here instead of reaching the board.
  void hold(bool held) {
    std::lock_guard lock(mutex_);
    held_ = held;
    held_bytes_.clear();
  }
  // Waits until at least `count` held bytes arrived.
  bool wait_held(std::size_t count) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, kHangLimit, [&] { return held_bytes_.size() >= count; });
  }

 private:
  void read_loop(const std::shared_ptr<transports::PtyStream>& pty, std::uint64_t generation) {
    auto buffer = std::make_shared<std::array<std::uint8_t, 256>>();
    pty->async_read_some(boost::asio::buffer(*buffer), [this, pty, generation, buffer](boost::system::error_code error,
                                                                                        std::size_t size) {
      if (error) return;  // closed (unplugged)
      {
        std::lock_guard lock(mutex_);
        if (generation != generation_) return;
        if (held_) {
          held_bytes_.append(reinterpret_cast<const char*>(buffer->data()), size);
          changed_.notify_all();
        } else {
          board_->write(std::span<const std::uint8_t>(buffer->data(), size));
        }
      }
      read_loop(pty, generation);
    });
  }

  transports::IoThread& io_;
  transports::testing::FakePortTree& tree_;
  std::unique_ptr<transports::VirtualUno> board_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::shared_ptr<transports::PtyStream> pty_;
  std::shared_ptr<transports::PtyStream> spare_;
  std::uint64_t generation_ = 0;
  bool held_ = false;
  std::string held_bytes_;
};

// Link events as they come, for waiting on them.
class EventLog {
 public:
  void add(const transports::LinkEvent& event) {
    std::lock_guard lock(mutex_);
    events_.push_back(event);
    changed_.notify_all();
  }
  // Waits for the `n`th event (1-based) and returns it.
  transports::LinkEvent wait(std::size_t n) {
    std::unique_lock lock(mutex_);
    if (!changed_.wait_for(lock, kHangLimit, [&] { return events_.size() >= n; })) {
      ADD_FAILURE() << "no link event #" << n;
      return {};
    }
    return events_[n - 1];
  }
  std::size_t size() {
    std::lock_guard lock(mutex_);
    return events_.size();
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::vector<transports::LinkEvent> events_;
};

romi::Command servos(int throttle) { return romi::Command('S', {throttle, 1500}); }
std::uint32_t key(int throttle) { return witness_key(static_cast<std::uint16_t>(throttle), 1500); }

// A romi-rover board behind the by-id name kById, in a fake port tree the lookup reads.
class DevicesReconnect : public ::testing::Test {
 protected:
  void SetUp() override {
    if (!std::filesystem::exists(std::filesystem::path(TETHER_FIRMWARE_DIR) / "romi-rover.elf")) {
      GTEST_SKIP() << "romi-rover image not built";
    }
    enable_virtual_boards();
    board_.emplace(io, tree_);
  }
  UnpluggableBoard& board() { return *board_; }

  transports::IoThread io;

 private:
  transports::testing::FakePortTree tree_;
  const transports::testing::UsingFakePortTree use_{tree_};
  std::optional<UnpluggableBoard> board_;
};

TEST_F(DevicesReconnect, ARomiDeviceSurvivesItsPortComingBackUnderAnotherPath) {
  UnpluggableBoard& uno = board();
  auto witness = demo::ExecutionWitness::attach(uno.board());
  ASSERT_TRUE(witness);

  const RoverConfig config = parse_config(std::string(R"({"devices": [{"name": "rover", "codec": "romi", "transport":)") +
                                          R"({"serial": {"port": {"by_id": ")" + kById +
                                          R"("}, "boot_wait_ms": 0}}, "options": {"call_budget_ms": 3000,)" +
                                          R"( "attempt_timeout_ms": 1000, "max_attempts": 3}}]})");
  Rover rover = open_rover(config, io.executor());
  (void)witness->read();  // what the boot did is not a call's
  const RoverDevice& device = rover.devices().at(0);
  ASSERT_TRUE(device.port);
  EventLog events;
  device.port->add_link_handler([&events](const transports::LinkEvent& event) { events.add(event); });
  const std::string first_path = device.port->path();
  auto client = rover.client<romi::Client>("rover");

  std::set<std::uint32_t> confirmed;
  std::set<std::uint32_t> failed;
  const auto call = [&](int throttle) {
    error_code error;
    const romi::RomiResponse response = client->call(servos(throttle), error);
    (error || response.code != 0 ? failed : confirmed).insert(key(throttle));
    return error;
  };
  ASSERT_FALSE(call(1100));

  // A call in flight when the port vanishes: its request reached the "wire" but not the board.
  uno.hold(true);
  auto in_flight = client->async_call(servos(1200), boost::asio::use_future);
  ASSERT_TRUE(uno.wait_held(1));
  uno.unplug();
  const transports::LinkEvent down = events.wait(1);
  EXPECT_EQ(down.kind, transports::LinkEvent::Kind::down);
  EXPECT_NE(down.reason.find(first_path), std::string::npos) << down.reason;
  try {
    in_flight.get();
    ADD_FAILURE() << "the call in flight completed";
  } catch (const boost::system::system_error& error) {
    EXPECT_EQ(error.code(), make_error_code(transports::TransportError::disconnected)) << error.what();
  }
  failed.insert(key(1200));

  // During the outage new calls fail at once (well within the call budget).
  const auto before = std::chrono::steady_clock::now();
  EXPECT_EQ(call(1300), make_error_code(transports::TransportError::disconnected));
  EXPECT_EQ(call(1400), make_error_code(transports::TransportError::disconnected));
  EXPECT_LT(std::chrono::steady_clock::now() - before, 1s);  // the budget is 3 s: no call waited for it
  EXPECT_EQ(device.port->link_counters().disconnects, 1u);
  EXPECT_FALSE(device.port->link_counters().up);

  // Back under another pts number behind the same by-id name.
  uno.hold(false);
  const std::string second_path = uno.plug();
  EXPECT_NE(second_path, first_path);
  const transports::LinkEvent up = events.wait(2);
  EXPECT_EQ(up.kind, transports::LinkEvent::Kind::up);
  EXPECT_EQ(up.path, second_path);
  EXPECT_EQ(device.port->path(), second_path);
  EXPECT_FALSE(call(1700));  // the first call after the return succeeds
  EXPECT_FALSE(call(1600));
  const transports::LinkCounters counters = device.port->link_counters();
  EXPECT_EQ(counters.disconnects, 1u);
  EXPECT_EQ(counters.reconnects, 1u);
  EXPECT_TRUE(counters.up);
  EXPECT_EQ(events.size(), 2u);  // one down, one up: no event per failed attempt

  // The witness: exactly the confirmed commands ran, each once; nothing that failed ran.
  const demo::ExecutionWitness::Reading reading = witness->read();
  EXPECT_FALSE(reading.rebooted);
  EXPECT_EQ(reading.unobserved, 0u);
  std::multiset<std::uint32_t> executed(reading.keys.begin(), reading.keys.end());
  EXPECT_EQ(executed, std::multiset<std::uint32_t>(confirmed.begin(), confirmed.end()));
  for (const std::uint32_t each : failed) EXPECT_EQ(executed.count(each), 0u) << each;
  EXPECT_EQ(confirmed.size(), 3u);
  rover.close();
}

TEST_F(DevicesReconnect, WithoutReconnectAVanishedPortEndsTheClient) {
  UnpluggableBoard& uno = board();
  const RoverConfig config = parse_config(std::string(R"({"devices": [{"name": "rover", "codec": "romi", "transport":)") +
                                          R"({"serial": {"port": {"by_id": ")" + kById +
                                          R"("}, "boot_wait_ms": 0, "reconnect": false}}}]})");
  Rover rover = open_rover(config, io.executor());
  auto client = rover.client<romi::Client>("rover");
  EXPECT_EQ(client->call(servos(1100)).code, 0);
  uno.hold(true);
  auto in_flight = client->async_call(servos(1200), boost::asio::use_future);
  ASSERT_TRUE(uno.wait_held(1));
  uno.unplug();
  try {
    in_flight.get();
    ADD_FAILURE() << "the call in flight completed";
  } catch (const boost::system::system_error& error) {
    EXPECT_NE(error.code(), make_error_code(transports::TransportError::disconnected)) << error.what();
  }
  uno.hold(false);
  uno.plug();
  error_code error;
  client->call(servos(1300), error);
  EXPECT_TRUE(error);  // the link stays failed: nothing re-opens it
  EXPECT_EQ(rover.devices().at(0).port->link_counters().disconnects, 0u);
}

}  // namespace
}  // namespace tether::devices
