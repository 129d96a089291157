// The Elcano ring on real firmware: elcano-node images on virtual Unos in a lockstep ring, the host's own
// RingNode in the test (ring_harness.hpp). Configurations go into each board's EEPROM before it boots;
// counters come from each board's published NodeStats; servo pulses from the pins. Every run is
// deterministic for its seed; randomised parts print RANDOM_SEED and honour it. Measured figures are
// printed as `[ figures ] ...` lines.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <map>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "../stack_paint.hpp"
#include "ring_harness.hpp"
#include "tether/elcano/node/behaviour.hpp"
#include "tether/elcano/session_policy.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/virtual_uno_stream.hpp"

namespace tether::elcano::interop {
namespace {

using namespace std::chrono_literals;
using transports::FaultConfig;
using transports::SimDuration;
using transports::VirtualUno;
using tether::testing::heap_start;
using tether::testing::paint_free_sram;
using tether::testing::peak_stack;
namespace pins = transports::uno_pins;

constexpr std::size_t kBoard1 = 0, kBoard2 = 1, kBoard3 = 2;

// Simulated-time limit of waits that only run out when something is broken.
constexpr SimDuration kPatience = 2s;

// The high time of the last complete pulse on `pin`, in whole microseconds (rounded).
long pulse_us(VirtualUno& board, int pin) {
  const auto high = board.pulse_timing(pin).high_time;
  return static_cast<long>((high.count() + 500) / 1000);
}

// Sum of one counter over every board.
template <typename Field>
std::uint64_t total(Ring& ring, Field field) {
  std::uint64_t sum = 0;
  for (std::size_t i = 0; i < ring.size(); ++i) sum += field(ring.stats(i));
  return sum;
}

void expect_clean_links(Ring& ring) {
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const node::NodeStats stats = ring.stats(i);
    SCOPED_TRACE("node " + std::to_string(i + 1));
    EXPECT_EQ(stats.link.crc_errors, 0u);
    EXPECT_EQ(stats.link.framing_errors, 0u);
    EXPECT_EQ(stats.link.oversize_frames, 0u);
    EXPECT_EQ(stats.link.partial_timeouts, 0u);
    EXPECT_EQ(stats.ring.queue_full_drops, 0u);
    EXPECT_EQ(stats.answers_refused, 0u);
    EXPECT_EQ(stats.uart_rx_overflows, 0u);
    EXPECT_EQ(stats.uart_framing_errors, 0u);
  }
}

// The last message of `kind` the host saw.
const RingEvent* last_event(const Ring& ring, RingEvent::Kind kind) {
  for (auto it = ring.events().rbegin(); it != ring.events().rend(); ++it) {
    if (it->event.kind == kind) return &it->event;
  }
  return nullptr;
}

void print_board_figures(const char* test, Ring& ring) {
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const node::NodeStats s = ring.stats(i);
    std::printf("[ figures ] %s node %zu: captured %u forwarded %u originated %u undeliverable %u frames_ok %u "
                "crc_errors %u framing_errors %u partial_timeouts %u queue_full %u uart_overflows %u rx_bytes %llu\n",
                test, i + 1, static_cast<unsigned>(s.ring.captured), static_cast<unsigned>(s.ring.forwarded),
                static_cast<unsigned>(s.ring.originated), static_cast<unsigned>(s.ring.undeliverable),
                static_cast<unsigned>(s.link.frames_ok), static_cast<unsigned>(s.link.crc_errors),
                static_cast<unsigned>(s.link.framing_errors), static_cast<unsigned>(s.link.partial_timeouts),
                static_cast<unsigned>(s.ring.queue_full_drops), static_cast<unsigned>(s.uart_rx_overflows),
                static_cast<unsigned long long>(ring.board(i).stats().rx_bytes));
  }
}

// --- configuration ------------------------------------------------------------------------------------------

