// `tether call` naming its device like every device subcommand (--virtual, --config/--device with virtual
// and TCP transports, --port), its short usage errors, and the examples of its help run as written on the
// image they name. (Output format and exit statuses against a scripted device: codecs/romi/host/tests.)
#include <gtest/gtest.h>

#include <boost/asio/buffer.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read_until.hpp>
#include <boost/asio/streambuf.hpp>
#include <boost/asio/write.hpp>

#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include "fake_port.hpp"
#include "tether_process.hpp"

namespace tether::cli::testing {
namespace {

using nlohmann::json;

TEST(TetherCall, VirtualBoardByImageName) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const Outcome run = run_tether({"call", "--virtual", "romi-test", "e"});
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "[0,1,2]\n");
}

TEST(TetherCall, DeviceOfARoverConfiguration) {
  TETHER_REQUIRE_FIRMWARE("romi-rover");
  const Outcome run = run_tether({"call", "--config", kRover, "--device", "arm", "--json", "S[1500,1500]"});
  EXPECT_EQ(run.status, 0) << run.err;
  const json object = json::parse(run.out);
  EXPECT_EQ(object["values"], json::array({0}));
  EXPECT_EQ(object["answered"], true);
}

// A Romi device behind a TCP-serial bridge (ser2net), named by a configuration: the test plays the device
// on the accepted connection, answering the spec's vector for `e` with id 0.
TEST(TetherCall, DeviceBehindTcpFromAConfiguration) {
  namespace asio = boost::asio;
  asio::io_context io;
  asio::ip::tcp::acceptor acceptor(io, asio::ip::tcp::endpoint(asio::ip::address_v4::loopback(), 0));
  asio::ip::tcp::socket socket(io);
  asio::streambuf request;
  std::string received;
  acceptor.async_accept(socket, [&](const boost::system::error_code& error) {
    if (error) return;
    asio::async_read_until(socket, request, "\r\n", [&](const boost::system::error_code& read_error, std::size_t size) {
      if (read_error) return;
      received.assign(asio::buffers_begin(request.data()), asio::buffers_begin(request.data()) + static_cast<long>(size));
      static const std::string answer = "#e[0,1,2]:00dc\r\n";
      asio::async_write(socket, asio::buffer(answer), [](const boost::system::error_code&, std::size_t) {});
    });
  });
  std::thread device([&] { io.run_for(std::chrono::seconds(60)); });  // hang protection

  const std::filesystem::path config =
      std::filesystem::temp_directory_path() / ("tether-call-tcp-" + std::to_string(::getpid()) + ".json");
  std::ofstream(config) << json{{"devices",
                                 {{{"name", "arm"},
                                   {"codec", "romi"},
                                   {"transport",
                                    {{"tcp", {{"host", "127.0.0.1"}, {"port", acceptor.local_endpoint().port()}}}}}}}}}
                               .dump();
  const Outcome run = run_tether({"call", "--config", config.string(), "--device", "arm", "--id", "0", "e"});
  std::filesystem::remove(config);
  io.stop();
  device.join();
  EXPECT_EQ(run.status, 0) << run.err;
  EXPECT_EQ(run.out, "[0,1,2]\n");
  EXPECT_EQ(received, "#e:00d6\r\n");
}

TEST(TetherCall, DeviceOfAnotherCodecIsAUsageError) {
  const Outcome run = run_tether({"call", "--virtual", "proxy", "e"});  // refused before anything starts
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("speaks proxy, not romi"), std::string::npos) << run.err;
}

