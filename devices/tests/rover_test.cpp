// Opening rovers: one virtual Uno per codec running the real images, typed lookups, clean close, and
// failures (missing port, missing image, refused connection, silent device) that roll back what opened.
#include <gtest/gtest.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/use_future.hpp>

#include <atomic>
#include <chrono>
#include <optional>

#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "tether/devices/rover.hpp"
#include "tether/devices/virtual_boards.hpp"
#include "tether/elcano/plugin.hpp"
#include "tether/proxy/plugin.hpp"
#include "tether/romi/plugin.hpp"
#include "tether/rpc/client.hpp"
#include "tether/rpc/plugin.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/virtual_uno_clock.hpp"

namespace tether::devices {
namespace {

using transports::IoThread;

// Every rover here has virtual devices: enabled once, before the first test.
class EnableVirtualBoards : public ::testing::Environment {
 public:
  void SetUp() override { enable_virtual_boards(); }
};
[[maybe_unused]] ::testing::Environment* const virtual_boards_enabled =
    ::testing::AddGlobalTestEnvironment(new EnableVirtualBoards);


ParseOptions firmware() {
  ParseOptions options;
  options.firmware_dir = TETHER_FIRMWARE_DIR;
  return options;
}

std::string seed() { return std::to_string(tether::testing::random_seed()); }

// One JSON device per codec on a virtual Uno.
std::string romi_device(const std::string& name = "arm") {
  return R"({"name": ")" + name + R"(", "codec": "romi", "transport": {"virtual": {"firmware": "romi-test", "seed": )" +
         seed() + "}}}";
}
std::string proxy_device() {
  return R"({"name": "servos", "codec": "proxy", "transport": {"virtual": {"firmware": "proxy", "seed": )" + seed() +
         R"(}}, "options": {"inits": [{"kind": "servo", "pin": 9, "safe_position": 90},
                                     {"kind": "digital", "pin": 13, "safe_state": false}]}})";
}
std::string compat_device() {
  return R"({"name": "legacy", "codec": "proxy-compat", "transport": {"virtual": {"firmware": "proxy-compat"}},
             "options": {"inits": [{"kind": "servo", "pin": 9, "safe_position": 90}]}})";
}
RoverConfig rover_of(const std::vector<std::string>& devices) {
  std::string list;
  for (const auto& device : devices) list += (list.empty() ? "" : ",") + device;
  return parse_config(R"({"devices": [)" + list + "]}", firmware());
}

// The ConfigError open_rover throws for `config` (fails the test if it opens).
ConfigError open_error(const RoverConfig& config, boost::asio::any_io_executor executor,
                       const OpenOptions& options = OpenOptions()) {
  try {
    Rover rover = open_rover(config, executor, options);
    ADD_FAILURE() << "opened";
  } catch (const ConfigError& error) {
    return error;
  }
  return ConfigError("", "");
}

TEST(DevicesRover, OpensOneVirtualDevicePerCodecUsesThemAndClosesCleanly) {
  IoThread io;
  std::vector<std::string> opened;
  OpenOptions hooks;
  hooks.on_opened = [&](const RoverDevice& device) { opened.push_back(device.name); };
  Rover rover = open_rover(rover_of({romi_device(), proxy_device(), compat_device()}), io.executor(), hooks);
  EXPECT_EQ(opened, (std::vector<std::string>{"arm", "servos", "legacy"}));
  ASSERT_TRUE(rover.is_open());

  ASSERT_EQ(rover.devices().size(), 3u);
  EXPECT_EQ(rover.devices()[0].name, "arm");
  EXPECT_EQ(rover.devices()[0].codec, romi::kCodec);
  EXPECT_EQ(rover.devices()[0].transport.rfind("virtual romi-test.elf (real_time, seed ", 0), 0u)
      << rover.devices()[0].transport;
  EXPECT_EQ(rover.devices()[1].codec, proxy::kCodec);
  EXPECT_EQ(rover.devices()[2].codec, proxy::kCompatCodec);

  // romi: a call is answered.
  const auto arm = rover.client<romi::Client>("arm");
  const romi::RomiResponse values = arm->call("e");
  EXPECT_EQ(values.code, 0);
  EXPECT_EQ(values.values, nlohmann::json::parse("[0,1,2]"));

  // proxy: the session is up, the inits were acked, a send is acked.
  const auto servos = rover.client<proxy::Client>("servos");
  EXPECT_TRUE(servos->session().established);
  EXPECT_GE(servos->counters().acks, 2u) << "both inits acked during the open";
  const proxy::SendResult set = servos->servo(9).set(120);
  EXPECT_TRUE(set.acked);

  // proxy-compat: a send is written.
  const auto legacy = rover.client<proxy::Client>("legacy");
  EXPECT_EQ(legacy->mode(), proxy::Mode::compat);
  boost::system::error_code error;
  legacy->servo(9).set(120, error);
  EXPECT_FALSE(error) << error.message();

  rover.close();
  EXPECT_FALSE(rover.is_open());
  EXPECT_TRUE(rover.devices().empty());
  EXPECT_FALSE(arm->is_open());
  EXPECT_FALSE(servos->is_open());
  EXPECT_FALSE(legacy->is_open());
  arm->call("e", error);
  EXPECT_EQ(error, boost::asio::error::operation_aborted) << "a kept handle fails cleanly after close";
  rover.close();  // idempotent
}