TEST(ElcanoNodeConfig, EepromBlockIsAdoptedAndAnythingElseFallsBackToTheBuildDefaults) {
  RingOptions options;
  options.boards = reference_ring();
  options.boards[0].loop_period = 7;
  options.boards[0].next_poll_interval = 9;
  options.boards[0].next_receiver_buffer = 48;
  Ring ring(options);
  // Node 2: the block with one bit flipped in storage (its CRC no longer matches). Node 3: erased.
  std::uint8_t block[node::kConfigBlockSize];
  node::encode_config(options.boards[1], block);
  block[8] ^= 0x01;
  ring.board(kBoard2).write_eeprom(node::kConfigAddress, block);
  ring.board(kBoard3).write_eeprom(node::kConfigAddress, std::vector<std::uint8_t>(node::kConfigBlockSize, 0xFF));
  ring.run(10ms);

  const node::NodeStats first = ring.stats(kBoard1);
  EXPECT_EQ(first.layout, node::kStatsLayout);
  EXPECT_EQ(first.config_source, static_cast<std::uint8_t>(node::ConfigSource::eeprom));
  EXPECT_EQ(first.node_number, 1);
  EXPECT_EQ(first.generation, 'B');
  EXPECT_EQ(first.capture_bits, kGoalBit);
  EXPECT_EQ(first.behaviour_bits, node::kAnswerGoalWithSegment);
  EXPECT_EQ(first.loop_period, 7);
  EXPECT_EQ(first.next_poll_interval, 9);
  EXPECT_EQ(first.next_receiver_buffer, 48);
  EXPECT_EQ(first.baud, 115200u);
  EXPECT_EQ(first.reset_cause, transports::atmega328p::PORF);
  EXPECT_EQ(ring.board(kBoard1).uart().baud, 117647u) << "115200 at U2X, as the Arduino core sets it";

  // Build-time defaults (firmware/elcano-node/CMakeLists.txt): generation B, 115200, captures nothing.
  for (const std::size_t index : {kBoard2, kBoard3}) {
    const node::NodeStats fallback = ring.stats(index);
    SCOPED_TRACE("node " + std::to_string(index + 1));
    EXPECT_EQ(fallback.config_source, static_cast<std::uint8_t>(index == kBoard2 ? node::ConfigSource::rejected_block
                                                                                 : node::ConfigSource::defaults));
    EXPECT_EQ(fallback.capture_bits, 0);
    EXPECT_EQ(fallback.behaviour_bits, 0);
    EXPECT_EQ(fallback.generation, 'B');
    EXPECT_EQ(fallback.loop_period, 0);
  }
  // So nodes 2 and 3 pass a drive through, and it comes back to the host that sent it.
  ASSERT_EQ(ring.send(Message::drive(10, 5)), Status::ok);
  ASSERT_TRUE(ring.run_until([&] { return ring.count(RingEvent::Kind::undeliverable) == 1; }, kPatience));
  EXPECT_EQ(ring.stats(kBoard2).ring.forwarded, 1u);
  EXPECT_EQ(ring.stats(kBoard3).ring.forwarded, 1u);
}

// --- the reference ring -------------------------------------------------------------------------------------

