// `tether --help`, every subcommand's --help, and usage errors (exit status 2 and a message naming the
// problem), device options included. Nothing here needs a device.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <sys/stat.h>

#include "tether/testing/child_process.hpp"
#include "tether_process.hpp"

#ifndef TETHER_SOURCE_DIR
#error "TETHER_SOURCE_DIR must name the source tree"
#endif
#ifndef TETHER_VERSION
#error "TETHER_VERSION must be the project's version (top-level CMakeLists.txt)"
#endif

namespace tether::cli::testing {
namespace {

void expect_usage_error(const std::vector<std::string>& arguments, const std::string& message) {
  SCOPED_TRACE(::testing::PrintToString(arguments));
  const Outcome run = run_tether(arguments);
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.out, "");
  EXPECT_NE(run.err.find(message), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("usage: tether " + arguments[0]), std::string::npos) << run.err;
}

TEST(TetherUsage, HelpListsEverySubcommand) {
  const Outcome run = run_tether({"--help"});
  EXPECT_EQ(run.status, 0);
  for (const char* name : {"sim", "call", "send", "shell", "monitor", "stats"}) {
    EXPECT_NE(run.out.find(std::string("\n  ") + name + " "), std::string::npos) << name << "\n" << run.out;
  }
}

TEST(TetherUsage, VersionIsTheProjects) {
  const Outcome run = run_tether({"--version"});
  EXPECT_EQ(run.status, 0);
  EXPECT_EQ(run.out, std::string("tether ") + TETHER_VERSION + "\n");
  EXPECT_EQ(run.err, "");
  EXPECT_NE(run_tether({"--help"}).out.find("tether --version"), std::string::npos);
}

TEST(TetherUsage, EverySubcommandHasHelpWithTheDeviceOptionsAndJson) {
  for (const char* name : {"call", "send", "shell", "monitor", "stats"}) {
    SCOPED_TRACE(name);
    const Outcome run = run_tether({name, "--help"});
    EXPECT_EQ(run.status, 0);
    EXPECT_EQ(run.out.rfind(std::string("usage: tether ") + name, 0), 0u) << run.out;
    for (const char* option : {"--port PATH", "--config FILE --device NAME", "--virtual FIRMWARE", "--json"}) {
      EXPECT_NE(run.out.find(option), std::string::npos) << option;
    }
  }
  for (const char* name : {"sim"}) {
    const Outcome run = run_tether({name, "--help"});
    EXPECT_EQ(run.status, 0);
    EXPECT_NE(run.out.find("--json"), std::string::npos) << name;
  }
  // `tether help NAME` is `tether NAME --help`.
  EXPECT_EQ(run_tether({"help", "monitor"}).out, run_tether({"monitor", "--help"}).out);
}

TEST(TetherUsage, SendHelpListsTheSchemasMessages) {
  const Outcome run = run_tether({"send", "--help"});
  EXPECT_NE(run.out.find("servo-control pin=N position=N"), std::string::npos);
  EXPECT_NE(run.out.find("digital-init pin=N safe-state=BOOL"), std::string::npos);
  EXPECT_NE(run.out.find("ping-failsafe-reset"), std::string::npos);
  EXPECT_NE(run.out.find("dc-motor-control pin-forward=N pin-reverse=N position=N"), std::string::npos);  // compat
}

TEST(TetherUsage, DeviceSelectionErrors) {
  expect_usage_error({"stats"}, "no device given");
  expect_usage_error({"monitor", "--port", "/dev/null", "--virtual", "romi-test"}, "give only one of");
  expect_usage_error({"shell", "--virtual", "romi-test", "--baud", "9600"}, "--baud does not apply to --virtual");
  expect_usage_error({"stats", "--port", "/dev/null", "--codec", "romi", "--capture", "drive"},
                     "--capture applies to the elcano codec");
  expect_usage_error({"monitor", "--port", "/dev/null", "--codec", "mavlink"}, "--codec needs romi, proxy");
  expect_usage_error({"monitor", "--port", "/dev/null", "--baud", "fast"}, "--baud needs a positive number");
  expect_usage_error({"monitor", "--port"}, "--port needs a value");
  expect_usage_error({"stats", "--config", kRover}, "--config needs --device NAME (devices in " + kRover + R"(: "arm", )");
  expect_usage_error({"stats", "--config", kRover, "--device", "wheels"}, "no device 'wheels'");
  expect_usage_error({"stats", "--config", kRover, "--device", "arm", "--baud", "9600"},
                     "--baud does not apply with --config");
  expect_usage_error({"stats", "--device", "arm"}, "--device needs --config FILE");
  expect_usage_error({"stats", "--config", "/nonexistent/rover.json", "--device", "arm"}, "/nonexistent/rover.json");
}

// `send --virtual nosuchimage` said the image "speaks romi, not the proxy protocol" (the codec
// guessed from the name came first).
TEST(TetherUsage, MissingFirmwareImageIsNotFound) {
  for (const std::vector<std::string>& arguments :
       {std::vector<std::string>{"send", "--virtual", "nosuchimage", "servo-init", "pin=9", "safe-position=90"},
        std::vector<std::string>{"call", "--virtual", "nosuchimage", "e"},
        std::vector<std::string>{"stats", "--virtual", "proxy-nosuchimage", "--duration", "0"}}) {
    expect_usage_error(arguments, "firmware image not found: ");
    const Outcome run = run_tether(arguments);
    EXPECT_NE(run.err.find(arguments[2] + ".elf: No such file or directory"), std::string::npos) << run.err;
    EXPECT_EQ(run.err.find("speaks"), std::string::npos) << run.err;
  }
  expect_usage_error({"call", "--virtual", ::testing::TempDir(), "e"}, ": Is a directory");
}

// Regression: output that could not be written (a full disk, a closed stdout) exited 0; a result that did
// not reach its reader is a failure: exit 2 and a message on stderr.
TEST(TetherUsage, OutputThatCannotBeWrittenExitsTwo) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::vector<std::vector<std::string>> commands = {{"--version"}, {"call", "--virtual", "romi-test", "e"},
                                                          {"call", "--virtual", "romi-test", "--json", "e"}};
  for (const auto& [redirect, reason] : {std::pair{">/dev/full", "No space left on device"},
                                         std::pair{">&-", "Bad file descriptor"}}) {
    for (const std::vector<std::string>& arguments : commands) {
      SCOPED_TRACE(::testing::PrintToString(arguments) + " " + redirect);
      std::vector<std::string> argv = {"sh", "-c", std::string("exec \"$0\" \"$@\" 2>&1 ") + redirect, TETHER_BINARY};
      argv.insert(argv.end(), arguments.begin(), arguments.end());
      ::tether::testing::ChildProcess run(argv, /*capture_stdout=*/true);  // stderr only: stdout goes elsewhere
      std::string err;
      while (const auto line = run.read_line(std::chrono::seconds(60))) err += *line + "\n";
      EXPECT_EQ(run.wait(std::chrono::seconds(20)), 2) << err;
      EXPECT_NE(err.find(std::string("the output could not be written: ") + reason), std::string::npos) << err;
    }
  }
}

