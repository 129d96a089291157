/// @file scripted_peer.hpp
/// The device side of a client test: a peer serving one end of a `ByteStream` (in-memory pair, pty
/// master, ...) that records what the client sent and writes scripted answers, byte for byte. The codec
/// fake devices (`romi::testing::FakeDevice`, `proxy::testing::FakeDevice`) derive from it and add only
/// their codec: how received bytes become records (requests, frames), and how answers are built.
/// `ScriptedDevice` adds what every fake device keeps: the records in arrival order, a script run for
/// each, and waiting for records.
///
/// Threading: the peer runs on a strand of the stream's executor; `on_bytes` runs there. Every public
/// function may be called from any thread. Record what tests inspect with `record` (under the peer's
/// lock, waking `wait_until`).
///
/// Lifetime: create with `std::make_shared`, then `start()`. The read loop holds the peer weakly; sends
/// and delayed sends hold it until they ran. Dropping the peer (or `close()`) closes its end.
#pragma once

#include <boost/asio/any_io_executor.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>

#include <array>
#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "tether/transports/byte_stream.hpp"

namespace tether::transports::testing {

/// A stream-serving test peer; see the file overview.
class ScriptedPeer : public std::enable_shared_from_this<ScriptedPeer> {
 public:
  ScriptedPeer(const ScriptedPeer&) = delete;
  ScriptedPeer& operator=(const ScriptedPeer&) = delete;
  /// Closes the stream.
  virtual ~ScriptedPeer();

  /// Writes `bytes` now (in order with every other send).
  void send(std::string bytes);
  /// Writes `bytes` after `delay` (in order with the sends made then).
  void send_after(std::chrono::milliseconds delay, std::string bytes);
  /// Closes the stream and cancels delayed sends.
  void close();
  /// Every byte received so far.
  std::string received() const;

 protected:
  /// Peer serving `end` (not null); reading starts with `start()`.
  explicit ScriptedPeer(std::shared_ptr<ByteStream> end);

  /// Starts the read loop (after construction: it needs shared_from_this). Any thread, once.
  void start();

  /// Bytes read from the stream (already appended to `received()`). Contract:
  ///   1. Runs on the peer's strand, in arrival order, with a view valid only during the call.
  ///   2. May call `send`, `send_after`, `close` and `record`; must not wait for the client.
  ///   3. Must not throw.
  virtual void on_bytes(const std::uint8_t* data, std::size_t size) = 0;

  /// Runs `update` under the peer's lock, then wakes `wait_until`. Any thread.
  void record(const std::function<void()>& update) const;
  /// Runs `read` under the peer's lock (snapshots of what `record` wrote). Any thread.
  void inspect(const std::function<void()>& read) const;
  /// Waits until `ready()` (evaluated under the peer's lock) holds; false after `timeout`. Any thread.
  bool wait_until(const std::function<bool()>& ready, std::chrono::milliseconds timeout) const;

 private:
  void read();
  void write_next();

  std::shared_ptr<ByteStream> end_;
  boost::asio::strand<boost::asio::any_io_executor> strand_;
  std::shared_ptr<std::array<std::uint8_t, 512>> buffer_;

  // Strand only.
  std::deque<std::shared_ptr<std::string>> writes_;
  bool writing_ = false;
  std::vector<std::shared_ptr<boost::asio::steady_timer>> timers_;

  // Any thread.
  mutable std::mutex mutex_;
  mutable std::condition_variable changed_;
  std::string received_;
};

/// A `ScriptedPeer` that turns bytes into `Record`s (what a device received: a request, a frame) and runs
/// a script for each. `Device` is the derived class (the script's second argument).
template <typename Device, typename Record>
class ScriptedDevice : public ScriptedPeer {
 public:
  /// Called for every record. Contract:
  ///   1. Runs on the peer's strand, in arrival order, after the record is visible to `records()`.
  ///   2. May answer with `device.send` / `send_after`; must not wait for the client.
  ///   3. Must not throw.
  using Script = std::function<void(const Record& record, Device& device)>;

  /// Sets the script (any thread, before the records it should see; empty: records only).
  void set_script(Script script) {
    record([&] { script_ = std::move(script); });
  }
  /// Every record so far (snapshot). Any thread.
  std::vector<Record> records() const {
    std::vector<Record> snapshot;
    inspect([&] { snapshot = records_; });
    return snapshot;
  }
  /// Waits until `ready(records)` holds; false after `timeout`. Any thread.
  bool wait_for_records(const std::function<bool(const std::vector<Record>&)>& ready,
                        std::chrono::milliseconds timeout) const {
    return wait_until([&] { return ready(records_); }, timeout);
  }

 protected:
  using ScriptedPeer::ScriptedPeer;

  /// Appends `entry` to the records (waking waiters), then runs the script on it. Strand.
  void deliver(const Record& entry) {
    Script script;
    record([&] {
      records_.push_back(entry);
      script = script_;
    });
    if (script) script(entry, static_cast<Device&>(*this));
  }

 private:
  // Under the peer's lock.
  Script script_;
  std::vector<Record> records_;
};

}  // namespace tether::transports::testing
