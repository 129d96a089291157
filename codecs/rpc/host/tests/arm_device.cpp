// The arm device for the client tests: see arm_device.hpp.
#include "arm_device.hpp"

#include <optional>
#include <stdexcept>

#include "ArmRpc_service.h"

namespace tether::rpc::testing {
namespace {

struct Application {
  int moves = 0;
  std::int32_t last_angle = 0;
  int watches = 0;
  std::uint16_t fail_code = 0;
  std::string fail_text;
  Millis now = 0;
};
Application* app = nullptr;  // the one device of a test (handlers are plain functions)

}  // namespace
}  // namespace tether::rpc::testing

// The handlers, as an application defines them for the generated service.
tether::rpc::Status Arm_MoveJoint(const arm_JointRequest& request, arm_JointReply& reply) {
  using tether::rpc::testing::app;
  ++app->moves;
  app->last_angle = request.angle_cdeg;
  if (app->fail_code != 0) return tether::rpc::Status::error(app->fail_code, app->fail_text.c_str());
  reply.reached_cdeg = request.angle_cdeg - 1;
  return tether::rpc::Status::ok();
}

tether::rpc::Status Arm_Watch(const arm_StateRequest&, arm_State& next) {
  using tether::rpc::testing::app;
  ++app->watches;
  next.angles_cdeg_count = 2;
  next.angles_cdeg[0] = app->watches;
  next.angles_cdeg[1] = -app->watches;
  next.millis = app->now;
  return tether::rpc::Status::ok();
}

namespace tether::rpc::testing {

struct ArmDevice::State {
  Application application;
  device::Service service{};  // the generated one, with the hash the test asks for
  std::function<void(std::string)> output;
  std::optional<ArmRpcService::Device> runtime;

  static void write(void* self, ByteView frame) {
    static_cast<State*>(self)->output(std::string(reinterpret_cast<const char*>(frame.data()), frame.size()));
  }
};

ArmDevice::ArmDevice(std::uint64_t schema_hash, std::function<void(std::string)> output)
    : state_(std::make_unique<State>()) {
  if (app != nullptr) throw std::logic_error("one ArmDevice at a time");
  app = &state_->application;
  state_->service = ArmRpcService::service();
  state_->service.schema_hash = schema_hash;
  state_->output = std::move(output);
}

ArmDevice::~ArmDevice() { app = nullptr; }

void ArmDevice::boot(std::uint32_t session, Millis now) {
  state_->runtime.reset();
  state_->runtime.emplace(state_->service, device::FrameSink{&State::write, state_.get()});
  state_->runtime->begin(session, now);
}

void ArmDevice::feed(const std::uint8_t* data, std::size_t size, Millis now) {
  state_->application.now = now;
  std::size_t used = 0;
  while (used < size) used += state_->runtime->handle_bytes(ByteView(data + used, size - used), now);
}

void ArmDevice::poll(Millis now) {
  state_->application.now = now;
  state_->runtime->poll(now);
}

void ArmDevice::fail_moves(std::uint16_t code, std::string text) {
  state_->application.fail_code = code;
  state_->application.fail_text = std::move(text);
}
int ArmDevice::moves() const { return state_->application.moves; }
std::int32_t ArmDevice::last_angle() const { return state_->application.last_angle; }
int ArmDevice::watches() const { return state_->application.watches; }
std::uint32_t ArmDevice::duplicates() const { return state_->runtime->counters().link.duplicates; }
std::uint32_t ArmDevice::refused() const { return state_->runtime->counters().refused; }
std::uint32_t ArmDevice::stream_messages() const { return state_->runtime->counters().stream_messages; }
int ArmDevice::open_streams() const { return state_->runtime->open_streams(); }

}  // namespace tether::rpc::testing
