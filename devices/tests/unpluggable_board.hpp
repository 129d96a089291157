// What the reconnect tests share: a virtual Uno (or a ring of them) behind a pty named by a stable by-id
// symlink in a fake port tree, which a test unplugs (the pty's master closed, the name removed) and plugs
// back under another /dev/pts/N; and a log of the port's link events to wait on. Nothing here sleeps to
// decide anything: waits are for events and bytes, with limits that only bound a hang. Optionally the first
// board resets when the host opens its port, as an Uno's DTR does (`reset_on_open`), with a bootloader.
#pragma once

#include <gtest/gtest.h>

#include <sys/inotify.h>
#include <unistd.h>

#include <boost/asio/buffer.hpp>
#include <boost/asio/posix/stream_descriptor.hpp>

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <span>
#include <stdexcept>
#include <string>
#include <system_error>
#include <thread>
#include <vector>

#include "tether/devices/virtual_boards.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/testing/fake_port_tree.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::devices::testing {

using namespace std::chrono_literals;
inline constexpr auto kHangLimit = 20s;  // only bounds a hang; nothing waits this long when it works
inline constexpr const char* kById = "usb-Tether_Virtual_Uno_4242-if00";

/// One board of an UnpluggableBoard: its image and, optionally, its EEPROM and a bootloader.
struct BoardImage {
  std::filesystem::path firmware;  ///< an .elf path
  std::vector<std::uint8_t> eeprom;
  std::filesystem::path bootloader{};  ///< Intel HEX (optiboot), started by every external reset
};

/// `name.elf` in the build's firmware folder.
inline std::filesystem::path firmware_image(const std::string& name) {
  return std::filesystem::path(TETHER_FIRMWARE_DIR) / (name + ".elf");
}

/// The serial device `codec` behind kById (no boot wait, reconnect on), with `options` (a JSON object or
/// empty), as a rover configuration's text.
inline std::string serial_device_config(const std::string& codec, const std::string& options = "",
                                        const std::string& transport_extra = "") {
  return R"({"devices": [{"name": "dev", "codec": ")" + codec + R"(", "transport": {"serial": {"port": {"by_id": ")" +
         kById + R"("}, "boot_wait_ms": 0)" + transport_extra + "}}" +
         (options.empty() ? std::string() : R"(, "options": )" + options) + "}]}";
}

/// Runs one board (or a ring: host TX -> first board -> ... -> last board -> host RX, in lockstep) and
/// bridges it to whichever pty is "plugged in"; can hold back what the host sends.
class UnpluggableBoard {
 public:
  UnpluggableBoard(transports::IoThread& io, transports::testing::FakePortTree& tree, std::vector<BoardImage> images)
      : io_(io), tree_(tree) {
    if (images.empty()) throw std::invalid_argument("UnpluggableBoard: no board");
    for (const BoardImage& image : images) {
      transports::VirtualUnoOptions options;
      options.firmware = image.firmware;
      options.bootloader = image.bootloader;
      options.pacing = transports::Pacing::real_time;
      options.name = "unpluggable[" + std::to_string(boards_.size()) + "]";
      std::error_code error;
      std::string message;
      auto board = transports::VirtualUno::create(options, error, &message);
      if (!board) throw std::runtime_error("virtual Uno " + image.firmware.string() + ": " + message);
      if (!image.eeprom.empty()) board->write_eeprom(0, image.eeprom);
      boards_.push_back(std::move(board));
    }
    boards_.back()->set_output_handler([this](const std::uint8_t* data, std::size_t size) {
      std::lock_guard lock(mutex_);
      if (pty_) (void)!::write(pty_->object().native_handle(), data, size);  // unplugged: lost, as on a wire
    });
    if (boards_.size() == 1) {
      boards_.front()->start();
    } else {
      group_ = std::make_unique<transports::VirtualUnoGroup>(transports::Pacing::real_time);
      for (const auto& board : boards_) group_->add(*board);
      for (std::size_t i = 0; i + 1 < boards_.size(); ++i) group_->connect(*boards_[i], *boards_[i + 1]);
      group_->start();
    }
    wait_booted();
    plug();
  }
  /// A single board running `firmware`.
  UnpluggableBoard(transports::IoThread& io, transports::testing::FakePortTree& tree, const std::filesystem::path& firmware)
      : UnpluggableBoard(io, tree, std::vector<BoardImage>{BoardImage{firmware, {}}}) {}
  ~UnpluggableBoard() {
    if (group_) {
      group_->stop();
    } else {
      boards_.front()->stop();
    }
    unplug(/*for_good=*/true);
    if (spare_) spare_->close();
    group_.reset();  // the group goes first, then its (stopped) members
  }
  UnpluggableBoard(const UnpluggableBoard&) = delete;
  UnpluggableBoard& operator=(const UnpluggableBoard&) = delete;

