// The rest of the ring for RingClient tests: a scripted peer that reads what the host writes to the first
// board (decoded with the codec's reader) and writes what the last board would send to the host, byte for
// byte. Plus the shared pieces of the tests: short timing, message helpers, event and completion recorders.
#pragma once

#include <boost/asio/any_io_executor.hpp>

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tether/elcano/client.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/in_memory_stream.hpp"
#include "tether/testing/eventually.hpp"
#include "tether/client/link_clock.hpp"
#include "tether/client/testing/event_log.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "tether/transports/testing/scripted_peer.hpp"

namespace tether::elcano::testing {

using namespace std::chrono_literals;

/// Generous bound for "happens promptly" (no assertion on elapsed time is tighter than this).
inline constexpr auto kPrompt = std::chrono::milliseconds(3000);

/// One message (or read error) the ring received from the host.
struct RingRecord {
  std::string wire;                      ///< the bytes since the previous record (the message's bytes)
  bool ok = false;                       ///< a complete, valid message
  Message message;                       ///< when ok
  Error error = Error::success;  ///< when not ok
  std::chrono::steady_clock::time_point at;  ///< arrival
};

/// A chunk of bytes as the ring's end of the stream read it.
struct Arrival {
  Millis at = 0;          ///< when the read completed, on the ring's clock (`use_clock`)
  std::size_t bytes = 0;  ///< how many bytes it brought
};

/// Scripted rest-of-the-ring; create with `start`, always `close` (or drop) it. `send`, `send_after`,
/// `close` and `received` come from `transports::testing::ScriptedPeer`.
class FakeRing : public transports::testing::ScriptedDevice<FakeRing, RingRecord> {
 public:
  /// Called on the ring's strand for every record.
  using Script = ScriptedDevice::Script;

  /// Ring reading `generation` from `end` at once.
  static std::shared_ptr<FakeRing> start(std::shared_ptr<transports::ByteStream> end, Generation generation,
                                         Script script = {});
  FakeRing(std::shared_ptr<transports::ByteStream> end, Generation generation, int);  // for make_shared

  /// Sets the script (any thread, before the records it should see).
  void on_message(Script script) { set_script(std::move(script)); }
  /// Every record so far (snapshot).
  std::vector<RingRecord> messages() const { return records(); }
  /// Waits until at least `count` records arrived; false after `timeout`.
  bool wait_for_messages(std::size_t count, std::chrono::milliseconds timeout = kPrompt) const {
    return wait_for_records([count](const std::vector<RingRecord>& records) { return records.size() >= count; },
                            timeout);
  }
  /// Every read of the ring's end so far, in order.
  std::vector<Arrival> arrivals() const;
  /// Stamps arrivals with `clock` (the client's manual clock; before the first byte arrives).
  void use_clock(std::shared_ptr<client::LinkClock> clock) {
    record([&] { clock_ = std::move(clock); });
  }

 private:
  void on_bytes(const std::uint8_t* data, std::size_t size) override;

  // Strand only.
  LinkCounters counters_;
  Decoder<kMaxMessageBytes> reader_;
  std::string wire_;

  // Under the peer's lock.
  std::vector<Arrival> arrivals_;
  std::shared_ptr<client::LinkClock> clock_ = client::steady_link_clock();
};

/// The bytes of `message` in `generation` (what the host writes when it originates it).
std::string wire(const Message& message, Generation generation = Generation::b);

/// The tests' sensor report with speed `speed`: S{s speed}{a -12}{b 432}{p 420,90210}.
Message sensor(std::int32_t speed);
/// The tests' goal number `number`: G{n number}{b 90}{p 100,200}.
Message goal(std::int32_t number);
/// The tests' segment number `number`: X{n number}{s 160}{b 80}{p 3200,-64000}.
Message segment(std::int32_t number);

/// Options for tests: fast pacing (115200 baud, a 64-byte receiver that keeps up), the engine's shape
/// scaled down (attempt `attempt_ms`, budget `budget_ms`, 3 sends), on `clock` (null: the steady clock).
Options test_options(Duration attempt_ms = 200, Duration budget_ms = 1000,
                     std::shared_ptr<client::LinkClock> clock = nullptr);

/// `options` on the steady clock, for tests whose pacing must see time pass (on `Link`'s manual clock the
/// pacer holds the second message back until the test advances it). Their attempt windows and budgets
/// are far beyond `kPrompt` when they make requests, so load cannot make one pass.
Options on_steady_clock(Options options);

/// Pacing of 1 byte per second (a 2-byte receiver at 10 baud): nothing but the first byte leaves within a
/// test, so the node's output queue stays as the test filled it.
session::LinkPacing trickle();

/// Records every event; tests wait for the ones they expect.
using EventLog = client::testing::EventLog<Event>;
using ::tether::testing::eventually;
using client::testing::ManualClock;

/// The outcome of an asynchronous operation.
struct Outcome {
  error_code error;          ///< its error_code
  std::optional<Message> message;  ///< requests and receives
};

/// Collects completions (any thread). Handlers share its state, so a completion arriving after the
/// collector is gone is harmless.
class Completions {
 public:
  /// A send completion handler recording into slot `index`.
  std::function<void(error_code)> send_handler(std::size_t index);
  /// A request / receive completion handler recording into slot `index`.
  std::function<void(error_code, Message)> message_handler(std::size_t index);
  /// Waits until `count` completions arrived.
  bool wait_for(std::size_t count, std::chrono::milliseconds timeout = kPrompt) const;
  /// Completions so far.
  std::size_t calls() const;
  /// The outcome of operation `index` (empty while it has not completed).
  std::optional<Outcome> at(std::size_t index) const;

 private:
  void store(std::size_t index, Outcome outcome);
  struct State {
    mutable std::mutex mutex;
    std::condition_variable changed;
    std::vector<std::optional<Outcome>> outcomes;
    std::size_t calls = 0;
  };
  std::shared_ptr<State> state_ = std::make_shared<State>();
};

/// A client and the rest of the ring on the two ends of an in-memory pair.
struct Link {
  /// The client runs on `clock`, a manual clock, unless `options` name another: no attempt window, budget or
  /// timeout passes behind a test's back, so a loaded machine cannot re-send or time out an operation; tests
  /// about deadlines (and pacing beyond the bucket) advance `clock`. Each direction of the in-memory pair
  /// holds `stream_capacity` bytes: 1 makes the client read the ring's bytes one at a time.
  Link(boost::asio::any_io_executor executor, Options options, FakeRing::Script script = {},
       std::size_t stream_capacity = 4096);
  ~Link();
  Link(const Link&) = delete;
  Link& operator=(const Link&) = delete;

  std::shared_ptr<ManualClock> clock;
  EventLog log;
  std::shared_ptr<FakeRing> ring;
  std::optional<RingClient> client;
};

}  // namespace tether::elcano::testing
