// arm-client FIRMWARE_DIR: the typed client of arm.proto (arm::ArmClient, from tether_generate_rpc), built
// against an install prefix. Prints one line per step; exit status 0 when every step gave what it should.
//   offline: over an in-memory stream with no device, the client is made from its compiled-in schema and
//            a call completes (with queue_timeout: nobody answers the Hello);
//   device:  on a virtual Uno running the example's image (rpc-example.elf): a move (blocking, then with
//            asio's use_future), a move the device refuses, Describe, three messages of the Watch stream.
//            An image that never answers the Hello is reported as such (`device: no hello`).
#include <boost/asio.hpp>

#include <condition_variable>
#include <filesystem>
#include <iostream>
#include <mutex>
#include <string>

#include "arm.tether.hpp"
#include <tether/transports/in_memory_stream.hpp>
#include <tether/transports/io_thread.hpp>
#include <tether/transports/virtual_uno_stream.hpp>

namespace {

arm::JointRequest move(std::uint32_t joint, std::int32_t angle) {
  arm::JointRequest request;
  request.set_joint(joint);
  request.set_angle_cdeg(angle);
  return request;
}

bool offline(tether::transports::IoThread& io) {
  auto [host_end, device_end] = tether::transports::InMemoryStream::make_pair(io.executor());
  tether::rpc::Options options;
  options.timing.queue_timeout = 300;
  arm::ArmClient arm(host_end, options);
  const bool compiled_in = arm.dynamic().schema().compiled_in() &&
                           arm.dynamic().schema().hash() == arm::ArmClient::kSchemaHash;
  try {
    (void)arm.async_MoveJoint(move(2, 100), boost::asio::use_future).get();
    std::cout << "offline: MoveJoint answered without a device\n";
    return false;
  } catch (const boost::system::system_error& e) {
    std::cout << "offline: compiled-in schema " << tether::rpc::format_hash(arm::ArmClient::kSchemaHash)
              << (compiled_in ? "" : " (NOT compiled in)") << ", MoveJoint completed: " << e.code().message() << "\n";
    const bool ok = compiled_in && e.code() == tether::rpc::RpcError::queue_timeout;
    if (ok) std::cout << "offline: ok\n";
    return ok;
  }
}

bool on_device(tether::transports::IoThread& io, const std::filesystem::path& images) {
  tether::transports::VirtualUnoOptions board;
  board.firmware = images / "rpc-example.elf";
  arm::ArmClient arm(tether::transports::VirtualUnoStream::open(io.executor(), board));
  tether::rpc::error_code ready;
  arm.wait_ready(ready);
  if (ready == tether::rpc::RpcError::queue_timeout && !arm.session().device_hash) {
    std::cout << "device: no hello from " << board.firmware.string() << " (" << arm.counters().hellos_sent
              << " hellos sent)\n";
    return false;
  }
  if (ready) {
    std::cout << "device: " << ready.message() << "\n";
    return false;
  }
  bool ok = true;
  std::cout << "device: session " << *arm.session().session_id << "\n";

  const arm::JointReply reached = arm.MoveJoint(move(2, -4500));
  std::cout << "MoveJoint(2, -4500): reached " << reached.reached_cdeg() << "\n";
  ok = ok && reached.reached_cdeg() == -4500;

  const arm::JointReply later = arm.async_MoveJoint(move(1, 900), boost::asio::use_future).get();
  std::cout << "async_MoveJoint(1, 900): reached " << later.reached_cdeg() << "\n";
  ok = ok && later.reached_cdeg() == 900;

  try {
    (void)arm.MoveJoint(move(9, 0));
    std::cout << "MoveJoint(9, 0): no error\n";
    ok = false;
  } catch (const tether::rpc::CallError& e) {
    std::cout << "MoveJoint(9, 0): " << e.what() << "\n";
    ok = ok && e.device_error().code == 1;
  }

  const arm::Description description = arm.Describe(arm::DescribeRequest());
  std::cout << "Describe: " << description.name() << ", " << description.joints() << " joints, "
            << description.moves() << " moves\n";
  ok = ok && description.name() == "tether-arm" && description.moves() == 2;

  std::mutex mutex;
  std::condition_variable changed;
  int states = 0;
  std::int32_t joint2 = 0;
  tether::rpc::Stream watch = arm.Watch(arm::StateRequest(), std::chrono::milliseconds(50),
                                        [&](const tether::rpc::error_code& error, const arm::State& state) {
                                          if (error || state.angles_cdeg_size() < 3) return;
                                          const std::lock_guard<std::mutex> lock(mutex);
                                          ++states;
                                          joint2 = state.angles_cdeg(2);
                                          changed.notify_all();
                                        });
  {
    std::unique_lock<std::mutex> lock(mutex);
    const bool watched = changed.wait_for(lock, std::chrono::seconds(20), [&] { return states >= 3; });
    std::cout << "Watch: " << states << " states, joint 2 at " << joint2 << "\n";
    ok = ok && watched && joint2 == -4500;
  }
  watch.close();
  arm.close();
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: arm-client FIRMWARE_DIR\n";
    return 2;
  }
  tether::transports::IoThread io;
  bool ok = false;
  try {
    ok = offline(io);
    ok = on_device(io, argv[1]) && ok;
  } catch (const std::exception& e) {
    std::cout << "failed: " << e.what() << "\n";
    ok = false;
  }
  return ok ? 0 : 1;
}
