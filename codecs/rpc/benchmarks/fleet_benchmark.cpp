// One host io_context thread drives 16 rpc devices over in-memory links, each called at 100 MoveJoint
// calls/s through the typed client (arm::ArmClient, tether_generate_rpc on examples/rpc/arm.proto), and
// reports the host thread's CPU per call and the calls' latency percentiles. The fake devices run on a second
// thread with its own io_context, so the host figure holds the clients, their timers and the link only.
//
//   tether_rpc_fleet_benchmark [seconds=10] [rate_per_device=100] [devices=16]
//
// A call counts as good when it completed without error and the reply is the device's (`reached_cdeg =
// angle_cdeg - 1`). The harness (callers, tallies, CPU readings) is benchmarks/fleet.hpp's.
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "arm.tether.hpp"
#include "fleet.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/device_message.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/rpc/client.hpp"
#include "tether/transports/in_memory_stream.hpp"
#include "tether_rpc.pb.h"

namespace {

namespace asio = boost::asio;
using namespace tether;
using namespace tether::fleet;
using transports::ByteStream;
using transports::InMemoryStream;

// A fake arm device (device thread only): answers the Hello with arm.proto's hash and each MoveJoint call
// with its Reply (`reached_cdeg = angle_cdeg - 1`), then the Ack, in the device runtime's order. Built from
// libprotobuf's classes of the envelope: the device's CPU is not what is measured.
class RpcDevice final : public FakeDevice {
 public:
  RpcDevice(std::shared_ptr<ByteStream> end, std::uint32_t session) : FakeDevice(std::move(end)), session_(session) {}

 private:
  void on_bytes(const std::uint8_t* data, std::size_t size) override {
    ByteView input(data, size);
    while (!input.empty()) {
      const FeedResult fed = decoder_.feed(input);
      input = ByteView(input.data() + fed.consumed, input.size() - fed.consumed);
      if (fed.status != DecodeStatus::frame) continue;
      rpc::wire::HostMessage in;
      if (!proxy::parse_device_message(in, decoder_.frame())) continue;
      rpc::wire::DeviceMessage answer;
      if (in.has_hello()) {
        answer.mutable_hello()->set_schema_hash(arm::ArmClient::kSchemaHash);
        answer.mutable_hello()->set_session(session_);
        answer.mutable_hello()->set_max_payload(64);
        answer.mutable_hello()->set_methods(4);
        send_message(answer);
      } else if (in.has_call()) {
        arm::JointRequest request;
        arm::JointReply reply;
        request.ParseFromString(in.call().request());
        reply.set_reached_cdeg(request.angle_cdeg() - 1);
        answer.mutable_reply()->set_call(in.id());
        answer.mutable_reply()->set_reply(reply.SerializeAsString());
        send_message(answer);
      }
      rpc::wire::DeviceMessage ack;
      ack.mutable_ack()->set_id(in.id());
      send_message(ack);
    }
  }
  void send_message(const rpc::wire::DeviceMessage& message) {
    const std::string payload = message.SerializeAsString();
    std::uint8_t out[160];
    const Result<size_t> frame = proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()),
                                                     proxy::Integrity::crc16, true, out);
    if (frame.ok()) send(out, frame.value());
  }

  LinkCounters counters_;
  proxy::Decoder<rpc::kMaxPayload> decoder_{proxy::Integrity::crc16, counters_};
  std::uint32_t session_;
};

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
  const double rate = argc > 2 ? std::atof(argv[2]) : 100.0;
  const int count = argc > 3 ? std::atoi(argv[3]) : 16;
  if (!(seconds > 0) || !(rate > 0) || count < 1 || count > 256) {
    std::fprintf(stderr, "usage: %s [seconds > 0] [calls per second per device > 0] [devices 1..256]\n", argv[0]);
    return 2;
  }
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));

  asio::io_context host_io(1);
  asio::io_context device_io(1);

  std::vector<std::shared_ptr<RpcDevice>> devices;
  std::vector<std::unique_ptr<arm::ArmClient>> clients;
  for (int i = 0; i < count; ++i) {
    auto [host_end, device_end] = InMemoryStream::make_pair(host_io.get_executor(), device_io.get_executor());
    auto device = std::make_shared<RpcDevice>(std::shared_ptr<ByteStream>(device_end),
                                              static_cast<std::uint32_t>(0x1000 + i));
    asio::post(device_io, [device] { device->start(); });
    devices.push_back(device);
    clients.push_back(std::make_unique<arm::ArmClient>(std::shared_ptr<ByteStream>(host_end)));
  }

  Tally tally;
  std::vector<std::unique_ptr<Caller>> callers;
  std::int32_t angle = 0;
  for (auto& client : clients) {
    callers.push_back(std::make_unique<Caller>(host_io, period, [c = client.get(), &angle](std::function<void(bool)> done) {
      arm::JointRequest request;
      request.set_joint(2);
      request.set_angle_cdeg(angle = (angle + 1) % 9000);
      const std::int32_t expected = request.angle_cdeg() - 1;
      c->async_MoveJoint(request, [done = std::move(done), expected](rpc::error_code error, arm::JointReply reply) {
        done(!error && reply.reached_cdeg() == expected);
      });
    }, tally));
  }

  std::size_t ready = 0;
  const FleetRun run = run_fleet(
      host_io, device_io, callers, period, seconds,
      [&] {
        for (auto& c : clients) {
          if (c->session().established) ++ready;
        }
      },
      [&] {
        for (auto& c : clients) c->close();
        for (auto& d : devices) d->close();
      });

  std::printf("rpc fleet: %d devices (arm, MoveJoint through arm::ArmClient) at %.0f calls/s each for %.1f s, "
              "one host thread; %zu of %d ready after the warm-up second\n",
              count, rate, seconds, ready, count);
  print_cpu(run, tally.calls, seconds);
  print("rpc", tally);
  return tally.errors == 0 && tally.calls > 0 ? 0 : 1;
}
