// The arm device for the client tests: see arm_device.hpp.
#include "arm_device.hpp"

#include <optional>
#include <stdexcept>

#include "arm.pb.h"
#include "tether/rpc/device/rpc_device.hpp"

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

Status move_joint(const void* request, void* reply) {
  const auto& in = *static_cast<const arm_JointRequest*>(request);
  ++app->moves;
  app->last_angle = in.angle_cdeg;
  if (app->fail_code != 0) return Status::error(app->fail_code, app->fail_text.c_str());
  static_cast<arm_JointReply*>(reply)->reached_cdeg = in.angle_cdeg - 1;
  return Status::ok();
}

Status watch(const void*, void* reply) {
  auto& out = *static_cast<arm_State*>(reply);
  ++app->watches;
  out.angles_cdeg_count = 2;
  out.angles_cdeg[0] = app->watches;
  out.angles_cdeg[1] = -app->watches;
  out.millis = app->now;
  return Status::ok();
}

const device::Method kMethods[] = {
    {arm_JointRequest_fields, arm_JointReply_fields, &move_joint, false},
    {arm_StateRequest_fields, arm_State_fields, &watch, true},
};
union Requests {
  arm_JointRequest move;
  arm_StateRequest watch;
};
union Replies {
  arm_JointReply move;
  arm_State watch;
};

}  // namespace

struct ArmDevice::State {
  Application application;
  Requests requests;
  Replies replies;
  device::Service service{};
  std::function<void(std::string)> output;
  std::optional<device::Device<>> runtime;

  static void write(void* self, ByteView frame) {
    static_cast<State*>(self)->output(std::string(reinterpret_cast<const char*>(frame.data()), frame.size()));
  }
};

ArmDevice::ArmDevice(std::uint64_t schema_hash, std::function<void(std::string)> output)
    : state_(std::make_unique<State>()) {
  if (app != nullptr) throw std::logic_error("one ArmDevice at a time");
  app = &state_->application;
  state_->service = device::Service{schema_hash, kMethods, 2, &state_->requests, sizeof state_->requests,
                                    &state_->replies, sizeof state_->replies};
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