TEST(ElcanoReferenceRing, EachMessageReachesItsCapturingNodeAndNothingElseConsumesIt) {
  RingOptions options;
  options.boards = reference_ring();
  Ring ring(options);
  ring.run(10ms);
  // Servos are driven from boot at neutral.
  ring.run(50ms);
  EXPECT_EQ(pulse_us(ring.board(kBoard3), pins::D9), 1500);
  EXPECT_EQ(pulse_us(ring.board(kBoard3), pins::D10), 1500);
  EXPECT_EQ(ring.board(kBoard1).pulse_timing(pins::D9).edges, 0u) << "only node 3 drives servos";

  // A drive from the host: nodes 1 and 2 forward it, node 3 consumes it, sets the servos and reports.
  ASSERT_EQ(ring.send(Message::drive(200, -20)), Status::ok);
  ASSERT_TRUE(ring.run_until([&] { return ring.count(RingEvent::Kind::captured, Type::sensor) == 1; }, kPatience));
  const RingEvent* report = last_event(ring, RingEvent::Kind::captured);
  ASSERT_NE(report, nullptr);
  EXPECT_TRUE(report->message == Message::sensor(200, -20, 0, 0, 0)) << describe(report->message);
  ring.run(60ms);  // the new pulse width shows from the next full 20 ms period
  EXPECT_EQ(pulse_us(ring.board(kBoard3), pins::D9), 1600) << "1500 + 200 / 2";
  EXPECT_EQ(pulse_us(ring.board(kBoard3), pins::D10), 1278) << "1500 + (-20) * 100 / 9";
  node::NodeStats s1 = ring.stats(kBoard1), s2 = ring.stats(kBoard2), s3 = ring.stats(kBoard3);
  EXPECT_EQ(s1.ring.captured, 0u);
  EXPECT_EQ(s1.ring.forwarded, 1u);
  EXPECT_EQ(s2.ring.captured, 0u);
  EXPECT_EQ(s2.ring.forwarded, 1u);
  EXPECT_EQ(s3.ring.captured, 1u);
  EXPECT_EQ(s3.ring.forwarded, 0u);
  EXPECT_EQ(s3.drives_applied, 1u);
  EXPECT_EQ(s3.throttle_us, 1600);
  EXPECT_EQ(s3.steering_us, 1278);
  EXPECT_EQ(s3.ring.originated, 1u);

  // A sensor from the host: node 1 forwards it, node 2 consumes it and answers a drive; node 3 does as
  // before. No segment yet: stop, wheels straight.
  ASSERT_EQ(ring.send(Message::sensor(120, 3, 10, 500, 600)), Status::ok);
  ASSERT_TRUE(ring.run_until([&] { return ring.count(RingEvent::Kind::captured, Type::sensor) == 2; }, kPatience));
  EXPECT_TRUE(last_event(ring, RingEvent::Kind::captured)->message == Message::sensor(0, 0, 0, 0, 0));
  s1 = ring.stats(kBoard1);
  s2 = ring.stats(kBoard2);
  s3 = ring.stats(kBoard3);
  EXPECT_EQ(s1.ring.forwarded, 2u);
  EXPECT_EQ(s1.ring.captured, 0u);
  EXPECT_EQ(s2.ring.captured, 1u);
  EXPECT_EQ(s2.ring.originated, 1u);
  EXPECT_EQ(s2.ring.forwarded, 1u);
  EXPECT_EQ(s3.ring.captured, 2u);

  // A segment from the host: node 2 consumes it; with the heading of 10 it has from the sensor, bearing
  // 60 is a 50 degree error: steering clamped to 45.
  ASSERT_EQ(ring.send(Message::segment(4, 300, 60, 1, 2)), Status::ok);
  ASSERT_TRUE(ring.run_until([&] { return ring.count(RingEvent::Kind::captured, Type::sensor) == 3; }, kPatience));
  EXPECT_TRUE(last_event(ring, RingEvent::Kind::captured)->message == Message::sensor(300, 45, 0, 0, 0));
  ring.run(60ms);
  EXPECT_EQ(pulse_us(ring.board(kBoard3), pins::D9), 1650);
  EXPECT_EQ(pulse_us(ring.board(kBoard3), pins::D10), 2000);

  s1 = ring.stats(kBoard1);
  s2 = ring.stats(kBoard2);
  s3 = ring.stats(kBoard3);
  EXPECT_EQ(s2.ring.originated, 2u);
  EXPECT_EQ(s3.ring.originated, 3u);
  EXPECT_EQ(s1.ring.captured + s2.ring.captured + s3.ring.captured + ring.host_ring().captured,
            3u + s2.ring.originated + s3.ring.originated)
      << "three host messages and five answers, each consumed exactly once";
  EXPECT_EQ(ring.count(RingEvent::Kind::undeliverable), 0u);
  EXPECT_EQ(ring.count(RingEvent::Kind::forwarded), 0u) << "the host only ever received its captures";
  expect_clean_links(ring);
  print_board_figures("reference", ring);
}

