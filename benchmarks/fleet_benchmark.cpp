// One host io_context thread drives 16 in-memory fake devices (8 Romi, 4 proxy, 4 Elcano rings), each
// called at 100 requests/s, and reports the host thread's CPU per call and the calls' latency
// percentiles. The fake devices run on a second thread (their end of each in-memory pair completes on
// its own io_context), so the host figure holds the clients, their timers and the in-memory link only.
//
//   tether_fleet_benchmark [seconds=10] [rate_per_device=100]
//
// Romi: `e` answered `[0,1,2]`. Proxy (primary mode): `servo(9).set(90)` acknowledged (the handshake's
// Reset answered with a ResetEvent). Elcano: a goal `G{n 1}{b 90}{p 100,200}` answered by the ring with a
// segment (`async_request(goal, Type::segment)`). Latency: from starting the call to its completion
// handler, both on the host thread. A call still in flight when its device's next tick comes is not
// started again (counted as `skipped`), so the load never exceeds the rate.
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>

#include <sys/resource.h>
#include <time.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <deque>
#include <functional>
#include <future>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "tether/elcano/client.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/elcano/encoder.hpp"
#include "tether/proxy/client.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/romi/client.hpp"
#include "tether/romi/decoder.hpp"
#include "tether/romi/encoder.hpp"
#include "fleet.hpp"
#include "tether/transports/in_memory_stream.hpp"
#include "tether_proxy.pb.h"

namespace {

namespace asio = boost::asio;
using namespace tether;
using namespace tether::fleet;
using transports::ByteStream;
using transports::InMemoryStream;

// --- fake devices (device thread) ----------------------------------------------------------------------

class RomiDevice final : public FakeDevice {
 public:
  using FakeDevice::FakeDevice;

 private:
  void on_bytes(const std::uint8_t* data, std::size_t size) override {
    for (std::size_t i = 0; i < size; ++i) {
      if (decoder_.feed(data[i]) != DecodeStatus::frame) continue;
      const romi::Frame& frame = decoder_.frame();
      std::uint8_t out[64];
      const Result<size_t> answer = romi::encode_response(frame.opcode, ByteView::from_literal("[0,1,2]"), frame.id, out);
      if (answer.ok()) send(out, answer.value());
    }
  }
  LinkCounters counters_;
  romi::Decoder<romi::kDeviceDecoderCapacity> decoder_{counters_};
};

class ProxyDevice final : public FakeDevice {
 public:
  using FakeDevice::FakeDevice;

 private:
  void on_bytes(const std::uint8_t* data, std::size_t size) override {
    for (std::size_t i = 0; i < size; ++i) {
      if (decoder_.feed(data[i]) != DecodeStatus::frame) continue;
      const ByteView payload = decoder_.frame();
      proxy::ArduinoIn in;
      if (!in.ParseFromArray(payload.data(), static_cast<int>(payload.size()))) continue;
      proxy::ArduinoOut ack;
      ack.mutable_ack()->set_messageid(in.messageid());
      answer(ack);
      if (in.has_reset()) {
        proxy::ArduinoOut reset;
        reset.mutable_resetevent()->set_sessionid(++session_);
        answer(reset);
      }
    }
  }
  void answer(const proxy::ArduinoOut& message) {
    const std::string payload = message.SerializeAsString();
    std::uint8_t out[128];
    const Result<size_t> frame = proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()),
                                                     proxy::Integrity::crc16, false, out);
    if (frame.ok()) send(out, frame.value());
  }
  LinkCounters counters_;
  proxy::Decoder<512> decoder_{proxy::Integrity::crc16, counters_};
  std::uint32_t session_ = 100;
};

// The rest of the ring: every goal the host writes comes back as a segment with the goal's number.
class ElcanoRing final : public FakeDevice {
 public:
  using FakeDevice::FakeDevice;

 private:
  void on_bytes(const std::uint8_t* data, std::size_t size) override {
    for (std::size_t i = 0; i < size; ++i) {
      if (decoder_.feed(data[i]) != DecodeStatus::frame) continue;
      const elcano::Message& goal = decoder_.frame();
      if (goal.type != elcano::Type::goal) continue;
      const elcano::Message segment = elcano::Message::segment(goal.number, 160, 80, 3200, -64000);
      std::uint8_t out[96];
      const Result<size_t> bytes = elcano::encode_message(segment, elcano::Generation::b, out);
      if (bytes.ok()) send(out, bytes.value());
    }
  }
  LinkCounters counters_;
  elcano::Decoder<96> decoder_{elcano::Generation::b, counters_};
};

}  // namespace