// Usage errors show the synopsis and where the details are, not the whole help.
TEST(TetherCall, UsageErrorsPrintAShortUsage) {
  for (const std::vector<std::string>& arguments :
       {std::vector<std::string>{"call", "e"}, {"call", "--virtual", "romi-test"}, {"call", "--port", "/dev/null", "--id", "256", "e"},
        {"call", "--port", "/dev/null", "--verbose", "e"}, {"call", "--port", "/dev/null", "e", "a"}}) {
    SCOPED_TRACE(::testing::PrintToString(arguments));
    const Outcome run = run_tether(arguments);
    EXPECT_EQ(run.status, 2);
    EXPECT_EQ(run.out, "");
    EXPECT_EQ(run.err.rfind("tether call: ", 0), 0u) << run.err;
    EXPECT_NE(run.err.find("usage: tether call --port PATH"), std::string::npos) << run.err;
    EXPECT_NE(run.err.find("Run `tether call --help` for the details."), std::string::npos) << run.err;
    EXPECT_EQ(run.err.find("--manual  "), std::string::npos) << run.err;  // the options' descriptions
    EXPECT_LT(std::count(run.err.begin(), run.err.end(), '\n'), 10) << run.err;
  }
  EXPECT_NE(run_tether({"call", "e"}).err.find("no device given"), std::string::npos);
  EXPECT_NE(run_tether({"call", "--virtual", "romi-test"}).err.find("no command given"), std::string::npos);
}

// The timeout message is the client's (it says what timed out); call prints it as it is.
TEST(TetherCall, NoAnswerPrintsTheClientsMessage) {
  FakePort port;  // a device that never answers
  const Outcome run = run_tether({"call", "--port", port.path(), "--timeout", "300", "--json", "a"});
  EXPECT_EQ(run.status, 2);
  const json object = json::parse(run.out);
  EXPECT_EQ(object["code"], -25);
  const std::string message = object["message"];
  EXPECT_FALSE(message.empty());
  EXPECT_EQ(object["values"], json::array({-25, message}));
  EXPECT_EQ(run.err, "tether call: -25 " + message + "\n");
}

// Every example of `tether call --help` runs as written on romi-test, the image it names.
TEST(TetherCall, HelpExamplesRunOnTheImageTheyName) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string help = run_tether({"call", "--help"}).out;
  struct Example {
    std::string command;
    std::string answer;
    int status;
  };
  for (const Example& example : {Example{"e", "[0,1,2]", 0}, Example{"s[2,3]", "[0,5]", 0},
                                 Example{"t[\"hello\"]", "[0,\"hello\"]", 0},
                                 Example{"f", "[101,\"I will try again tomorrow\"]", 1}}) {
    SCOPED_TRACE(example.command);
    EXPECT_NE(help.find("'" + example.command + "' -> " + example.answer), std::string::npos) << help;
    const Outcome run = run_tether({"call", "--virtual", "romi-test", example.command});
    EXPECT_EQ(run.status, example.status) << run.err;
    EXPECT_EQ(run.out, example.answer + "\n");
  }
  EXPECT_NE(help.find("Try it: `tether call --virtual romi-test e`"), std::string::npos);
}

// A name for a port in the test's temporary folder (a stand-in for /dev/serial/by-id/...), not there yet.
std::string port_link(const std::string& name) {
  const std::string link = ::testing::TempDir() + "/tether-call-" + name + "-" + std::to_string(::getpid());
  std::filesystem::remove(link);
  return link;
}

// A port that is not there yet is waited for within the call's budget: the board plugged in while the call
// waits (`tether sim --link` serves it behind the name) answers it.
TEST(TetherCall, WaitsWithinItsBudgetForItsPortToAppear) {
  TETHER_REQUIRE_FIRMWARE("romi-test");
  const std::string link = port_link("appears");
  Terminal terminal({"call", "--port", link, "--timeout", "60000", "e"});  // the budget only bounds a hang
  ASSERT_TRUE(terminal.expect("waiting for serial " + link)) << terminal.screen();
  const SimBoard board(std::vector<std::string>{firmware("romi-test").string(), "--link", link});
  EXPECT_TRUE(terminal.expect("[0,1,2]")) << terminal.screen();
  EXPECT_EQ(terminal.wait_exit(), 0) << terminal.screen();
}