TEST(ElcanoReferenceRing, GoalSegmentDriveSensorChainCompletes) {
  RingOptions options;
  options.boards = reference_ring();
  options.seed = tether::testing::random_seed();
  Ring ring(options);
  ring.run(10ms);
  for (std::size_t i = 0; i < ring.size(); ++i) paint_free_sram(ring.board(i));
  auto random = tether::testing::seeded_generator(61);
  std::uniform_int_distribution<std::int32_t> bearings(-720, 720), positions(-100000, 100000);

  constexpr int kChains = 25;
  std::vector<Millis> latencies;
  const std::uint64_t bytes_before = ring.bytes_sent() + ring.bytes_received();
  const Millis started = ring.now();
  node::Behaviour expected_node2(node::kAnswerSegmentWithDrive);
  for (int chain = 0; chain < kChains; ++chain) {
    const Message request = Message::goal(chain, bearings(random), positions(random), positions(random));
    const Message expected_segment = node::Behaviour(node::kAnswerGoalWithSegment).on_captured(request).message;
    const Message expected_drive = expected_node2.on_captured(expected_segment).message;
    const Message expected = node::Behaviour(node::kReportDriveAsSensor).on_captured(expected_drive).message;
    const std::size_t before = ring.count(RingEvent::Kind::captured, Type::sensor);
    const Millis sent = ring.now();
    ASSERT_EQ(ring.send(request), Status::ok);
    ASSERT_TRUE(ring.run_until([&] { return ring.count(RingEvent::Kind::captured, Type::sensor) > before; }, kPatience))
        << "chain " << chain << ": " << describe(request);
    const RingEvent* answer = last_event(ring, RingEvent::Kind::captured);
    EXPECT_TRUE(answer->message == expected)
        << describe(request) << " -> " << describe(answer->message) << ", expected " << describe(expected);
    latencies.push_back(ring.now() - sent);
  }
  const Millis elapsed = ring.now() - started;
  ring.run(60ms);
  const node::NodeStats s3 = ring.stats(kBoard3);
  EXPECT_EQ(pulse_us(ring.board(kBoard3), pins::D9), node::throttle_pulse_us(node::kCruiseSpeed));
  EXPECT_EQ(pulse_us(ring.board(kBoard3), pins::D10), s3.steering_us);
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const node::NodeStats stats = ring.stats(i);
    SCOPED_TRACE("node " + std::to_string(i + 1));
    EXPECT_EQ(stats.ring.captured, static_cast<std::uint32_t>(kChains));
    EXPECT_EQ(stats.ring.originated, static_cast<std::uint32_t>(kChains));
    EXPECT_EQ(stats.ring.forwarded, 0u);
  }
  EXPECT_EQ(s3.drives_applied, static_cast<std::uint32_t>(kChains));
  EXPECT_EQ(ring.host_ring().captured, static_cast<std::uint32_t>(kChains));
  expect_clean_links(ring);
  std::printf("[ figures ] chain: %d chains (4 messages each) in %u ms simulated, %llu bytes on host links, "
              "latency goal->sensor min %u max %u ms\n",
              kChains, static_cast<unsigned>(elapsed),
              static_cast<unsigned long long>(ring.bytes_sent() + ring.bytes_received() - bytes_before),
              static_cast<unsigned>(*std::min_element(latencies.begin(), latencies.end())),
              static_cast<unsigned>(*std::max_element(latencies.begin(), latencies.end())));
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const std::size_t stack = peak_stack(ring.board(i));
    const std::size_t free_ram = transports::atmega328p::kRamEnd + 1u - heap_start(ring.board(i)) - stack;
    std::printf("[ figures ] chain: node %zu peak stack %zu bytes, %zu bytes of RAM never used\n", i + 1, stack, free_ram);
    EXPECT_GT(free_ram, 256u) << "node " << i + 1 << ": the stack came close to the static data";
  }
}

TEST(ElcanoReferenceRing, TypeNobodyCapturesComesBackAndIsReportedUndeliverableOnce) {
  RingOptions options;
  options.boards = reference_ring();
  options.boards[kBoard2].capture_bits = kSegmentBit;  // nobody on the boards takes sensors now
  Ring ring(options);
  ring.run(10ms);
  ASSERT_EQ(ring.stats(kBoard2).capture_bits, kSegmentBit);
  ASSERT_EQ(ring.send(Message::sensor(1, 2, 3, 4, 5)), Status::ok);
  ASSERT_TRUE(ring.run_until([&] { return ring.count(RingEvent::Kind::undeliverable) >= 1; }, kPatience));
  const Millis returned = ring.now();
  ring.run(3s);  // longer than the origin record lives: nothing else comes round
  EXPECT_EQ(ring.count(RingEvent::Kind::undeliverable), 1u);
  EXPECT_EQ(ring.count(RingEvent::Kind::undeliverable, Type::sensor), 1u);
  EXPECT_EQ(ring.count(RingEvent::Kind::captured), 0u) << "the host's own sensor is not taken for a report";
  EXPECT_EQ(ring.host_ring().undeliverable, 1u);
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const node::NodeStats stats = ring.stats(i);
    SCOPED_TRACE("node " + std::to_string(i + 1));
    EXPECT_EQ(stats.ring.forwarded, 1u) << "went round exactly once";
    EXPECT_EQ(stats.ring.captured, 0u);
  }
  std::printf("[ figures ] undeliverable: back at the host after %u ms\n", static_cast<unsigned>(returned));
}