  /// Board `i` (0: the one the host writes to).
  transports::VirtualUno& board(std::size_t i = 0) { return *boards_.at(i); }

  /// From now on, every open of the plugged port by the host (the first open and each re-open) resets the
  /// first board (ResetKind::external), as an Uno's DTR does: with a bootloader, it runs first. A pty has no
  /// modem lines, so the open (inotify IN_OPEN on the slave, opened by the harness before) stands for DTR.
  void reset_on_open() {
    std::shared_ptr<transports::PtyStream> pty;
    std::uint64_t generation = 0;
    {
      std::lock_guard lock(mutex_);
      reset_on_open_ = true;
      pty = pty_;
      generation = generation_;
    }
    if (pty) watch_opens(pty->slave_path(), generation);
  }

  /// Resets by `reset_on_open` so far (each counted once the board has reset).
  std::uint64_t open_resets() {
    std::lock_guard lock(mutex_);
    return open_resets_;
  }

  /// A new pty behind the by-id name; returns its slave path.
  std::string plug() {
    auto pty = spare_ ? std::move(spare_) : transports::PtyStream::open(io_.executor());
    std::uint64_t generation = 0;
    {
      std::lock_guard lock(mutex_);
      if (pty_) ADD_FAILURE() << "plugged twice";
      pty_ = pty;
      generation = ++generation_;
    }
    read_loop(pty, generation);
    bool watch = false;
    {
      std::lock_guard lock(mutex_);
      watch = reset_on_open_;
    }
    if (watch) watch_opens(pty->slave_path(), generation);
    tree_.add_by_id(kById, pty->slave_path());
    return pty->slave_path();
  }
  /// Removes the by-id name and closes the pty's master: the host side reads EOF/EIO. The next plug's pty
  /// is opened first, while this one's number is taken, so it comes back under another /dev/pts/N.
  void unplug(bool for_good = false) {
    if (!for_good) spare_ = transports::PtyStream::open(io_.executor());
    std::shared_ptr<transports::PtyStream> pty;
    {
      std::lock_guard lock(mutex_);
      pty = std::move(pty_);
    }
    tree_.remove_by_id(kById);
    if (pty) pty->close();
    std::shared_ptr<boost::asio::posix::stream_descriptor> watcher;
    {
      std::lock_guard lock(mutex_);
      watcher = std::move(watcher_);
    }
    if (watcher) boost::asio::post(watcher->get_executor(), [watcher] { watcher->close(); });
  }
  /// What an unplugged USB-powered Uno goes through: a power cycle of the first board (its RAM, so its
  /// session, gone), and back once its firmware listens again.
  void power_cycle() {
    const std::uint64_t boots = board().stats().boots;
    board().reset(transports::ResetKind::power_cycle, 10ms);
    const auto limit = std::chrono::steady_clock::now() + kHangLimit;
    while (board().stats().boots == boots && std::chrono::steady_clock::now() < limit) std::this_thread::sleep_for(1ms);
    if (board().stats().boots == boots) ADD_FAILURE() << "the board did not reboot";
    wait_booted();
  }
  /// While held, bytes from the host are kept here instead of reaching the board.
  void hold(bool held) {
    std::lock_guard lock(mutex_);
    held_ = held;
    held_bytes_.clear();
  }
  /// Waits until at least `count` held bytes arrived.
  bool wait_held(std::size_t count) {
    std::unique_lock lock(mutex_);
    return changed_.wait_for(lock, kHangLimit, [&] { return held_bytes_.size() >= count; });
  }

 private:
  // Every firmware listens (bytes sent before its UART receiver is on are lost, as on a real board).
  void wait_booted() {
    const auto limit = std::chrono::steady_clock::now() + kHangLimit;
    for (const auto& board : boards_) {
      while (!board->uart().rx_enabled && std::chrono::steady_clock::now() < limit) std::this_thread::sleep_for(1ms);
      if (!board->uart().rx_enabled) ADD_FAILURE() << "a board did not enable its UART receiver";
    }
  }

