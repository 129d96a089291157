// The typed client that tether_generate_rpc writes for the tests' arm.proto (arm::ArmClient, on protoc's
// classes of the same file) against the real device runtime (ArmDevice) over an in-memory link, on a
// manual clock; and the compiled-in schema it stands on.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>
#include <gtest/gtest.h>

#include <boost/asio/use_future.hpp>

#include <atomic>
#include <future>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <typeinfo>
#include <vector>

#include "arm.tether.hpp"
#include "arm_device.hpp"
#include "arm_peer.hpp"
#include "tether/transports/in_memory_stream.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/client/testing/manual_clock.hpp"
#include "tether/transports/testing/scripted_peer.hpp"

namespace {

using namespace std::chrono_literals;
using tether::rpc::RpcError;
using tether::rpc::Schema;
using tether::rpc::testing::ArmDevice;
using tether::rpc::testing::ArmPeer;

const std::string kSchemas = TETHER_RPC_TEST_SCHEMAS;

tether::rpc::Options typed_test_options(std::shared_ptr<tether::client::LinkClock> clock) {
  tether::rpc::Options options;
  options.clock = std::move(clock);
  options.first_message_id = 100;
  options.timing.ping_period = 0;
  options.timing.processing_margin = 150;
  options.timing.queue_timeout = 3000;
  return options;
}

// A typed client and the arm device (whose hello carries `device_hash`, by default the schema's).
struct TypedLink {
  explicit TypedLink(std::optional<std::uint64_t> device_hash = std::nullopt)
      : clock(tether::client::testing::ManualClock::create()) {
    auto [host_end, device_end] = tether::transports::InMemoryStream::make_pair(io.executor());
    peer = ArmPeer::start(device_end, device_hash.value_or(arm::ArmClient::kSchemaHash), clock);
    peer->boot(0xC0FFEE);
    arm.emplace(host_end, typed_test_options(clock));
  }
  ~TypedLink() {
    if (arm) arm->close();
    peer->close();
  }
  // 1 ms of simulated time for both ends per 1 ms pause (as client_test.cpp's Link).
  void step() {
    clock->advance(1);
    peer->poll();
    std::this_thread::sleep_for(1ms);
  }
  bool run_until(const std::function<bool()>& done, tether::Duration limit = 10000) {
    for (tether::Duration i = 0; i < limit && !done(); ++i) step();
    return done();
  }
  template <typename T>
  bool run_until_ready(std::future<T>& future) {
    return run_until([&] { return future.wait_for(0s) == std::future_status::ready; });
  }
  bool ready() {
    return run_until([&] { return arm->session().established; });
  }