// --- generation D under line noise, with the host's request table --------------------------------------------

TEST(ElcanoReferenceRing, GenerationDUnderLineNoiseDropsCorruptMessagesAndRetriedRequestsComplete) {
  RingOptions options;
  options.boards = reference_ring(Generation::d);
  options.generation = Generation::d;
  options.seed = tether::testing::random_seed();
  Ring ring(options);
  FaultConfig noise;
  // About one chain (4 messages, ~90 bytes) in two is hit; most flips break the syntax, about one in six
  // leaves a well-formed message that only the CRC catches.
  noise.bit_error_rate = 1e-3;
  for (std::size_t i = 0; i < ring.size(); ++i) ring.board(i).set_faults(transports::Direction::to_mcu, noise);
  ring.board(kBoard3).set_faults(transports::Direction::from_mcu, noise);  // the link back to the host
  ring.run(10ms);
  for (std::size_t i = 0; i < ring.size(); ++i) ASSERT_EQ(ring.stats(i).generation, 'D');

  session::CallTiming timing = default_call_timing();
  // A clean chain takes ~15 ms. 32 attempts: a call fails only if all are hit (p ~ 0.5^32).
  timing.attempt_timeout = 100;
  timing.max_attempts = 32;
  timing.call_budget = 4000;
  RequestTable table(timing, 0, ring.host_link());
  bool in_flight = false;
  int completed = 0;
  int resends = 0;
  std::vector<int> attempts;
  ring.on_event = [&](const HostEvent& entry) {
    if (entry.event.kind != RingEvent::Kind::captured || entry.event.message.type != Type::sensor) return;
    const auto reply = table.on_reply(call_id(Type::sensor), 0, entry.at);
    if (reply.verdict != RequestTable::Verdict::completed) return;  // late reply to a call already done
    EXPECT_EQ(reply.completion.outcome, session::CallOutcome::ok);
    attempts.push_back(reply.completion.attempts);
    ++completed;
    in_flight = false;
  };

  constexpr int kCalls = 100;
  auto random = tether::testing::seeded_generator(62);
  std::uniform_int_distribution<std::int32_t> bearings(0, 359);
  const Millis started = ring.now();
  for (int call = 0; call < kCalls; ++call) {
    const Message request = Message::goal(call, bearings(random), 100 * call, -50 * call);
    ASSERT_TRUE(table.begin_with(call_id(Type::sensor), ring.now()).ok());
    ASSERT_EQ(ring.send(request), Status::ok);
    in_flight = true;
    const Millis call_start = ring.now();
    while (in_flight) {
      ring.run(1ms);
      for (;;) {
        const auto step = table.poll(ring.now());
        if (step.action == RequestTable::Action::idle) break;
        if (step.action == RequestTable::Action::resend) {
          ++resends;
          EXPECT_EQ(ring.send(request), Status::ok);
        } else {
          ADD_FAILURE() << "call " << call << " ended " << session::to_string(step.completion.outcome) << " after "
                        << int{step.completion.attempts} << " attempts";
          in_flight = false;
        }
      }
      ASSERT_LT(ring.now() - call_start, 10000u) << "the request table bounds every call";
    }
  }
  const Millis elapsed = ring.now() - started;
  EXPECT_EQ(completed, kCalls);
  const std::uint64_t crc_errors = total(ring, [](const node::NodeStats& s) { return s.link.crc_errors; });
  const std::uint64_t framing = total(ring, [](const node::NodeStats& s) { return s.link.framing_errors; });
  EXPECT_GT(crc_errors, 0u) << "corrupted messages are caught by the generation D CRC";
  EXPECT_GT(resends, 0) << "some chains were lost and the host re-sent the goal";
  EXPECT_EQ(ring.host_link().retries, static_cast<std::uint32_t>(resends));
  std::uint64_t flipped = 0;
  for (std::size_t i = 0; i < ring.size(); ++i) {
    const auto stats = ring.board(i).stats();
    flipped += stats.to_mcu.bytes_corrupted + stats.from_mcu.bytes_corrupted;
  }
  std::printf("[ figures ] noise: BER %.0e, %d calls in %u ms simulated, %d re-sends (max %d attempts), %llu bytes "
              "corrupted on the links, boards dropped %llu for CRC and %llu as malformed, host dropped %u for CRC "
              "and %u as malformed\n",
              noise.bit_error_rate, kCalls, static_cast<unsigned>(elapsed), resends,
              attempts.empty() ? 0 : *std::max_element(attempts.begin(), attempts.end()),
              static_cast<unsigned long long>(flipped), static_cast<unsigned long long>(crc_errors),
              static_cast<unsigned long long>(framing), static_cast<unsigned>(ring.host_link().crc_errors),
              static_cast<unsigned>(ring.host_link().framing_errors));
}