  // Resets the first board at each IN_OPEN of `slave` while generation `generation` is plugged.
  void watch_opens(const std::string& slave, std::uint64_t generation) {
    const int fd = ::inotify_init1(IN_NONBLOCK | IN_CLOEXEC);
    if (fd < 0 || ::inotify_add_watch(fd, slave.c_str(), IN_OPEN) < 0) {
      if (fd >= 0) ::close(fd);
      ADD_FAILURE() << "inotify on " << slave << " failed";
      return;
    }
    auto watcher = std::make_shared<boost::asio::posix::stream_descriptor>(io_.executor(), fd);
    {
      std::lock_guard lock(mutex_);
      if (watcher_) boost::asio::post(watcher_->get_executor(), [old = watcher_] { old->close(); });
      watcher_ = watcher;
    }
    read_opens(watcher, generation);
  }
  void read_opens(const std::shared_ptr<boost::asio::posix::stream_descriptor>& watcher, std::uint64_t generation) {
    auto buffer = std::make_shared<std::array<char, 1024>>();
    watcher->async_read_some(boost::asio::buffer(*buffer), [this, watcher, generation, buffer](
                                                               boost::system::error_code error, std::size_t size) {
      if (error) return;  // closed (unplugged)
      bool opened = false;
      for (std::size_t at = 0; at + sizeof(inotify_event) <= size;) {
        inotify_event event;
        std::memcpy(&event, buffer->data() + at, sizeof event);
        if ((event.mask & IN_OPEN) != 0) opened = true;
        at += sizeof(inotify_event) + event.len;
      }
      {
        std::lock_guard lock(mutex_);
        if (generation != generation_ || !pty_) return;
      }
      if (opened) {
        // Not under the lock: reset() waits for the board's thread, whose output handler takes the lock.
        boards_.front()->reset(transports::ResetKind::external);
        std::lock_guard lock(mutex_);
        ++open_resets_;  // counted once done
      }
      read_opens(watcher, generation);
    });
  }

  void read_loop(const std::shared_ptr<transports::PtyStream>& pty, std::uint64_t generation) {
    auto buffer = std::make_shared<std::array<std::uint8_t, 256>>();
    // The handler holds the pty weakly: the stream keeps a pending read's handler until it completes, and a
    // read the close aborts completes on the I/O thread, which may be gone by then (the test's end): a strong
    // reference would keep the pty and the handler alive for good (a leak at exit).
    const std::weak_ptr<transports::PtyStream> weak = pty;
    pty->async_read_some(boost::asio::buffer(*buffer), [this, weak, generation, buffer](boost::system::error_code error,
                                                                                         std::size_t size) {
      if (error) return;  // closed (unplugged)
      const std::shared_ptr<transports::PtyStream> plugged = weak.lock();
      if (!plugged) return;
      {
        std::lock_guard lock(mutex_);
        if (generation != generation_ || pty_ != plugged) return;  // unplugged since
        if (held_) {
          held_bytes_.append(reinterpret_cast<const char*>(buffer->data()), size);
          changed_.notify_all();
        } else {
          boards_.front()->write(std::span<const std::uint8_t>(buffer->data(), size));
        }
      }
      read_loop(plugged, generation);
    });
  }

  transports::IoThread& io_;
  transports::testing::FakePortTree& tree_;
  std::vector<std::unique_ptr<transports::VirtualUno>> boards_;
  std::unique_ptr<transports::VirtualUnoGroup> group_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::shared_ptr<transports::PtyStream> pty_;
  std::shared_ptr<transports::PtyStream> spare_;
  std::uint64_t generation_ = 0;
  bool held_ = false;
  std::string held_bytes_;
  bool reset_on_open_ = false;
  std::shared_ptr<boost::asio::posix::stream_descriptor> watcher_;
  std::uint64_t open_resets_ = 0;
};

/// Link events as they come, for waiting on them.
class EventLog {
 public:
  void add(const transports::LinkEvent& event) {
    std::lock_guard lock(mutex_);
    events_.push_back(event);
    changed_.notify_all();
  }
  /// Waits for the `n`th event (1-based) and returns it.
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

/// Waits (bounded by kHangLimit) until `done()` holds; false if it never did.
template <typename Predicate>
bool wait_until(Predicate done) {
  const auto limit = std::chrono::steady_clock::now() + kHangLimit;
  while (!done()) {
    if (std::chrono::steady_clock::now() >= limit) return false;
    std::this_thread::sleep_for(1ms);
  }
  return true;
}

/// A test with an UnpluggableBoard behind kById, in a fake port tree the lookup reads while it runs.
class ReconnectTest : public ::testing::Test {
 protected:
  /// Starts the board(s); null when an image is not built (the caller skips the test).
  UnpluggableBoard* start(std::vector<BoardImage> images) {
    for (const BoardImage& image : images) {
      if (!std::filesystem::exists(image.firmware)) return nullptr;
    }
    enable_virtual_boards();
    board_.emplace(io, tree_, std::move(images));
    return &*board_;
  }
  UnpluggableBoard* start(const std::string& image) { return start({BoardImage{firmware_image(image), {}}}); }

  transports::IoThread io;

 private:
  transports::testing::FakePortTree tree_;
  const transports::testing::UsingFakePortTree use_{tree_};
  std::optional<UnpluggableBoard> board_;
};

}  // namespace tether::devices::testing