TEST(DevicesRover, LookupsOfMissingNamesAndWrongCodecsSayWhatIsThere) {
  IoThread io;
  Rover rover = open_rover(rover_of({romi_device("arm"), romi_device("head")}), io.executor());
  try {
    rover.client<romi::Client>("armm");
    ADD_FAILURE();
  } catch (const std::out_of_range& error) {
    EXPECT_STREQ(error.what(), R"(rover: no device "armm" (devices: "arm", "head"))");
  }
  try {
    rover.client<proxy::Client>("arm");
    ADD_FAILURE();
  } catch (const std::out_of_range& error) {
    EXPECT_STREQ(error.what(), R"(rover: device "arm" speaks romi, not proxy or proxy-compat)");
  }
  try {
    rover.client<transports::ByteStream>("arm");  // no codec's client: the type is named as written
    ADD_FAILURE();
  } catch (const std::out_of_range& error) {
    EXPECT_STREQ(error.what(),
                 R"(rover: device "arm" speaks romi, not a device with a tether::transports::ByteStream client)");
  }
  EXPECT_EQ(rover.find("nothing"), nullptr);
  ASSERT_NE(rover.find("head"), nullptr);
  EXPECT_EQ(rover.find("head")->codec, romi::kCodec);

  Rover moved = std::move(rover);
  EXPECT_FALSE(rover.is_open());  // NOLINT(bugprone-use-after-move): documented as left empty
  EXPECT_TRUE(moved.is_open());
  EXPECT_EQ(moved.client<romi::Client>("head")->call("e").code, 0);
  moved.close();
  try {
    moved.client<romi::Client>("arm");
    ADD_FAILURE();
  } catch (const std::out_of_range& error) {
    EXPECT_STREQ(error.what(), R"(rover: no device "arm" (the rover has no devices))");
  }
}

TEST(DevicesRover, AMissingSerialPortFailsTheOpenAndClosesTheDevicesOpenedBefore) {
  IoThread io;
  const RoverConfig config = rover_of(
      {romi_device(), R"({"name": "servos", "codec": "proxy",
                          "transport": {"serial": {"path": "/dev/tether-no-such-port"}}})"});
  std::vector<std::shared_ptr<romi::Client>> opened;
  OpenOptions hooks;
  hooks.on_opened = [&](const RoverDevice& device) {
    opened.push_back(device.client.get<romi::Client>());
  };
  const ConfigError error = open_error(config, io.executor(), hooks);
  EXPECT_STREQ(error.what(), "devices[1].transport.serial.path: /dev/tether-no-such-port: No such file or directory");
  EXPECT_EQ(error.path(), "devices[1].transport.serial.path");
  EXPECT_EQ(error.code(), boost::system::errc::no_such_file_or_directory);
  ASSERT_EQ(opened.size(), 1u) << "the first device opened";
  EXPECT_FALSE(opened[0]->is_open()) << "and was closed before the error returned";

  // The error_code form: an empty rover, the code and the message.
  boost::system::error_code code;
  std::string message;
  Rover rover = open_rover(config, io.executor(), code, &message);
  EXPECT_FALSE(rover.is_open());
  EXPECT_EQ(code, boost::system::errc::no_such_file_or_directory);
  EXPECT_EQ(message, "devices[1].transport.serial.path: /dev/tether-no-such-port: No such file or directory");
}

TEST(DevicesRover, AMissingFirmwareImageNamesTheFile) {
  IoThread io;
  const RoverConfig config = parse_config(
      R"({"devices": [{"name": "arm", "codec": "romi", "transport": {"virtual": {"firmware": "no-such-image"}}}]})",
      firmware());
  const ConfigError error = open_error(config, io.executor());
  EXPECT_EQ(std::string(error.what()), "devices[0].transport.virtual.firmware: " + std::string(TETHER_FIRMWARE_DIR) +
                                           "/no-such-image.elf: No such file or directory");
  EXPECT_EQ(error.code(), boost::system::errc::no_such_file_or_directory);
}