// --- a board reset ------------------------------------------------------------------------------------------

TEST(ElcanoReferenceRing, BoardResetStopsTheChainNoLongerThanItsReboot) {
  RingOptions options;
  options.boards = reference_ring();
  Ring ring(options);
  ring.run(10ms);

  // A goal every 10 ms; its bearing (k mod 90) - 45 comes back as the sensor's angle and names the chain.
  constexpr Millis kInterval = 10;
  struct Chain {
    Millis sent = 0;
    Millis done = 0;
    bool completed = false;
  };
  std::vector<Chain> chains;
  std::map<std::int32_t, std::vector<std::size_t>> open;  // angle -> chains in flight, oldest first
  ring.on_event = [&](const HostEvent& entry) {
    if (entry.event.kind != RingEvent::Kind::captured) return;
    auto& waiting = open[entry.event.message.angle];
    ASSERT_FALSE(waiting.empty()) << "a sensor nobody asked for: " << describe(entry.event.message);
    chains[waiting.front()].completed = true;
    chains[waiting.front()].done = entry.at;
    waiting.erase(waiting.begin());
  };
  auto send_next = [&] {
    const std::size_t k = chains.size();
    const std::int32_t bearing = static_cast<std::int32_t>(k % 90) - 45;
    chains.push_back(Chain{ring.now(), 0, false});
    open[bearing].clear();  // a chain lost to a reset never completes: forget it when its angle comes round
    open[bearing].push_back(k);
    ASSERT_EQ(ring.send(Message::goal(static_cast<std::int32_t>(k), bearing, 0, 0)), Status::ok);
  };
  auto run_with_goals = [&](Millis duration) {
    const Millis end = ring.now() + duration;
    while (ring.now() < end) {
      send_next();
      ring.run(std::chrono::milliseconds(kInterval));
    }
  };

  run_with_goals(300);
  Millis steady_latency = 0;
  for (const Chain& chain : chains) {
    if (chain.sent + 50 > ring.now()) break;  // still on its way
    ASSERT_TRUE(chain.completed) << "before any reset every chain completes";
    steady_latency = std::max(steady_latency, chain.done - chain.sent);
  }

  // Reset node 2 at several points of a chain's life (its goal on the way in, its drive on the way out...),
  // each after the ring has settled again, and measure the reboot: until its UART receives again.
  Millis worst_outage = 0;
  std::int64_t worst_reboot_us = 0;
  std::size_t lost_total = 0;
  for (const Millis offset : {0u, 2u, 4u, 5u, 6u, 7u, 9u}) {
    SCOPED_TRACE("reset " + std::to_string(offset) + " ms after a goal");
    send_next();
    ring.run(std::chrono::milliseconds(offset));
    const std::size_t first_after = chains.size();  // goals sent from now on
    const SimDuration reset_at = ring.board(kBoard2).simulated_time();
    ring.board(kBoard2).reset(transports::ResetKind::external);
    ASSERT_TRUE(ring.run_until([&] { return !ring.board(kBoard2).uart().rx_enabled; }, 1ms, 10us));
    ASSERT_TRUE(ring.run_until([&] { return ring.board(kBoard2).uart().rx_enabled; }, 100ms, 10us));
    const auto reboot =
        std::chrono::duration_cast<std::chrono::microseconds>(ring.board(kBoard2).simulated_time() - reset_at);
    const auto reset_ms = static_cast<Millis>(std::chrono::duration_cast<std::chrono::milliseconds>(reset_at).count());
    ring.run(std::chrono::milliseconds(kInterval) - (ring.board(kBoard2).simulated_time() - reset_at) -
             std::chrono::milliseconds(offset));
    run_with_goals(200);
    ring.run(50ms);
    EXPECT_EQ(ring.stats(kBoard2).reset_cause & transports::atmega328p::EXTRF, transports::atmega328p::EXTRF);

    std::size_t lost = 0;
    Millis recovered_at = 0;
    for (std::size_t k = first_after; k < chains.size(); ++k) {
      if (!chains[k].completed) {
        ++lost;
        continue;
      }
      if (recovered_at == 0) recovered_at = chains[k].done;
    }
    ASSERT_NE(recovered_at, 0u) << "the ring works again after the reset";
    const Millis outage = recovered_at - reset_ms;
    // The first goal sent after node 2 is back (at most one interval later) completes in a steady chain's time.
    const auto bound = static_cast<Millis>((reboot.count() + 999) / 1000) + kInterval + steady_latency + 1;
    EXPECT_LE(outage, bound) << "reboot " << reboot.count() << " us, steady latency " << steady_latency << " ms";
    EXPECT_EQ(lost, 0u) << "every goal sent after the reset completes";
    std::printf("[ figures ] reset %u ms after a goal: node 2 rebooted in %lld us; chain stopped %u ms (bound %u = "
                "reboot + %u ms goal interval + %u ms steady latency + 1); %zu of %zu later chains lost\n",
                static_cast<unsigned>(offset), static_cast<long long>(reboot.count()), static_cast<unsigned>(outage),
                static_cast<unsigned>(bound), static_cast<unsigned>(kInterval), static_cast<unsigned>(steady_latency),
                lost, chains.size() - first_after);
    worst_outage = std::max(worst_outage, outage);
    worst_reboot_us = std::max<std::int64_t>(worst_reboot_us, reboot.count());
    lost_total += lost;
  }
  print_board_figures("reset", ring);
  std::printf("[ figures ] reset: worst reboot %lld us, worst outage %u ms, %zu chains lost after resets\n",
              static_cast<long long>(worst_reboot_us), static_cast<unsigned>(worst_outage), lost_total);
}

