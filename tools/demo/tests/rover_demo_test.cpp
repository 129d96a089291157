// The demo end to end on the embedded virtual rover (shortened): the table reports what the run did.
#include "tether/demo/rover_demo.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <variant>
#include <vector>

#include "tether/devices/config.hpp"
#include "tether/devices/virtual_boards.hpp"

#include "tether/proxy/plugin.hpp"
#include "tether/testing/random_seed.hpp"

namespace tether::demo {
namespace {

// Every rover here has virtual devices: enabled once, before the first test.
class EnableVirtualBoards : public ::testing::Environment {
 public:
  void SetUp() override { devices::enable_virtual_boards(); }
};
[[maybe_unused]] ::testing::Environment* const virtual_boards_enabled =
    ::testing::AddGlobalTestEnvironment(new EnableVirtualBoards);


DemoOptions short_run() {
  DemoOptions options;
  options.firmware_dir = TETHER_FIRMWARE_DIR;
  options.iterations = 40;
  options.seed = testing::random_seed();
  return options;
}

// The exactly-once figures of a device add up: every execution the witness logged belongs to a command
// (confirmed or not), and protocols with a duplicate filter (romi's reply cache, proxy's messageId filter)
// never run a command twice, even re-sent through noise and a reset.
void expect_exactly_once_adds_up(const DeviceReport& d) {
  ASSERT_TRUE(d.exactly_once.has_value()) << "the demo images carry the execution witness";
  const ExactlyOnce& e = *d.exactly_once;
  std::printf("%s: commands %llu confirmed %llu executed %llu twice %llu failed-but-executed %llu "
              "confirmed-not-executed %llu unsent %llu unobserved %llu\n",
              d.device.c_str(), static_cast<unsigned long long>(e.commands),
              static_cast<unsigned long long>(e.confirmed), static_cast<unsigned long long>(e.executed),
              static_cast<unsigned long long>(e.executed_twice), static_cast<unsigned long long>(e.executed_but_failed),
              static_cast<unsigned long long>(e.confirmed_not_executed),
              static_cast<unsigned long long>(e.executed_unsent), static_cast<unsigned long long>(e.unobserved));
  EXPECT_GE(e.commands, d.operations);
  EXPECT_LE(e.confirmed, e.commands);
  EXPECT_LE(e.executed, e.commands);
  EXPECT_LE(e.executed_twice, e.executed);
  // confirmed and executed + confirmed, not executed == confirmed; + executed, reported failed == executed.
  EXPECT_EQ(e.confirmed - e.confirmed_not_executed, e.executed - e.executed_but_failed);
  EXPECT_EQ(e.unobserved, 0u) << "the demo reads the log after every operation";
  if (d.confirmed) {
    // A confirmation is sent after the command ran.
    EXPECT_EQ(e.confirmed_not_executed, 0u);
    EXPECT_GT(e.executed, 0u);
  }
  if (d.codec == "romi" || d.codec == "proxy" || d.codec == "rpc") {
    EXPECT_EQ(e.executed_twice, 0u);
  }
}

TEST(RoverDemo, EveryCodecRunsTheWorkloadThroughNoiseAndAReset) {
  const DemoReport report = run_demo(short_run());
  std::printf("%s", format_table(report).c_str());
  ASSERT_EQ(report.devices.size(), 6u);
  for (const DeviceReport& d : report.devices) {
    SCOPED_TRACE(d.device);
    EXPECT_EQ(d.operations, 40u);
    EXPECT_EQ(d.successes + d.failures + d.wrong, d.operations);
    EXPECT_GT(d.successes, 0u);
    EXPECT_GT(d.bytes_to_device, 0u);
    EXPECT_EQ(d.resets_injected, 1u);
    if (d.confirmed) {
      ASSERT_TRUE(d.recovery_ms.has_value()) << "no success after the reset: " << d.first_error;
    } else {
      EXPECT_FALSE(d.recovery_ms.has_value()) << "unconfirmed writes cannot show a recovery";
    }
    ASSERT_TRUE(d.pins_match.has_value());
    EXPECT_TRUE(*d.pins_match) << d.pins_detail;
    EXPECT_GT(d.latency_p99_ms, 0.0);
    EXPECT_GE(d.latency_p99_ms, d.latency_p50_ms);
    expect_exactly_once_adds_up(d);
  }
  // The protocol that has sessions sees the reset.
  EXPECT_EQ(report.devices[1].codec, "proxy");
  ASSERT_TRUE(report.devices[1].resets_detected.has_value());
  EXPECT_EQ(*report.devices[1].resets_detected, 1u);
}

TEST(RoverDemo, WithoutFaultsEveryOperationSucceedsAndTheJsonCarriesTheFigures) {
  DemoOptions options = short_run();
  options.iterations = 20;
  options.bit_error_rate = 0;
  options.reset_halfway = false;
  const DemoReport report = run_demo(options);
  const nlohmann::json json = to_json(report);
  ASSERT_EQ(json["devices"].size(), 6u);
  for (const auto& d : json["devices"]) {
    SCOPED_TRACE(d["device"].get<std::string>());
    EXPECT_EQ(d["successes"], 20);
    // No assertion on "retries": the boards run in real time, so on a loaded machine a simulator can fall
    // behind the host's attempt window and an answer that is merely late is asked for again (seen in CI).
    EXPECT_TRUE(d["retries"].is_number_unsigned());
    EXPECT_EQ(d["bits_flipped"], 0);
    EXPECT_TRUE(d["recovery_ms"].is_null());
    EXPECT_GT(d["bytes_to_device"].get<std::uint64_t>(), 0u);
    // Clean links: every command confirmed ran, nothing ran that was not sent, and (romi and proxy filter
    // re-sends) nothing ran twice. (How many are confirmed depends on the machine's load, as above.)
    const auto& e = d["exactly_once"];
    ASSERT_TRUE(e.is_object());
    EXPECT_GE(e["confirmed"].get<std::uint64_t>(), d["successes"].get<std::uint64_t>());
    EXPECT_GE(e["executed"].get<std::uint64_t>(), e["confirmed"].get<std::uint64_t>());
    EXPECT_EQ(e["confirmed_not_executed"], 0);
    EXPECT_EQ(e["executed_unsent"], 0);
    if (d["codec"] != "elcano") {
      EXPECT_EQ(e["executed_twice"], 0);
    }
  }
}

// The embedded virtual rover with only its device `name` (none when it has no such device).
devices::RoverConfig embedded_rover_with_only(const DemoOptions& options, const std::string& name) {
  devices::ParseOptions parse;
  parse.firmware_dir = options.firmware_dir;
  devices::RoverConfig config = devices::parse_config(devices::default_virtual_rover_config(), parse);
  std::erase_if(config.devices, [&](const devices::DeviceConfig& device) { return device.name != name; });
  return config;
}

// The compat device has no acks: a rebooted device whose RESET announcement the host misses keeps no init,
// and every command after is refused. The demo writes the inits and last positions again after the run
// until the device's state stream shows them, so the pins end at a known command whatever was lost.
// Deterministic version of the CI flake ("D9 1250/1933 us"): the replay on RESET is switched off, so the
// rebooted device never gets its init from the client.
TEST(RoverDemo, TheCompatDeviceEndsAtTheLastCommandEvenWhenItsInitsWereLostInTheReboot) {
  DemoOptions options = short_run();
  options.iterations = 20;
  options.bit_error_rate = 0;
  devices::RoverConfig config = embedded_rover_with_only(options, "legacy");
  ASSERT_EQ(config.devices.size(), 1u);
  config.devices[0].options.get<proxy::DeviceOptions>().client.compat_replay_on_reset = false;
  options.config = config;
  const DemoReport report = run_demo(options);
  ASSERT_EQ(report.devices.size(), 1u);
  const DeviceReport& d = report.devices[0];
  EXPECT_EQ(d.resets_injected, 1u);
  EXPECT_GE(d.final_rewrites, 1u);
  ASSERT_TRUE(d.pins_match.has_value());
  EXPECT_TRUE(*d.pins_match) << d.pins_detail;
}


// (1-hour soak: 209 ServoControls confirmed to the caller that the device never ran, ~3.5 per power
// cycle). The proxy device alone, power-cycled every 8 operations: through repeated reboots nothing is
// confirmed that did not run. (The race behind the soak's figure -- a re-send reaching the rebooted device
// before the host saw its ResetEvent -- is rare at this scale; ProxyDeviceTest and ProxyClient pin it.)
TEST(RoverDemo, TheProxyDeviceConfirmsOnlyWhatItRanAcrossRepeatedPowerCycles) {
  DemoOptions options = short_run();
  options.iterations = 64;
  options.reset_every = 8;
  options.config = embedded_rover_with_only(options, "servos");
  ASSERT_EQ(options.config->devices.size(), 1u);
  const DemoReport report = run_demo(options);
  std::printf("%s", format_table(report).c_str());
  ASSERT_EQ(report.devices.size(), 1u);
  const DeviceReport& d = report.devices[0];
  EXPECT_EQ(d.resets_injected, 7u);
  expect_exactly_once_adds_up(d);
}

}  // namespace
}  // namespace tether::demo