TEST(DevicesRover, ARefusedTcpConnectionNamesHostAndPort) {
  // A port nobody listens on: bind one, note it, close it.
  unsigned short port = 0;
  {
    boost::asio::io_context context;
    boost::asio::ip::tcp::acceptor acceptor(context, {boost::asio::ip::make_address("127.0.0.1"), 0});
    port = acceptor.local_endpoint().port();
  }
  IoThread io;
  const RoverConfig config = parse_config(R"({"devices": [{"name": "legacy", "codec": "proxy-compat",
      "transport": {"tcp": {"host": "127.0.0.1", "port": )" + std::to_string(port) + "}}}]}");
  const ConfigError error = open_error(config, io.executor());
  EXPECT_EQ(std::string(error.what()),
            "devices[0].transport.tcp: 127.0.0.1:" + std::to_string(port) + ": Connection refused");
  EXPECT_EQ(error.code(), boost::system::errc::connection_refused);
}

TEST(DevicesRover, AProxyDeviceThatNeverAnswersTheHandshakeFailsTheOpen) {
  IoThread io;
  // romi firmware behind a proxy codec: no ResetEvent ever comes.
  const RoverConfig config = parse_config(
      R"({"devices": [{"name": "servos", "codec": "proxy", "transport": {"virtual": {"firmware": "romi-test"}},
          "options": {"open_timeout_ms": 1500}}]})",
      firmware());
  const ConfigError error = open_error(config, io.executor());
  EXPECT_EQ(error.path(), "devices[0]");
  EXPECT_EQ(error.code(), make_error_code(DevicesError::device_not_ready));
  EXPECT_EQ(error.detail().rfind("no proxy session within 1500 ms", 0), 0u) << error.what();
}

TEST(DevicesRover, AnInvalidConfigBuiltInCodeIsRejectedBeforeAnythingOpens) {
  IoThread io;
  RoverConfig config = rover_of({romi_device()});
  config.devices.push_back(config.devices[0]);
  const ConfigError error = open_error(config, io.executor());
  EXPECT_STREQ(error.what(), R"(devices[1].name: duplicate device name "arm" (also devices[0]))");
}


// The tests' goal number `number` towards `bearing`, at 100,200.
elcano::Message goal(std::int32_t number, std::int32_t bearing) {
  return elcano::Message::goal(number, bearing, 100, 200);
}

TEST(DevicesRover, TheDefaultVirtualRoverOpensEveryCodecIncludingTheElcanoRing) {
  IoThread io;
  const RoverConfig config = parse_config(default_virtual_rover_config(), firmware());
  Rover rover = open_rover(config, io.executor());
  ASSERT_EQ(rover.devices().size(), 6u);
  EXPECT_EQ(rover.devices()[3].codec, rpc::kCodec);
  EXPECT_EQ(rover.devices()[4].codec, elcano::kCodec);
  EXPECT_EQ(rover.devices()[4].transport, "virtual ring of 3 boards (elcano-node.elf; real_time)");

  EXPECT_EQ(rover.client<romi::Client>("arm")->call("S[1200,1800]").code, 0);  // the romi-rover image
  EXPECT_TRUE(rover.client<proxy::Client>("servos")->servo(10).set(45).acked);
  boost::system::error_code error;
  rover.client<proxy::Client>("legacy")->digital(7).set(true, error);
  EXPECT_FALSE(error) << error.message();
  // The rpc example's image, its schema read from beside the image (README's call).
  EXPECT_EQ(rover.client<rpc::Client>("joints")->call_json("MoveJoint", R"({"joint": 2, "angleCdeg": -4500})"),
            R"({"reachedCdeg":-4500})");

  // The reference ring: goal -> board 1 -> segment -> board 2 -> drive -> board 3 (servos) -> sensor -> host.
  const auto ring = rover.client<elcano::RingClient>("ring");
  const elcano::Message sensor = ring->request(goal(1, 90), elcano::Type::sensor);
  EXPECT_EQ(sensor.type, elcano::Type::sensor);
  EXPECT_EQ(sensor.speed, 150) << "the segment's cruise speed, driven and reported";
  EXPECT_EQ(sensor.angle, 45) << "bearing 90 from heading 0, clamped to the steering limit";

  // Every client runs on its board's time; the ring's is its first board's (the group keeps them in step).
  for (const RoverDevice& device : rover.devices()) {
    EXPECT_NE(std::dynamic_pointer_cast<transports::VirtualUnoClock>(device.clock), nullptr) << device.name;
  }

  rover.close();
  EXPECT_FALSE(ring->is_open());
}