// --- flow control -------------------------------------------------------------------------------------------

struct FlowResult {
  std::uint32_t sent = 0;
  std::uint32_t delivered = 0;
  std::uint32_t overflows = 0;
  std::uint8_t rx_peak = 0;
  std::uint64_t bytes = 0;
  Millis elapsed = 0;
};

// Ring host -> node 1 -> node 2 -> node 3 where node 3 captures segments. The slow node (`slow`, loop period
// 20 ms) is fed either by the host (slow = 0) or by node 1 (slow = 1); `paced` says whether its feeder's
// pacing describes it (64-byte buffer read every 20 ms) or a node that keeps up.
FlowResult run_stream(std::size_t slow, bool paced) {
  constexpr std::uint16_t kSlowPeriod = 20;
  constexpr std::uint32_t kMessages = 60;
  RingOptions options;
  options.boards = {node_config(1, 0, 0), node_config(2, 0, 0), node_config(3, kSegmentBit, 0)};
  options.boards[slow].loop_period = kSlowPeriod;
  const std::uint16_t feeder_poll = paced ? kSlowPeriod : 0;
  if (slow == 0) {
    options.host_pacing.receiver_poll_interval = feeder_poll;
  } else {
    options.boards[slow - 1].next_poll_interval = feeder_poll;
  }
  Ring ring(options);
  ring.run(10ms);
  FlowResult result;
  const Millis started = ring.now();
  auto message = [&result] { return Message::segment(static_cast<std::int32_t>(result.sent), 150, 30, 100, 200); };
  if (slow == 0) {
    // The host streams as fast as its pacing lets it: originate whenever its queue has room.
    while (result.sent < kMessages && ring.now() - started < 10000) {
      while (result.sent < kMessages && ring.send(message()) == Status::ok) ++result.sent;
      ring.run(1ms);
    }
  } else {
    // Bursts of 4 messages every 100 ms at line rate into node 1: on average well within what the slow node
    // reads, but a burst is ~110 bytes, more than its 64-byte ring holds.
    while (result.sent < kMessages) {
      for (int i = 0; i < 4 && result.sent < kMessages; ++i) {
        EXPECT_EQ(ring.send(message()), Status::ok);
        ++result.sent;
      }
      ring.run(100ms);
    }
  }
  ring.run_until([&] { return ring.stats(2).ring.captured >= kMessages; }, 3s, 10ms);
  ring.run(500ms);  // whatever is still on its way
  result.elapsed = ring.now() - started;
  result.delivered = ring.stats(2).ring.captured;
  result.overflows = ring.stats(slow).uart_rx_overflows;
  result.rx_peak = ring.stats(slow).rx_peak;
  result.bytes = ring.bytes_sent();
  const std::string name = std::string(slow == 0 ? "host" : "node 1") + (paced ? " paced" : " unpaced");
  print_board_figures(name.c_str(), ring);
  std::printf("[ figures ] flow (%s for node %zu reading every %u ms): %u messages sent (%llu bytes), %u delivered, "
              "%u UART overflows on the slow node (RX ring peak %u of 64), %u ms simulated\n",
              name.c_str(), slow + 1, kSlowPeriod, result.sent, static_cast<unsigned long long>(result.bytes),
              result.delivered, result.overflows, unsigned{result.rx_peak}, static_cast<unsigned>(result.elapsed));
  if (paced) expect_clean_links(ring);
  return result;
}

