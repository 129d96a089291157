// The rpc codec's workloads for `tether demo` and `tether bench` (tools/demo/include/tether/demo/workload.hpp),
// on a device of the example's schema (examples/rpc/arm.proto, the `rpc-example` image): the servo workload
// is a `MoveJoint` call answered with the angle reached, the sensor workload a `Describe` call.
#include <google/protobuf/descriptor.h>
#include <google/protobuf/message.h>

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "tether/core/execution_witness.hpp"
#include "tether/demo/workload.hpp"
#include "tether/rpc/plugin.hpp"

namespace tether::demo {

namespace {

namespace pb = google::protobuf;
using error_code = boost::system::error_code;

// The field `name` of `message`'s type, or null.
const pb::FieldDescriptor* field_of(const pb::Message& message, const char* name) {
  return message.GetDescriptor()->FindFieldByName(name);
}

// Why the device's schema cannot run the workloads (empty: it can): they need the example's methods.
std::string missing_methods(const rpc::Client& client) {
  const rpc::Method* move = client.schema().find("MoveJoint");
  const rpc::Method* describe = client.schema().find("Describe");
  if (move == nullptr || move->streaming || describe == nullptr || describe->streaming) {
    return "its schema has no unary MoveJoint and Describe (the workloads are examples/rpc/arm.proto's)";
  }
  const pb::Descriptor& request = *move->input;
  const pb::Descriptor& reply = *move->output;
  if (request.FindFieldByName("joint") == nullptr || request.FindFieldByName("angle_cdeg") == nullptr ||
      reply.FindFieldByName("reached_cdeg") == nullptr || describe->output->FindFieldByName("joints") == nullptr) {
    return "its MoveJoint or Describe is not examples/rpc/arm.proto's";
  }
  return {};
}

// MoveJoint{joint, angle_cdeg} -> JointReply{reached_cdeg}: the reply is the angle the device reached, and
// the device's witness key is (joint, angle).
class MoveJointWorkload final : public Workload {
 public:
  MoveJointWorkload(std::shared_ptr<rpc::Client> client, Payload payload)
      : client_(std::move(client)), payload_(payload) {}
  std::string operation() const override {
    return std::string("call MoveJoint{joint, angle_cdeg") + (payload_ == Payload::large ? " (3-byte varints)" : "") +
           "} -> JointReply + Ack";
  }
  Outcome run(unsigned i) override {
    Outcome outcome;
    const auto joint = static_cast<std::uint32_t>(i % 4u);
    // Different from one operation to the next; small: one-byte varints, large: the widest angles.
    const std::int32_t angle = payload_ == Payload::small ? static_cast<std::int32_t>((i * 37u) % 64u)
                               : payload_ == Payload::large
                                   ? static_cast<std::int32_t>((i * 7919u) % 32000u) - 16000
                                   : static_cast<std::int32_t>((i * 131u) % 9000u) - 4500;
    const std::shared_ptr<pb::Message> request = client_->new_request("MoveJoint");
    request->GetReflection()->SetUInt32(request.get(), field_of(*request, "joint"), joint);
    request->GetReflection()->SetInt32(request.get(), field_of(*request, "angle_cdeg"), angle);
    error_code error;
    const rpc::CallResult result = client_->call("MoveJoint", *request, error);
    if (error) {
      outcome.error = error == rpc::RpcError::device_error
                          ? "device error " + std::to_string(result.device_error.code) + ": " + result.device_error.text
                          : error.message();
    } else {
      const std::int32_t reached =
          result.reply->GetReflection()->GetInt32(*result.reply, field_of(*result.reply, "reached_cdeg"));
      if (reached != angle) {
        outcome.wrong = true;
        outcome.cause = "wrong answer";
        outcome.error = "reached " + std::to_string(reached) + " for " + std::to_string(angle);
      } else {
        outcome.ok = true;
      }
    }
    outcome.commands.emplace_back(
        witness_key(static_cast<std::uint16_t>(joint), static_cast<std::uint16_t>(angle)), outcome.ok);
    return outcome;
  }
  LinkCounters link() const override { return client_->counters().link; }
  std::optional<std::uint32_t> resets_detected() const override { return client_->counters().link.resets; }

 private:
  std::shared_ptr<rpc::Client> client_;
  Payload payload_;
};

// Describe{} -> Description{name, joints, range, moves}: read back from the device.
class DescribeWorkload final : public Workload {
 public:
  explicit DescribeWorkload(std::shared_ptr<rpc::Client> client) : client_(std::move(client)) {}
  std::string operation() const override { return "call Describe{} -> Description{name, joints, ...} + Ack"; }
  Outcome run(unsigned) override {
    Outcome outcome;
    error_code error;
    const rpc::CallResult result = client_->call("Describe", *client_->new_request("Describe"), error);
    if (error) {
      outcome.error = error.message();
      return outcome;
    }
    const std::uint32_t joints =
        result.reply->GetReflection()->GetUInt32(*result.reply, field_of(*result.reply, "joints"));
    if (joints == 0) {
      outcome.wrong = true;
      outcome.cause = "wrong answer";
      outcome.error = "a description with no joints";
    } else {
      outcome.ok = true;
    }
    return outcome;
  }
  LinkCounters link() const override { return client_->counters().link; }
  std::optional<std::uint32_t> resets_detected() const override { return client_->counters().link.resets; }

 private:
  std::shared_ptr<rpc::Client> client_;
};

std::unique_ptr<Workload> make_rpc(const devices::RoverDevice& device, const devices::DeviceConfig&,
                                   WorkloadKind kind, Payload payload, std::string& why) {
  const auto client = device.client.get<rpc::Client>();
  why = missing_methods(*client);
  if (!why.empty()) return nullptr;
  if (kind == WorkloadKind::sensor) return std::make_unique<DescribeWorkload>(client);
  return std::make_unique<MoveJointWorkload>(client, payload);
}

}  // namespace

}  // namespace tether::demo

namespace tether::rpc {

/// The codec's workloads (collected by tools/demo/CMakeLists.txt: plugin_workloads.cpp.in).
std::vector<demo::CodecWorkloads> workload_rows();

std::vector<demo::CodecWorkloads> workload_rows() { return {{"rpc", demo::make_rpc}}; }

}  // namespace tether::rpc
