// `tether call` as a subprocess against a pty whose master side is a scripted fake device: output, stderr
// messages and exit statuses (0 success, 1 application error, 2 protocol/transport/usage error).
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "fake_device.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/pty_stream.hpp"
#include "test_support.hpp"
#include "tether_process.hpp"

namespace tether::romi::testing {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using ::tether::cli::testing::Outcome;
using ::tether::cli::testing::run_tether;

// A fake device on the master side of a new pty; the command opens the slave side.
struct PtyDevice {
  ::tether::transports::IoThread io;
  std::shared_ptr<transports::PtyStream> pty = transports::PtyStream::open(io.executor());
  std::shared_ptr<FakeDevice> device = FakeDevice::start(pty);
  ~PtyDevice() { device->close(); }
  Outcome call(std::vector<std::string> arguments) {
    arguments.insert(arguments.begin(), {"call", "--port", pty->slave_path(), "--id", "0"});
    return run_tether(arguments);
  }
};

TEST(TetherCall, SuccessPrintsTheAnswerArrayAndExitsZero) {
  PtyDevice link;
  link.device->on_request(answer_with("[0,1,2]"));
  const Outcome run = link.call({"e"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "[0,1,2]\n");
  EXPECT_EQ(run.err, "");
  EXPECT_EQ(link.device->received(), request_frame("e", 0));
}

TEST(TetherCall, ArgumentsAndStringsGoOutAsTyped) {
  PtyDevice link;
  link.device->on_request(answer_with("[0]"));
  const Outcome run = link.call({"M[16,\"Shutdown\"]"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(link.device->received(), request_frame("M[16,\"Shutdown\"]", 0));
}

TEST(TetherCall, ApplicationErrorExitsOne) {
  PtyDevice link;
  link.device->on_request(answer_with(R"([101,"I will try again tomorrow"])"));
  const Outcome run = link.call({"f"});
  EXPECT_EQ(run.status, 1);
  EXPECT_EQ(run.out, "[101,\"I will try again tomorrow\"]\n");
  EXPECT_EQ(run.err, "tether call: 101 I will try again tomorrow\n");
}

TEST(TetherCall, DeviceProtocolErrorExitsTwo) {
  PtyDevice link;
  link.device->on_request(answer_with("[-16]"));
  const Outcome run = link.call({"z"});
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.out, "[-16]\n");
  EXPECT_EQ(run.err, "tether call: -16 unknown opcode\n");
}

TEST(TetherCall, SilentDeviceTimesOutAndExitsTwo) {
  PtyDevice link;
  const Outcome run = link.call({"--timeout", "300", "a"});
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.out, "");
  EXPECT_EQ(run.err, "tether call: -25 client: no reply from the device within 300 ms\n");
  EXPECT_EQ(link.device->requests().size(), 1u);
}

TEST(TetherCall, InvalidCommandIsRejectedBeforeTheWire) {
  PtyDevice link;
  link.device->on_request(answer_with("[0]"));
  Outcome run = link.call({"a[40000]"});
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.out, "");
  EXPECT_EQ(run.err, "tether call: -10 value out of range at character 3 ('4')\n");
  // Where the command goes wrong, for each kind of mistake.
  run = link.call({"e[0,,1]"});
  EXPECT_EQ(run.err, "tether call: -8 unexpected char at character 5 (',')\n");
  run = link.call({"e[0,1"});
  EXPECT_EQ(run.err, "tether call: -8 unexpected char at the end (the command is incomplete)\n");
  run = link.call({"a[\"no:colons\"]"});
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.err.rfind("tether call: -32 ", 0), 0u) << run.err;
  run = link.call({""});
  EXPECT_EQ(run.err, "tether call: -24 client: empty request\n");
  // Rejected commands do not even open the port. A valid call afterwards: the device saw nothing before it.
  run = link.call({"a"});
  EXPECT_EQ(run.status, 0);
  EXPECT_EQ(link.device->received(), "#a:008e\r\n");
}