TEST(ElcanoFlowControl, HostPacedForASlowFirstNodeLosesNothing) {
  const FlowResult paced = run_stream(0, true);
  EXPECT_EQ(paced.overflows, 0u);
  EXPECT_EQ(paced.delivered, paced.sent);
  const FlowResult unpaced = run_stream(0, false);
  EXPECT_GT(unpaced.overflows, 0u) << "the same stream at line rate overruns the slow node's ring";
  EXPECT_LT(unpaced.delivered, unpaced.sent);
}

TEST(ElcanoFlowControl, NodePacedForASlowNextNodeLosesNothing) {
  const FlowResult paced = run_stream(1, true);
  EXPECT_EQ(paced.overflows, 0u);
  EXPECT_EQ(paced.delivered, paced.sent);
  const FlowResult unpaced = run_stream(1, false);
  EXPECT_GT(unpaced.overflows, 0u) << "node 1 forwarding each burst at line rate overruns node 2's ring";
  EXPECT_LT(unpaced.delivered, unpaced.sent);
}

// --- the ring as one host byte stream -----------------------------------------------------------------------

TEST(ElcanoRingStream, HostStreamWritesToTheFirstBoardAndReadsTheLast) {
  // Two nodes with erased EEPROM forward everything (build-time defaults). The group runs on its own thread.
  transports::VirtualUnoOptions board_options;
  board_options.firmware = node_image();
  board_options.pacing = transports::Pacing::fast;
  VirtualUno first(board_options);
  VirtualUno last(board_options);
  transports::VirtualUnoGroup group(transports::Pacing::fast);
  group.add(first);
  group.add(last);
  group.connect(first, last);
  transports::IoThread io;
  auto stream = transports::VirtualUnoStream::attach_ring(io.executor(), first, last);
  EXPECT_EQ(&stream->board(), &first);
  EXPECT_EQ(&stream->reading_board(), &last);
  EXPECT_NE(stream->description().find("ring"), std::string::npos) << stream->description();
  group.start();
  const auto deadline = std::chrono::steady_clock::now() + 30s;
  while (!(first.uart().rx_enabled && last.uart().rx_enabled) && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(1ms);
  }
  ASSERT_TRUE(first.uart().rx_enabled && last.uart().rx_enabled) << "nodes did not boot";
  const std::string request = "D{s 50}{a 25}\nS{s 69}{a -12}{b 432}{p 420,90210}\n";
  // The messages, forwarded without spaces; nothing else (no banner).
  const std::string expected = "D{s50}{a25}\nS{s69}{a-12}{b432}{p420,90210}\n";
  stream->write(transports::asio::buffer(request));
  std::string received;
  char buffer[128];
  while (received.size() < expected.size()) {
    received.append(buffer, stream->read_some(transports::asio::buffer(buffer), 30s));
  }
  EXPECT_EQ(received, expected);
  EXPECT_EQ(first.available(), 0u) << "a wired board delivers nothing to the host";
  stream->close();
  group.stop();
}

}  // namespace
}  // namespace tether::elcano::interop
