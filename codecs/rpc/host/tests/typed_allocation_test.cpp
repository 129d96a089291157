// Heap allocations of a warmed-up typed call's encode + decode: none. The steps are the client's own, in
// its order (client.cpp; the typed client benchmark runs the same): the initiation encodes the request
// (`detail::make_typed_call_request`), the strand writes the envelope's frame into a recycled string
// (`envelope::write_frame`), the device's Reply and Ack frames go through the client's frame reader and
// `envelope::decode`, the reply's bytes are kept in the call's state until the Ack, the reply is taken
// from the client's recycled replies (`detail::TypedReplies`), parsed, and moved out to the caller
// (`detail::take_as`, as `Client::call_as`). Counted by this program's own global operator new (its own
// executable: the replacement is global), on this thread only.
#include <google/protobuf/message.h>
#include <gtest/gtest.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <new>
#include <string>

#include "arm.tether.hpp"
#include "tether/rpc/client.hpp"
#include "tether/rpc/envelope.hpp"
#include "tether/rpc/schema.hpp"
#include "typed_call_steps.hpp"

namespace {
thread_local std::size_t allocations = 0;
}  // namespace

// Every form a program's `new` reaches (the aligned ones are left to the runtime: nothing here aligns).
void* operator new(std::size_t size) {
  ++allocations;
  if (void* memory = std::malloc(size == 0 ? 1 : size)) return memory;
  throw std::bad_alloc();
}
void* operator new[](std::size_t size) { return operator new(size); }
void* operator new(std::size_t size, const std::nothrow_t&) noexcept {
  ++allocations;
  return std::malloc(size == 0 ? 1 : size);
}
void* operator new[](std::size_t size, const std::nothrow_t& tag) noexcept { return operator new(size, tag); }
void operator delete(void* memory) noexcept { std::free(memory); }
void operator delete[](void* memory) noexcept { std::free(memory); }
void operator delete(void* memory, std::size_t) noexcept { std::free(memory); }
void operator delete[](void* memory, std::size_t) noexcept { std::free(memory); }
void operator delete(void* memory, const std::nothrow_t&) noexcept { std::free(memory); }
void operator delete[](void* memory, const std::nothrow_t&) noexcept { std::free(memory); }

namespace {

using namespace tether;

// One typed MoveJoint call's encode and decode, with the state the client keeps between calls.
class TypedCall {
 public:
  TypedCall()
      : method_(*schema_.find("MoveJoint")), decoder_(counters_), answer_(rpc::testing::device_frames(kId, -4500)) {
    request_.set_joint(2);
    request_.set_angle_cdeg(-4500);
  }

  // The reply's reached_cdeg (0 when a step failed: the test's checks say which).
  std::int32_t run() {
    // Encode: the initiation's request, then the strand's frame.
    rpc::detail::CallRequest call = rpc::detail::make_typed_call_request<arm::JointReply>("MoveJoint", request_);
    if (!call.encoded || schema_.find(call.method) != &method_ || call.reply.type != method_.output) return 0;
    rpc::testing::call_frame(call, method_, kId, frame_);
    if (frame_.size() < 8) return 0;

    // Decode: the device's Reply and Ack.
    std::string reply_bytes;  // the call's state until the Ack
    if (!rpc::testing::read_answer(decoder_, answer_, true, kId, reply_bytes)) return 0;
    std::shared_ptr<google::protobuf::Message> decoded = replies_.take(call.reply);
    if (!decoded->ParseFromArray(reply_bytes.data(), static_cast<int>(reply_bytes.size()))) return 0;
    const arm::JointReply reply = rpc::detail::take_as<arm::JointReply>(decoded);
    return reply.reached_cdeg();
  }

 private:
  static constexpr std::uint32_t kId = 0x12345678;
  const rpc::Schema schema_{arm::ArmClient::descriptor()};
  const rpc::Method& method_;
  LinkCounters counters_;
  rpc::envelope::FrameReader<rpc::kMaxPayload> decoder_;
  rpc::detail::TypedReplies replies_;
  std::string frame_;
  const rpc::testing::DeviceFrames answer_;
  arm::JointRequest request_;
};

TEST(RpcTypedCallAllocations, AWarmedUpTypedCallsEncodeAndDecodeAllocateNothing) {
  TypedCall call;
  const std::size_t before_first = allocations;
  ASSERT_EQ(call.run(), -4500);
  // The first call makes what later calls reuse (its frame string and its reply): the count sees them.
  EXPECT_GT(allocations - before_first, 0u);
  for (int i = 0; i < 10; ++i) ASSERT_EQ(call.run(), -4500);
  std::size_t counted = 0;  // around the calls alone: the checks' own allocations are not the calls'
  int right = 0;
  for (int i = 0; i < 100; ++i) {
    const std::size_t before = allocations;
    const std::int32_t reached = call.run();
    counted += allocations - before;
    right += reached == -4500 ? 1 : 0;
  }
  EXPECT_EQ(right, 100);
  EXPECT_EQ(counted, 0u) << "allocations in 100 warmed-up typed calls";
}

TEST(RpcTypedCallAllocations, AReplyTheCallerStillHoldsIsNotReused) {
  const rpc::detail::TypedReply typed = rpc::detail::typed_reply<arm::JointReply>();
  rpc::detail::TypedReplies replies;
  std::shared_ptr<google::protobuf::Message> held = replies.take(typed);
  ASSERT_NE(dynamic_cast<arm::JointReply*>(held.get()), nullptr);
  const google::protobuf::Message* const first = held.get();
  std::shared_ptr<google::protobuf::Message> second = replies.take(typed);
  EXPECT_NE(second.get(), first);  // the first one's caller still has it
  second.reset();
  held.reset();
  const std::size_t before = allocations;
  std::shared_ptr<google::protobuf::Message> again = replies.take(typed);
  EXPECT_EQ(allocations - before, 0u);
  EXPECT_EQ(again.get(), first);  // released: parsed into again
}

}  // namespace