int main(int argc, char** argv) {
  const double seconds = argc > 1 ? std::atof(argv[1]) : 10.0;
  const double rate = argc > 2 ? std::atof(argv[2]) : 100.0;
  if (!(seconds > 0) || !(rate > 0)) {
    std::fprintf(stderr, "usage: %s [seconds > 0] [requests per second per device > 0]\n", argv[0]);
    return 2;
  }
  constexpr int kRomi = 8;
  constexpr int kProxy = 4;
  constexpr int kElcano = 4;
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(1.0 / rate));

  asio::io_context host_io(1);
  asio::io_context device_io(1);

  std::vector<std::shared_ptr<FakeDevice>> devices;
  std::vector<std::shared_ptr<ByteStream>> host_ends;
  auto connect = [&](auto make_device) {
    auto [host_end, device_end] = InMemoryStream::make_pair(host_io.get_executor(), device_io.get_executor());
    std::shared_ptr<FakeDevice> device = make_device(std::shared_ptr<ByteStream>(device_end));
    device->start();
    devices.push_back(device);
    host_ends.push_back(host_end);
    return std::shared_ptr<ByteStream>(host_end);
  };

  std::vector<std::unique_ptr<romi::Client>> romi_clients;
  std::vector<std::unique_ptr<proxy::Client>> proxy_clients;
  std::vector<std::unique_ptr<elcano::RingClient>> elcano_clients;
  for (int i = 0; i < kRomi; ++i) {
    romi_clients.push_back(std::make_unique<romi::Client>(
        connect([](std::shared_ptr<ByteStream> end) { return std::make_shared<RomiDevice>(std::move(end)); })));
  }
  for (int i = 0; i < kProxy; ++i) {
    proxy_clients.push_back(std::make_unique<proxy::Client>(
        connect([](std::shared_ptr<ByteStream> end) { return std::make_shared<ProxyDevice>(std::move(end)); })));
  }
  for (int i = 0; i < kElcano; ++i) {
    elcano_clients.push_back(std::make_unique<elcano::RingClient>(
        connect([](std::shared_ptr<ByteStream> end) { return std::make_shared<ElcanoRing>(std::move(end)); })));
  }

  Tally romi_tally;
  Tally proxy_tally;
  Tally elcano_tally;
  std::vector<std::unique_ptr<Caller>> callers;
  for (auto& client : romi_clients) {
    callers.push_back(std::make_unique<Caller>(host_io, period, [c = client.get()](std::function<void(bool)> done) {
      c->async_call("e", [done = std::move(done)](romi::error_code error, romi::RomiResponse response) {
        done(!error && response.ok() && response.values.size() == 3);
      });
    }, romi_tally));
  }
  for (auto& client : proxy_clients) {
    callers.push_back(std::make_unique<Caller>(host_io, period, [c = client.get()](std::function<void(bool)> done) {
      c->servo(9).async_set(90, [done = std::move(done)](proxy::error_code error, proxy::SendResult result) {
        done(!error && result.acked);
      });
    }, proxy_tally));
  }
  std::int32_t goal_number = 0;
  for (auto& client : elcano_clients) {
    callers.push_back(std::make_unique<Caller>(host_io, period, [c = client.get(), &goal_number](std::function<void(bool)> done) {
      const elcano::Message goal = elcano::Message::goal(++goal_number % 1000, 90, 100, 200);
      c->async_request(goal, elcano::Type::segment,
                       [done = std::move(done), number = goal.number](elcano::error_code error, elcano::Message reply) {
                         done(!error && reply.number == number);
                       });
    }, elcano_tally));
  }

  const FleetRun run = run_fleet(host_io, device_io, callers, period, seconds, nullptr, [&] {
    for (auto& c : romi_clients) c->close();
    for (auto& c : proxy_clients) c->close();
    for (auto& c : elcano_clients) c->close();
    for (auto& d : devices) d->close();
  });

  const std::uint64_t calls = romi_tally.calls + proxy_tally.calls + elcano_tally.calls;
  Tally all;
  for (const Tally* tally : {&romi_tally, &proxy_tally, &elcano_tally}) {
    all.latencies_us.insert(all.latencies_us.end(), tally->latencies_us.begin(), tally->latencies_us.end());
    all.calls += tally->calls;
    all.errors += tally->errors;
    all.skipped += tally->skipped;
  }
  std::printf("fleet: 16 devices (8 romi, 4 proxy, 4 elcano) at %.0f requests/s each for %.1f s, one host thread\n",
              rate, seconds);
  print_cpu(run, calls, seconds);
  print("romi", romi_tally);
  print("proxy", proxy_tally);
  print("elcano", elcano_tally);
  print("all", all);
  return all.errors == 0 && all.calls > 0 ? 0 : 1;
}