// ... and when the budget runs out first, the call fails with the open's error and says it waited.
TEST(TetherCall, AMissingPortFailsWhenTheBudgetRunsOut) {
  const std::string link = port_link("missing");
  const Outcome run = run_tether({"call", "--port", link, "--timeout", "300", "e"});
  EXPECT_EQ(run.status, 2);
  EXPECT_TRUE(matches(run.err, "tether call: cannot open " + link + ": No such file or directory; waited # ms for it "
                               "(the call's budget) (serial " + link + "*)\n"))
      << run.err;
}

// With --no-reconnect nothing is waited for: a budget of an hour would outlast the test's hang limit.
TEST(TetherCall, WithoutReconnectAMissingPortFailsAtOnce) {
  const std::string link = port_link("no-reconnect");
  const Outcome run = run_tether({"call", "--port", link, "--timeout", "3600000", "--no-reconnect", "e"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("No such file or directory"), std::string::npos) << run.err;
  EXPECT_EQ(run.err.find("waited"), std::string::npos) << run.err;
}

// A port that vanishes with the call on its way ends the call at once: the device may have run it, so it
// is not sent again once the port is back.
TEST(TetherCall, APortThatVanishesWithTheCallOnItsWayEndsIt) {
  FakePort port;
  const std::string link = port_link("vanishes");
  std::filesystem::create_symlink(port.path(), link);
  Terminal terminal({"call", "--port", link, "--timeout", "60000", "e"});
  EXPECT_NE(port.read_until('\n').find("e:"), std::string::npos);  // the request reached the "device"
  std::filesystem::remove(link);
  port.pty->close();  // unplugged
  EXPECT_TRUE(terminal.expect("disconnected")) << terminal.screen();
  EXPECT_TRUE(terminal.expect("not sent again")) << terminal.screen();
  EXPECT_EQ(terminal.wait_exit(), 2) << terminal.screen();
}

// rpc's call waits the same way (the helper is shared; its message names the rpc budget's outcome).
TEST(TetherCall, AnRpcCallWaitsForAMissingPortWithinItsBudgetToo) {
  TETHER_REQUIRE_FIRMWARE("rpc-example");
  const std::string link = port_link("rpc");
  std::filesystem::path schema = firmware("rpc-example");
  schema.replace_extension(".proto");
  const Outcome run = run_tether({"call", "--port", link, "--codec", "rpc", "--schema", schema.string(), "--timeout",
                                  "300", "Describe"});
  EXPECT_EQ(run.status, 2);
  EXPECT_NE(run.err.find("; waited "), std::string::npos) << run.err;
}

// An rpc stream rides an outage: while its port is gone the wait for the next message is suspended (the
// command waits for the port), and the board plugged in again behind the name carries the stream on (the
// client re-opens it in the new session). The pause outlasts the stream's --timeout: without the
// suspension the command failed with "no stream message within 2000 ms".
TEST(TetherCall, AnRpcStreamWaitsForItsVanishedPortAndGoesOn) {
  TETHER_REQUIRE_FIRMWARE("rpc-example");
  const std::string link = port_link("rpc-stream");
  std::filesystem::path schema = firmware("rpc-example");
  schema.replace_extension(".proto");
  const std::vector<std::string> sim = {firmware("rpc-example").string(), "--link", link};
  std::optional<SimBoard> board(std::in_place, sim);
  Terminal terminal({"call", "--port", link, "--codec", "rpc", "--schema", schema.string(), "--timeout", "2000",
                     "--json", "Watch", "--period", "20", "--count", "30"});
  ASSERT_TRUE(terminal.expect("\"seq\":3,")) << terminal.screen();
  board.reset();  // unplugged: `tether sim` closes its pty and removes the name
  ASSERT_TRUE(terminal.expect("waiting for " + link + " to come back")) << terminal.screen();
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  board.emplace(sim);
  EXPECT_EQ(terminal.wait_exit(std::chrono::seconds(60)), 0) << terminal.screen();
  EXPECT_EQ(terminal.screen().find("no stream message"), std::string::npos) << terminal.screen();
}

}  // namespace
}  // namespace tether::cli::testing
