// A robot program on its own schema: arm.proto's typed client (arm::ArmClient, from tether_generate_rpc)
// driving the arm on an Arduino: a move, the same move with asio's use_future, a move the device refuses,
// a range change, the arm's description, and three states of the Watch stream.
//
//   arm-client --port /dev/ttyACM0      an Uno running the example's sketch (2 s for its boot on open)
//   arm-client --virtual rpc-example.elf  the example's image on a virtual Uno (a Tether built with it)
//
// Exit status 0 when every answer was what the example device gives, 1 otherwise, 2 for bad arguments.
#include <boost/asio.hpp>

#include <condition_variable>
#include <iostream>
#include <mutex>
#include <string>

#include "arm.tether.hpp"
#include <tether/transports/io_thread.hpp>
#include <tether/transports/serial_port_stream.hpp>
#ifdef ARM_CLIENT_VIRTUAL_UNO
#include <tether/transports/virtual_uno_stream.hpp>
#endif

namespace {

arm::JointRequest move(std::uint32_t joint, std::int32_t angle) {
  arm::JointRequest request;
  request.set_joint(joint);
  request.set_angle_cdeg(angle);
  return request;
}

bool run(arm::ArmClient& arm) {
  arm.wait_ready();  // the device answered the Hello with arm.proto's hash (else: an exception naming both)
  std::cout << "session " << *arm.session().session_id << "\n";
  bool ok = true;

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
  } catch (const tether::rpc::CallError& e) {  // the device's code and text
    std::cout << "MoveJoint(9, 0): device error " << e.device_error().code << ": " << e.device_error().text << "\n";
    ok = ok && e.device_error().code == 1;
  }

  arm::ModeRequest mode;
  mode.set_mode(arm::MODE_ACTIVE);
  mode.mutable_range()->set_min_cdeg(-9000);
  mode.mutable_range()->set_max_cdeg(9000);
  const arm::ModeReply previous = arm.SetMode(mode);
  std::cout << "SetMode(ACTIVE, -9000..9000): was " << arm::Mode_Name(previous.previous()) << "\n";

  const arm::Description description = arm.Describe(arm::DescribeRequest());
  std::cout << "Describe: " << description.name() << ", " << description.joints() << " joints, "
            << description.min_cdeg() << ".." << description.max_cdeg() << ", " << description.moves()
            << " moves\n";
  ok = ok && description.min_cdeg() == -9000 && description.max_cdeg() == 9000;

  // Telemetry: the device sends a State every 50 ms while the stream is open; the handler runs on the
  // client's thread.
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
  watch.close();  // or let it go out of scope
  return ok;
}

}  // namespace

int main(int argc, char** argv) {
  const std::string usage = "usage: arm-client --port PATH | --virtual FIRMWARE.elf\n";
  if (argc != 3) {
    std::cerr << usage;
    return 2;
  }
  const std::string how = argv[1];
  tether::transports::IoThread io;  // one thread runs the client's I/O
  try {
    std::shared_ptr<tether::transports::ByteStream> stream;
    if (how == "--port") {
      stream = tether::transports::SerialPortStream::open(io.executor(), argv[2],
                                                          tether::transports::SerialOptions::arduino_uno());
#ifdef ARM_CLIENT_VIRTUAL_UNO
    } else if (how == "--virtual") {
      tether::transports::VirtualUnoOptions board;
      board.firmware = argv[2];
      stream = tether::transports::VirtualUnoStream::open(io.executor(), board);
#endif
    } else {
      std::cerr << usage;
      return 2;
    }
    arm::ArmClient arm(stream);
    const bool ok = run(arm);
    arm.close();
    return ok ? 0 : 1;
  } catch (const std::exception& e) {
    std::cerr << "arm-client: " << e.what() << "\n";
    return 1;
  }
}