// Takes over a rover's running virtual board and advances it from a thread of its own at a third of real
// time or less (5 ms of simulation, then 10 ms of sleep): what a loaded machine does to a board paced in
// real time, made reproducible. Stop it before the rover closes.
class SlowedBoard {
 public:
  explicit SlowedBoard(std::shared_ptr<transports::VirtualUno> board) : board_(std::move(board)) {
    board_->stop();
    thread_ = std::thread([this] {
      while (running_) {
        board_->run_for(std::chrono::milliseconds(5));
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    });
  }
  ~SlowedBoard() { stop(); }
  SlowedBoard(const SlowedBoard&) = delete;
  SlowedBoard& operator=(const SlowedBoard&) = delete;
  void stop() {
    running_ = false;
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::shared_ptr<transports::VirtualUno> board_;
  std::atomic<bool> running_{true};
  std::thread thread_;
};

// A rover's virtual device whose board runs slower than real time, as under load: the first call's 1 s
// window ends (on board time) while the device is in 1.5 s of simulated busy wait, and the second call gets
// its answer once the late one went to the stale counter. With the client on the steady clock the second
// call's 2 s budget ended while the device was still busy (client_timeout).
TEST(DevicesRover, AVirtualDeviceOnABoardSlowerThanRealTimeKeepsItsDeadlinesOnBoardTime) {
  IoThread io;
  Rover rover = open_rover(rover_of({romi_device()}), io.executor());
  const RoverDevice& device = rover.devices().front();
  ASSERT_EQ(device.boards.size(), 1u);
  const auto client = rover.client<romi::Client>("arm");
  SlowedBoard slow(device.boards.front());
  const auto started = device.boards.front()->simulated_time();
  boost::system::error_code error;
  const romi::RomiResponse late = client->call("w[1500]", error);
  EXPECT_EQ(error, make_error_code(romi::Error::client_timeout)) << error.message();
  EXPECT_EQ(late.code, -25);
  EXPECT_LT(device.boards.front()->simulated_time() - started, std::chrono::milliseconds(1500))
      << "the device is still busy";
  const romi::RomiResponse own = client->call("s[20,22]", error);
  ASSERT_FALSE(error) << error.message();
  EXPECT_EQ(own.values, nlohmann::json::parse("[0,42]"));
  EXPECT_GE(client->counters().link.stale, 1u);
  slow.stop();
  rover.close();
}

TEST(DevicesRover, AMissingRingImageFailsTheOpenAndClosesTheDevicesOpenedBefore) {
  IoThread io;
  const RoverConfig config = rover_of(
      {romi_device(), R"({"name": "ring", "codec": "elcano", "transport": {"virtual_ring": {"boards": [
          {"firmware": "elcano-node"}, {"firmware": "no-such-node"}]}}})"});
  std::shared_ptr<romi::Client> arm;
  OpenOptions hooks;
  hooks.on_opened = [&](const RoverDevice& device) { arm = device.client.get<romi::Client>(); };
  const ConfigError error = open_error(config, io.executor(), hooks);
  EXPECT_EQ(std::string(error.what()), "devices[1].transport.virtual_ring.boards[1].firmware: " +
                                           std::string(TETHER_FIRMWARE_DIR) +
                                           "/no-such-node.elf: No such file or directory");
  ASSERT_NE(arm, nullptr);
  EXPECT_FALSE(arm->is_open());
}

TEST(DevicesRover, ARingWithRawEepromBytesRunsTheBuildDefaults) {
  IoThread io;
  // An erased EEPROM (no block): each node runs its build-time defaults (captures nothing, forwards all),
  // so a goal goes round the ring and comes back undeliverable.
  const RoverConfig config = parse_config(R"({"devices": [{"name": "ring", "codec": "elcano",
      "transport": {"virtual_ring": {"boards": [{"eeprom": [255, 255]}, {}]}},
      "options": {"attempt_timeout_ms": 300, "call_budget_ms": 600, "max_attempts": 1}}]})",
                                          firmware());
  Rover rover = open_rover(config, io.executor());
  boost::system::error_code error;
  rover.client<elcano::RingClient>("ring")->request(goal(2, 0), elcano::Type::segment, error);
  EXPECT_EQ(error, elcano::RingError::undeliverable) << error.message();
}