  tether::transports::IoThread io;
  std::shared_ptr<tether::client::testing::ManualClock> clock;
  std::shared_ptr<ArmPeer> peer;
  std::optional<arm::ArmClient> arm;
};

arm::JointRequest joint_request(std::uint32_t joint, std::int32_t angle) {
  arm::JointRequest request;
  request.set_joint(joint);
  request.set_angle_cdeg(angle);
  return request;
}

TEST(RpcTypedClient, TheCompiledInSchemaIsTheFilesMethodsAndHash) {
  const Schema compiled(arm::ArmClient::descriptor());
  const Schema loaded = Schema::load(kSchemas + "/arm.proto");
  EXPECT_EQ(compiled.hash(), loaded.hash());
  EXPECT_EQ(arm::ArmClient::kSchemaHash, loaded.hash());
  EXPECT_TRUE(compiled.compiled_in());
  EXPECT_FALSE(loaded.compiled_in());
  EXPECT_EQ(compiled.file(), "arm.proto");
  EXPECT_EQ(&compiled.pool(), google::protobuf::DescriptorPool::generated_pool());
  ASSERT_EQ(compiled.methods().size(), loaded.methods().size());
  for (std::size_t i = 0; i < compiled.methods().size(); ++i) {
    EXPECT_EQ(compiled.methods()[i].name, loaded.methods()[i].name);
    EXPECT_EQ(compiled.methods()[i].index, i);
    EXPECT_EQ(compiled.methods()[i].streaming, loaded.methods()[i].streaming);
    EXPECT_EQ(compiled.methods()[i].input->full_name(), loaded.methods()[i].input->full_name());
  }
  EXPECT_EQ(compiled.methods()[0].input, arm::JointRequest::descriptor());
  EXPECT_EQ(compiled.methods()[1].output, arm::State::descriptor());
}

TEST(RpcTypedClient, TheCompiledInSchemaRefusesWhatTheLoaderRefuses) {
  // google.protobuf's own compiled-in files: proto2 ones (descriptor.proto) have no service; build a
  // proto3 service with client streaming in a pool of its own to show the same check runs.
  google::protobuf::DescriptorPool pool;
  google::protobuf::FileDescriptorProto file;
  file.set_name("stream.proto");
  file.set_syntax("proto3");
  file.set_package("up");
  file.add_message_type()->set_name("Chunk");
  auto* service = file.add_service();
  service->set_name("Upload");
  auto* method = service->add_method();
  method->set_name("Send");
  method->set_input_type(".up.Chunk");
  method->set_output_type(".up.Chunk");
  method->set_client_streaming(true);
  const google::protobuf::FileDescriptor* built = pool.BuildFile(file);
  ASSERT_NE(built, nullptr);
  try {
    const Schema schema(*built->service(0));
    ADD_FAILURE() << "no exception";
  } catch (const tether::rpc::SchemaError& e) {
    EXPECT_STREQ(e.what(), "stream.proto: Upload.Send: client streaming is not carried (a method is a call or a server stream)");
  }
}

TEST(RpcTypedClient, CallsTakeAndReturnProtocsClasses) {
  TypedLink link;
  ASSERT_TRUE(link.ready());
  // Blocking, on another thread while time runs here.
  std::optional<arm::JointReply> blocking;
  std::thread caller([&] { blocking = link.arm->MoveJoint(joint_request(2, -4500)); });
  ASSERT_TRUE(link.run_until([&] { return link.peer->moves() == 1; }));
  caller.join();
  ASSERT_TRUE(blocking);
  EXPECT_EQ(blocking->reached_cdeg(), -4501);

  // Asynchronous with a handler, then with asio's use_future.
  std::promise<std::pair<tether::rpc::error_code, arm::JointReply>> done;
  auto future = done.get_future();
  link.arm->async_MoveJoint(joint_request(1, 300), [&](tether::rpc::error_code error, arm::JointReply reply) {
    done.set_value({error, std::move(reply)});
  });
  ASSERT_TRUE(link.run_until_ready(future));
  const auto [error, reply] = future.get();
  ASSERT_FALSE(error) << error.message();
  EXPECT_EQ(reply.reached_cdeg(), 299);

  std::future<arm::JointReply> awaited = link.arm->async_MoveJoint(joint_request(3, 10), boost::asio::use_future);
  ASSERT_TRUE(link.run_until_ready(awaited));
  EXPECT_EQ(awaited.get().reached_cdeg(), 9);
  EXPECT_EQ(link.peer->moves(), 3);
  EXPECT_EQ(link.arm->counters().replies, 3u);
}

TEST(RpcTypedClient, AReplyIsProtocsClassItselfNotAParsedCopy) {
  TypedLink link;
  ASSERT_TRUE(link.ready());
  std::promise<tether::rpc::CallResult> done;
  auto future = done.get_future();
  link.arm->dynamic().async_call("MoveJoint", joint_request(2, 100),
                                 [&](tether::rpc::error_code, tether::rpc::CallResult result) { done.set_value(std::move(result)); });
  ASSERT_TRUE(link.run_until_ready(future));
  const tether::rpc::CallResult result = future.get();
  ASSERT_NE(result.reply, nullptr);
  const auto* typed = dynamic_cast<const arm::JointReply*>(result.reply.get());
  ASSERT_NE(typed, nullptr) << "the reply is a " << typeid(*result.reply).name();
  EXPECT_EQ(typed->reached_cdeg(), 99);
}

TEST(RpcTypedClient, TypedFormsOfAClientWhoseSchemaIsReadFromTheFileCopyThroughBytes) {
  tether::transports::IoThread io;
  auto clock = tether::client::testing::ManualClock::create();
  auto [host_end, device_end] = tether::transports::InMemoryStream::make_pair(io.executor());
  auto peer = ArmPeer::start(device_end, arm::ArmClient::kSchemaHash, clock);
  peer->boot(7);
  tether::rpc::Client client(host_end, Schema::load(kSchemas + "/arm.proto"), typed_test_options(clock));
  std::future<arm::JointReply> reply = client.async_call_as<arm::JointReply>("MoveJoint", joint_request(1, 50),
                                                                             boost::asio::use_future);
  for (int i = 0; i < 10000 && reply.wait_for(0s) != std::future_status::ready; ++i) {
    clock->advance(1);
    peer->poll();
    std::this_thread::sleep_for(1ms);
  }
  ASSERT_EQ(reply.wait_for(0s), std::future_status::ready);
  EXPECT_EQ(reply.get().reached_cdeg(), 49);
  client.close();
  peer->close();
}

TEST(RpcTypedClient, ADeviceErrorThrowsWithItsCodeAndTextOrComesAsTheErrorCode) {
  TypedLink link;
  ASSERT_TRUE(link.ready());
  link.peer->fail_moves(42, "joint 3 is locked");
  std::optional<tether::rpc::CallError> thrown;
  std::thread caller([&] {
    try {
      (void)link.arm->MoveJoint(joint_request(3, 0));
    } catch (const tether::rpc::CallError& e) {
      thrown.emplace(e);
    }
  });
  ASSERT_TRUE(link.run_until([&] { return link.peer->moves() == 1; }));
  caller.join();
  ASSERT_TRUE(thrown);
  EXPECT_STREQ(thrown->what(), "MoveJoint: device error 42: joint 3 is locked");
  EXPECT_EQ(thrown->device_error().code, 42);

  tether::rpc::error_code error;
  arm::JointReply reply;
  reply.set_reached_cdeg(5);
  std::thread quiet([&] { reply = link.arm->MoveJoint(joint_request(3, 0), error); });
  ASSERT_TRUE(link.run_until([&] { return link.peer->moves() == 2; }));
  quiet.join();
  EXPECT_EQ(error, RpcError::device_error);
  EXPECT_EQ(reply.reached_cdeg(), 0);  // empty

  std::future<arm::JointReply> awaited = link.arm->async_MoveJoint(joint_request(3, 0), boost::asio::use_future);
  ASSERT_TRUE(link.run_until_ready(awaited));
  try {
    (void)awaited.get();
    ADD_FAILURE() << "no exception";
  } catch (const boost::system::system_error& e) {
    EXPECT_EQ(e.code(), RpcError::device_error);
  }
}

TEST(RpcTypedClient, AStreamHandsProtocsClassToItsHandlerUntilClosed) {
  TypedLink link;
  ASSERT_TRUE(link.ready());
  std::mutex mutex;
  std::vector<std::int32_t> firsts;
  std::vector<int> sizes;
  tether::rpc::Stream watch = link.arm->Watch(
      arm::StateRequest(), 100ms, [&](const tether::rpc::error_code& error, const arm::State& state) {
        ASSERT_FALSE(error) << error.message();
        const std::lock_guard<std::mutex> lock(mutex);
        sizes.push_back(state.angles_cdeg_size());
        firsts.push_back(state.angles_cdeg_size() > 0 ? state.angles_cdeg(0) : -1);
      });
  ASSERT_TRUE(link.run_until([&] {
    const std::lock_guard<std::mutex> lock(mutex);
    return firsts.size() >= 3;
  }));
  {
    const std::lock_guard<std::mutex> lock(mutex);
    EXPECT_EQ(sizes[0], 2);
    EXPECT_EQ(firsts[2], 3);  // [watches, -watches]
  }
  watch.close();
  EXPECT_FALSE(watch.is_open());
  ASSERT_TRUE(link.run_until([&] { return link.peer->open_streams() == 0; }));
}

TEST(RpcTypedClient, AStreamsEndComesWithAnEmptyMessage) {
  TypedLink link;
  ASSERT_TRUE(link.ready());
  std::promise<std::pair<tether::rpc::error_code, int>> ended;
  std::atomic<bool> set{false};
  tether::rpc::Stream watch = link.arm->Watch(
      arm::StateRequest(), 100ms, [&](const tether::rpc::error_code& error, const arm::State& state) {
        if (error && !set.exchange(true)) ended.set_value({error, state.angles_cdeg_size()});
      });
  link.arm->close();
  auto future = ended.get_future();
  ASSERT_EQ(future.wait_for(5s), std::future_status::ready);
  const auto [error, size] = future.get();
  EXPECT_EQ(error, boost::asio::error::operation_aborted);
  EXPECT_EQ(size, 0);
}

TEST(RpcTypedClient, ADeviceOfAnotherSchemaIsRefusedNamingBothHashes) {
  TypedLink link(0x1234);
  ASSERT_TRUE(link.run_until([&] { return link.arm->session().device_hash.has_value(); }));
  try {
    link.arm->wait_ready();  // at once: the device's hello came
    ADD_FAILURE() << "no exception";
  } catch (const boost::system::system_error& e) {
    EXPECT_EQ(e.code(), RpcError::schema_mismatch);
    EXPECT_NE(std::string(e.what()).find("0x0000000000001234"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find(tether::rpc::format_hash(arm::ArmClient::kSchemaHash)), std::string::npos)
        << e.what();
  }
}

}  // namespace
