// Host cost of one rpc call through the typed client (the example's arm.proto, protoc's classes and the
// compiled-in schema that tether_generate_rpc builds): encode + decode of one MoveJoint call, with the
// functions the client runs (codecs/rpc/host/src/client.cpp), in its order:
//   encode: the initiation encodes the request (`detail::make_typed_call_request`: the call's copy), the strand
//           writes the HostMessage envelope (id, method index, request bytes) and its frame (COBS + CRC-16,
//           leading delimiter) into a frame string it recycles (`envelope::write_frame`);
//   decode: the device's Reply frame through the client's frame reader (`envelope::FrameReader`: whole
//           in one read, so decoded in one pass), the DeviceMessage envelope read (`envelope::decode`),
//           the reply bytes kept in the call's state until the Ack, the reply taken from the client's
//           recycled replies of the typed call's class (an arm::JointReply,
//           `detail::TypedReplies`: the previous call's, released by its caller) and parsed (a type without
//           strings: libprotobuf's parser alone), then moved out as the typed client hands it over
//           (`Client::call_as`), which releases it for the next call.
// BM_RpcTypedMoveJointWithAck also decodes the device's Ack frame, the other frame of the round trip.
// BM_RpcDynamicJsonMoveJoint is the dynamic client's `call_json` (the CLI's and Python's path): the schema
// read from arm.proto at run time, the request parsed from JSON into a dynamic message, the reply printed as
// JSON (protobuf's mapping, every field), both through the client's JsonMapping; the rest as above.
// No I/O, no strand, no timers: those are the fleet benchmark's.
#include <benchmark/benchmark.h>

#include <google/protobuf/descriptor.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/message.h>
#include <google/protobuf/util/json_util.h>

#include <cstdint>
#include <memory>
#include <string>

#include "arm.tether.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/rpc/client.hpp"
#include "tether/rpc/envelope.hpp"
#include "tether/rpc/json_mapping.hpp"
#include "tether/rpc/schema.hpp"
#include "tether_rpc.pb.h"
#include "typed_call_steps.hpp"

namespace {

namespace pb = google::protobuf;
using namespace tether;

using rpc::testing::DeviceFrames;

// Decode: the device's frames through the client's frame reader; the Reply's payload bytes.
template <std::size_t Capacity>
std::string reply_payload(rpc::envelope::FrameReader<Capacity>& decoder, const DeviceFrames& answer, bool with_ack,
                          std::uint32_t id, benchmark::State& state) {
  std::string reply_bytes;
  if (!rpc::testing::read_answer(decoder, answer, with_ack, id, reply_bytes)) state.SkipWithError("undecodable");
  return reply_bytes;
}

void set_counters(benchmark::State& state, std::size_t call_bytes, const DeviceFrames& answer) {
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()));
  state.counters["call_bytes"] = static_cast<double>(call_bytes);
  state.counters["reply_bytes"] = static_cast<double>(answer.reply.size());
  state.counters["ack_bytes"] = static_cast<double>(answer.ack.size());
}