TEST(DevicesRover, AsyncOpenRunsOnAServicesOwnSingleThreadedEventLoop) {
  boost::asio::io_context io;  // the service's only thread runs it: a blocking open here would deadlock
  std::optional<Rover> rover;
  std::exception_ptr failure;
  async_open_rover(rover_of({romi_device(), proxy_device()}), io.get_executor(),
                   [&](std::exception_ptr error, Rover opened) {
                     failure = error;
                     rover.emplace(std::move(opened));
                   });
  const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!rover && std::chrono::steady_clock::now() < limit) io.run_one_for(std::chrono::milliseconds(50));
  ASSERT_TRUE(rover.has_value());
  ASSERT_FALSE(failure);
  std::optional<romi::RomiResponse> answer;
  rover->client<romi::Client>("arm")->async_call("e", [&](boost::system::error_code, romi::RomiResponse response) {
    answer = std::move(response);
  });
  while (!answer && std::chrono::steady_clock::now() < limit) io.run_one_for(std::chrono::milliseconds(50));
  ASSERT_TRUE(answer.has_value());
  EXPECT_EQ(answer->code, 0);
  rover->close();
}

TEST(DevicesRover, AsyncOpenWithAFutureRethrowsTheConfigError) {
  IoThread io;
  const RoverConfig config =
      rover_of({romi_device(), R"({"name": "b", "codec": "romi", "transport": {"serial": {"path": "/dev/tether-none"}}})"});
  std::future<Rover> opening = async_open_rover(config, io.executor(), boost::asio::use_future);
  try {
    opening.get();
    ADD_FAILURE() << "opened";
  } catch (const ConfigError& error) {
    EXPECT_STREQ(error.what(), "devices[1].transport.serial.path: /dev/tether-none: No such file or directory");
  }
  Rover rover = async_open_rover(rover_of({romi_device()}), io.executor(), boost::asio::use_future).get();
  EXPECT_EQ(rover.client<romi::Client>("arm")->call("e").code, 0);
}

TEST(DevicesRover, AKeptRingHandleOutlivesTheRoverSafely) {
  IoThread io;
  std::shared_ptr<elcano::RingClient> ring;
  {
    Rover rover = open_rover(parse_config(R"({"devices": [{"name": "ring", "codec": "elcano",
        "transport": {"virtual_ring": {"boards": [{}, {}]}}}]})", firmware()), io.executor());
    ring = rover.client<elcano::RingClient>("ring");
  }  // the rover closes the client and stops the ring; the boards live as long as the client's stream
  boost::system::error_code error;
  ring->send(goal(3, 0), error);
  EXPECT_EQ(error, boost::asio::error::operation_aborted);
  ring.reset();
}

// A device's transport alone: the reference ring as a bare byte stream (what `tether monitor` reads).
TEST(DevicesRover, OpenTransportGivesTheRingAsABareStream) {
  IoThread io;
  const RoverConfig config = parse_config(default_virtual_rover_config(), firmware());
  const DeviceConfig* ring = nullptr;
  for (const DeviceConfig& device : config.devices) {
    if (device.name == "ring") ring = &device;
  }
  ASSERT_NE(ring, nullptr);
  OpenedTransport opened = open_transport(*ring, io.executor());
  ASSERT_NE(opened.stream, nullptr);
  EXPECT_EQ(opened.boards.size(), 3u);
  // A drive goes through boards 1 and 2 to board 3, which drives the servos and reports a sensor message.
  const std::string drive = "D{s 50}{a 25}\n";
  opened.stream->write(boost::asio::buffer(drive));
  std::string received;
  char buffer[128];
  const auto limit = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (received.find('\n') == std::string::npos && std::chrono::steady_clock::now() < limit) {
    received.append(buffer, opened.stream->read_some(boost::asio::buffer(buffer), std::chrono::seconds(20)));
  }
  EXPECT_EQ(received.substr(0, 2), "S{") << received;
  EXPECT_NE(received.find("{s 50}{a 25}"), std::string::npos) << received;
  opened.stream->close();
  if (opened.stop) opened.stop();
}

TEST(DevicesRover, OpenTransportErrorsNameTheTransport) {
  IoThread io;
  const RoverConfig config = parse_config(
      R"({"devices": [{"name": "arm", "codec": "romi", "transport": {"serial": {"path": "/dev/tether-no-such-port"}}}]})");
  try {
    open_transport(config.devices[0], io.executor());
    ADD_FAILURE() << "opened a port that does not exist";
  } catch (const ConfigError& error) {
    EXPECT_EQ(error.path(), "transport.serial.path");
    EXPECT_NE(std::string(error.what()).find("/dev/tether-no-such-port"), std::string::npos) << error.what();
  }
}

}  // namespace
}  // namespace tether::devices