// A path that exists but is no file (a device, a FIFO) is named for what it is, not "not found".
TEST(TetherUsage, FirmwareImageThatIsNoFileIsNamedForWhatItIs) {
  expect_usage_error({"call", "--virtual", "/dev/zero", "e"},
                     "not a firmware image: /dev/zero is a character device (an AVR ELF file is needed)");
  const std::string fifo = ::testing::TempDir() + "/tether-usage-fifo";
  std::filesystem::remove(fifo);
  ASSERT_EQ(mkfifo(fifo.c_str(), 0600), 0);
  expect_usage_error({"call", "--virtual", fifo, "e"}, "not a firmware image: " + fifo + " is a FIFO");
  std::filesystem::remove(fifo);
}

// configuration files that are not one, too large, or list too many names.
// g++ 12 at -O3 (Release) reports a -Wrestrict overlap inside libstdc++'s operator+ for
// `"d" + std::string` that cannot happen (GCC bug 105329); silenced for this test only.
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wrestrict"
#endif
TEST(TetherUsage, ConfigErrorsSayWhatIsWrongAndStayShort) {
  expect_usage_error({"stats", "--config", ::testing::TempDir(), "--device", "a"}, ": Is a directory");
  const std::string file = ::testing::TempDir() + "tether-usage-many-devices.json";
  nlohmann::json rover = {{"devices", nlohmann::json::array()}};
  for (int i = 0; i < 30; ++i) {
    rover["devices"].push_back({{"name", "d" + std::to_string(i)},
                                {"codec", "romi"},
                                {"transport", {{"serial", {{"path", "/dev/null"}}}}}});
  }
  std::ofstream(file) << rover.dump();
  Outcome run = run_tether({"stats", "--config", file, "--device", "a"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find(R"(no device 'a' in )" + file +
                         R"( (devices: "d0", "d1", "d2", "d3", "d4", "d5", "d6", "d7", "d8", "d9" and 20 more))"),
            std::string::npos)
      << run.err;
  EXPECT_LT(run.err.size(), 1000u);
  std::ofstream(file) << std::string(2'000'000, ' ');
  expect_usage_error({"stats", "--config", file, "--device", "a"},
                     file + ": configuration too large: 2000000 bytes (at most 1048576)");
  std::ofstream(file) << R"({"devices": [{"name": "a", "codec": "romi", "codec": "proxy"}]})";
  expect_usage_error({"stats", "--config", file, "--device", "a"},
                     file + ": devices[0].codec: duplicate key (the object has it already)");
  std::remove(file.c_str());
}
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic pop
#endif

TEST(TetherUsage, SendRejectsUnknownMessagesFieldsAndValuesBeforeOpening) {
  // /dev/null is never opened: every message is checked first.
  const std::vector<std::string> device = {"send", "--port", "/dev/null"};
  auto with = [&](std::vector<std::string> words) {
    std::vector<std::string> arguments = device;
    arguments.insert(arguments.end(), words.begin(), words.end());
    return arguments;
  };
  expect_usage_error(with({"servo-move", "pin=9"}), "unknown message 'servo-move' (messages: ping, servo-init, ");
  expect_usage_error(with({"servo-control", "pin=9", "angle=3"}),
                     "servo-control: unknown field 'angle' (fields: pin, position)");
  expect_usage_error(with({"servo-control", "pin=9", "position=up"}), "servo-control: position needs a number");
  expect_usage_error(with({"servo-control", "pin=-1", "position=3"}),
                     "servo-control: pin needs a number 0..4294967295");
  expect_usage_error(with({"digital-control", "pin=13", "state=maybe"}), "digital-control: state needs true or false");
  expect_usage_error(with({"servo-control", "pin=9"}), "servo-control: missing position=N");
  // Servo positions are degrees, in both modes: 999 or -5 is a typo, not something to clamp.
  expect_usage_error(with({"servo-control", "pin=9", "position=999"}),
                     "servo-control: position needs degrees 0..180, got '999'");
  expect_usage_error(with({"servo-init", "pin=9", "safe-position=-5"}),
                     "servo-init: safe-position needs degrees 0..180, got '-5'");
  expect_usage_error(with({"--codec", "proxy-compat", "servo-control", "pin=9", "position=181"}),
                     "servo-control: position needs degrees 0..180, got '181'");
  expect_usage_error(with({"servo-control", "pin=9", "pin=10", "position=1"}), "servo-control: pin given twice");
  expect_usage_error(with({}), "no message given");
  // The compat schema has other messages and fields.
  expect_usage_error(with({"--codec", "proxy-compat", "digital-control", "pin=7", "state=1"}),
                     "digital-control: unknown field 'state' (fields: pin, activate)");
  expect_usage_error(with({"--codec", "proxy-compat", "ping"}), "unknown message 'ping'");
  expect_usage_error({"send", "--port", "/dev/null", "--codec", "romi", "ping"}, "speaks romi, not the proxy protocol");
}

TEST(TetherUsage, SubcommandOptionErrors) {
  expect_usage_error({"monitor", "--port", "/dev/null", "--count", "0"}, "--count needs a positive number");
  expect_usage_error({"monitor", "--port", "/dev/null", "--duration", "soon"}, "--duration needs seconds");
  expect_usage_error({"monitor", "--port", "/dev/null", "--keepalive"}, "--keepalive applies to the proxy codec");
  expect_usage_error({"stats", "--port", "/dev/null", "--codec", "proxy", "--probe", "?"},
                     "--probe and --passive apply to the romi or rpc codec only");
  expect_usage_error({"stats", "--port", "/dev/null", "--probe", "a[99999]"}, "--probe 'a[99999]'");
  expect_usage_error({"shell", "--port", "/dev/null", "L[1]"}, "unexpected argument 'L[1]'");
  expect_usage_error({"shell", "--port", "/dev/null", "--verbose"}, "unknown option --verbose");
}

TEST(TetherUsage, UnopenableDevicesExitTwoWithTheReason) {
  Outcome run = run_tether({"stats", "--port", "/dev/tether-no-such-port", "--duration", "0"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("/dev/tether-no-such-port: No such file or directory"), std::string::npos) << run.err;
  run = run_tether({"monitor", "--virtual", "/nonexistent/image.elf", "--count", "1"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("/nonexistent/image.elf: No such file or directory"), std::string::npos) << run.err;
}

// `tether sim` takes an image name like `--virtual` does (the same lookup in the firmware folder).
TEST(TetherSim, ImageByNameLikeVirtual) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  for (const char* name : {"romi-test", "romi-test.elf"}) {
    SCOPED_TRACE(name);
    ::tether::testing::ChildProcess sim({TETHER_BINARY, "sim", name, "--json"}, true);
    const auto line = sim.read_line(std::chrono::seconds(30));
    ASSERT_TRUE(line);
    const nlohmann::json object = nlohmann::json::parse(*line);
    EXPECT_EQ(object["firmware"], firmware("romi-test").string());
    const Outcome run = run_tether({"call", "--port", object["pty"], "e"});
    EXPECT_EQ(run.status, 0) << run.err;
    EXPECT_EQ(run.out, "[0,1,2]\n");
    sim.signal(SIGINT);
    EXPECT_EQ(sim.wait(std::chrono::seconds(20)), 0);
  }
  const Outcome missing = run_tether({"sim", "no-such-image"});
  EXPECT_EQ(missing.status, 2);
  EXPECT_NE(missing.err.find("no-such-image.elf"), std::string::npos) << missing.err;
}

// The picocom line of `tether sim --help` is one that works with a Romi image: Enter must send CR LF.
TEST(TetherSim, HelpSuggestsPicocomWithCrLf) {
  const Outcome run = run_tether({"sim", "--help"});
  EXPECT_NE(run.out.find("picocom -b 115200 --omap crcrlf --echo /dev/pts/N"), std::string::npos) << run.out;
}

TEST(TetherSim, JsonPrintsThePtyAsAnObject) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  ::tether::testing::ChildProcess sim({TETHER_BINARY, "sim", firmware("romi-test").string(), "--json"}, true);
  const auto line = sim.read_line(std::chrono::seconds(30));
  ASSERT_TRUE(line);
  const nlohmann::json object = nlohmann::json::parse(*line);
  EXPECT_EQ(object["firmware"], firmware("romi-test").string());
  const std::string pty = object["pty"];
  EXPECT_TRUE(pty.starts_with("/dev/pts/")) << pty;
  // The port is ready when the line is printed: the first request is answered.
  const Outcome run = run_tether({"call", "--port", pty, "--json", "e"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(nlohmann::json::parse(run.out)["values"], nlohmann::json::parse("[0,1,2]"));
  sim.signal(SIGINT);
  EXPECT_EQ(sim.wait(std::chrono::seconds(20)), 0);
}

}  // namespace
}  // namespace tether::cli::testing