TEST(TetherCall, InvalidJsonAnswerIsReportedWithWhatArrived) {
  PtyDevice link;
  link.device->on_request(answer_with("[0,oops]"));
  const Outcome run = link.call({"a"});
  EXPECT_EQ(run.status, 2);
  EXPECT_EQ(run.out, "[-26,\"client: invalid JSON\"]\n");
  EXPECT_EQ(run.err, "tether call: -26 client: invalid JSON (received: a[0,oops])\n");
}

TEST(TetherCall, ManualSendsTheTerminalForm) {
  PtyDevice link;
  link.device->on_request([](const DeviceRequest&, FakeDevice& device) { device.send("#a[0]:00e7\r\n"); });
  const Outcome run = link.call({"--manual", "a"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "[0]\n");
  EXPECT_EQ(link.device->received(), "#a:xxxx\r\n");
}

TEST(TetherCall, JsonPrintsAnObjectForEveryOutcome) {
  {
    PtyDevice link;
    link.device->on_request(answer_with("[0,1,2]"));
    const Outcome run = link.call({"--json", "e"});
    EXPECT_EQ(run.status, 0);
    const json object = json::parse(run.out);
    EXPECT_EQ(object["code"], 0);
    EXPECT_EQ(object["values"], json::parse("[0,1,2]"));
    EXPECT_EQ(object["answered"], true);
    EXPECT_EQ(object["attempts"], 1);
  }
  PtyDevice link;  // a fresh pty per run: the command opens the port exclusively (TIOCEXCL)
  const Outcome run = link.call({"--json", "--timeout", "200", "e"});
  EXPECT_EQ(run.status, 2);
  const json object = json::parse(run.out);
  EXPECT_EQ(object["code"], -25);
  EXPECT_EQ(object["answered"], false);
  EXPECT_EQ(object["values"], json::array({-25, "client: no reply from the device within 200 ms"}));
}

TEST(TetherCall, LogLinesDuringTheCallGoToStderr) {
  PtyDevice link;
  link.device->on_request([](const DeviceRequest& request, FakeDevice& device) {
    device.send(FakeDevice::log("motor: ready"));
    device.send(FakeDevice::response(request.opcode, "[0]", request.id));
  });
  const Outcome run = link.call({"a"});
  EXPECT_EQ(run.status, 0);
  EXPECT_EQ(run.out, "[0]\n");
  EXPECT_EQ(run.err, "log: motor: ready\n");
}

TEST(TetherCall, IdIsRandomButNever255UnlessGiven) {
  {
    PtyDevice link;
    link.device->on_request(answer_with("[0]"));
    const Outcome run = run_tether({"call", "--port", link.pty->slave_path(), "--id", "123", "e"});
    EXPECT_EQ(run.status, 0) << run.err;
    EXPECT_EQ(link.device->received(), "#e:7b04\r\n");  // the spec's vector for id 123
  }
  for (int i = 0; i < 3; ++i) {
    PtyDevice link;
    link.device->on_request(answer_with("[0]"));
    const Outcome run = run_tether({"call", "--port", link.pty->slave_path(), "e"});
    EXPECT_EQ(run.status, 0) << run.err;
    const auto requests = link.device->requests();
    ASSERT_EQ(requests.size(), 1u);
    EXPECT_NE(requests[0].id, 255);
  }
}

TEST(TetherCall, HelpAndUsageErrors) {
  Outcome run = run_tether({"call", "--help"});
  EXPECT_EQ(run.status, 0);
  EXPECT_NE(run.out.find("usage: tether call --port PATH"), std::string::npos);
  EXPECT_NE(run.out.find("--manual"), std::string::npos);
  run = run_tether({"--help"});
  EXPECT_NE(run.out.find("call"), std::string::npos);
  run = run_tether({"call", "a"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("no device given"), std::string::npos);
  run = run_tether({"call", "--port", "/dev/tether-no-such-port", "a"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("cannot open /dev/tether-no-such-port"), std::string::npos);
  run = run_tether({"call", "--port", "/dev/null", "--timeout", "soon", "a"});
  EXPECT_EQ(run.status, 2);
  run = run_tether({"call", "--port", "/dev/null", "--id", "256", "a"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("--id needs a number 0..255"), std::string::npos);
}

}  // namespace
}  // namespace tether::romi::testing