void typed_move_joint(benchmark::State& state, bool with_ack) {
  const rpc::Schema schema(arm::ArmClient::descriptor());
  const rpc::Method& method = *schema.find("MoveJoint");
  constexpr std::uint32_t kId = 0x12345678;
  const DeviceFrames answer = rpc::testing::device_frames(kId, -4500);
  LinkCounters counters;
  rpc::envelope::FrameReader<rpc::kMaxPayload> decoder(counters);  // the client's
  arm::JointRequest request;
  request.set_joint(2);
  request.set_angle_cdeg(-4500);
  std::size_t call_bytes = 0;
  std::int64_t reached = 0;
  std::string frame;  // the client's recycled frame string
  rpc::detail::TypedReplies replies;  // the client's recycled replies
  for (auto _ : state) {
    // Encode: the initiation's encoding of the request, then what the strand does with it.
    rpc::detail::CallRequest call = rpc::detail::make_typed_call_request<arm::JointReply>("MoveJoint", request);
    if (call.type != method.input || schema.find(call.method) != &method) state.SkipWithError("not the compiled-in type");
    rpc::testing::call_frame(call, method, kId, frame);
    call_bytes = frame.size();
    benchmark::DoNotOptimize(frame.data());

    const std::string reply_bytes = reply_payload(decoder, answer, with_ack, kId, state);
    // The typed call's reply class is the method's output: taken as one (client.cpp on_completion).
    if (call.reply.type != method.output) state.SkipWithError("not the typed reply");
    std::shared_ptr<pb::Message> decoded = replies.take(call.reply);
    if (!decoded->ParseFromArray(reply_bytes.data(), static_cast<int>(reply_bytes.size()))) {
      state.SkipWithError("bad reply");
    }
    const arm::JointReply reply = rpc::detail::take_as<arm::JointReply>(decoded);
    reached = reply.reached_cdeg();
    benchmark::DoNotOptimize(reached);
  }
  if (reached != -4500) state.SkipWithError("wrong reply");
  set_counters(state, call_bytes, answer);
}

void BM_RpcDynamicJsonMoveJoint(benchmark::State& state) {
  const rpc::Schema schema = rpc::Schema::load(TETHER_RPC_EXAMPLE_SCHEMA);
  const rpc::Method& method = *schema.find("MoveJoint");
  constexpr std::uint32_t kId = 0x12345678;
  const DeviceFrames answer = rpc::testing::device_frames(kId, -4500);
  pb::DynamicMessageFactory factory;
  const pb::Message* request_prototype = factory.GetPrototype(method.input);
  const pb::Message* reply_prototype = factory.GetPrototype(method.output);
  LinkCounters counters;
  rpc::envelope::FrameReader<rpc::kMaxPayload> decoder(counters);  // the client's
  const std::string json_request = R"({"joint": 2, "angleCdeg": -4500})";
  const rpc::JsonMapping json(schema.pool());  // the client's, made once with its schema
  pb::util::JsonPrintOptions print;
  print.always_print_primitive_fields = true;
  std::size_t call_bytes = 0;
  std::string json_reply;
  std::string frame;
  for (auto _ : state) {
    std::shared_ptr<pb::Message> request(request_prototype->New());
    if (!json.from_json(json_request, *request).ok()) state.SkipWithError("bad JSON");
    rpc::detail::CallRequest call = rpc::detail::make_call_request("MoveJoint", *request);
    if (schema.find(call.method) != &method) state.SkipWithError("no method");
    rpc::testing::call_frame(call, method, kId, frame);
    call_bytes = frame.size();
    benchmark::DoNotOptimize(frame.data());

    const std::string reply_bytes = reply_payload(decoder, answer, false, kId, state);
    std::shared_ptr<pb::Message> decoded(reply_prototype->New(), [](pb::Message* m) { delete m; });
    if (!decoded->ParseFromArray(reply_bytes.data(), static_cast<int>(reply_bytes.size()))) {
      state.SkipWithError("bad reply");
    }
    json_reply.clear();
    (void)json.to_json(*decoded, json_reply, print);
    benchmark::DoNotOptimize(json_reply.data());
  }
  if (json_reply != R"({"reachedCdeg":-4500})") state.SkipWithError(("wrong reply " + json_reply).c_str());
  set_counters(state, call_bytes, answer);
}
BENCHMARK(BM_RpcDynamicJsonMoveJoint);

void BM_RpcTypedMoveJoint(benchmark::State& state) { typed_move_joint(state, false); }
BENCHMARK(BM_RpcTypedMoveJoint);

void BM_RpcTypedMoveJointWithAck(benchmark::State& state) { typed_move_joint(state, true); }
BENCHMARK(BM_RpcTypedMoveJointWithAck);

}  // namespace
