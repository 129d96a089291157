// Host tests of the descriptors kept in flash (nanopb_descriptors_in_flash.h, flash_descriptors.hpp): the
// PB_BIND that puts them in flash binds the same tables as nanopb's own, and the RAM copy nanopb works on
// encodes and decodes every RocketryProto message as the original descriptors do. On the host "flash" is
// ordinary memory: what an AVR reads with LPM is the interop tests' (interop.ProxyCompatPins.*).
#include <pb.h>
// nanopb's PB_BIND, kept before rocketry.pb.h replaces it (rocketry.options includes the flash header).
#pragma push_macro("PB_BIND")
#include "rocketry.pb.h"
#pragma pop_macro("PB_BIND")

#include <gtest/gtest.h>
#include <pb_decode.h>
#include <pb_encode.h>

#include <cstdint>
#include <string>
#include <vector>

#include "tether/proxy/device/flash_descriptors.hpp"

#ifndef TETHER_PB_DESCRIPTORS_IN_FLASH
#error "rocketry.pb.h should include nanopb_descriptors_in_flash.h (rocketry.options)"
#endif

// Every RocketryProto message bound again, in this namespace, by nanopb's own PB_BIND (leaves first, as
// rocketry.pb.c binds them: a list refers to the descriptors bound before it).
namespace nanopb_bound {
PB_BIND(RocketryProto_ServoInit, RocketryProto_ServoInit, AUTO)
PB_BIND(RocketryProto_ServoControl, RocketryProto_ServoControl, AUTO)
PB_BIND(RocketryProto_DigitalInit, RocketryProto_DigitalInit, AUTO)
PB_BIND(RocketryProto_DigitalControl, RocketryProto_DigitalControl, AUTO)
PB_BIND(RocketryProto_Reset, RocketryProto_Reset, AUTO)
PB_BIND(RocketryProto_DCMotorInit, RocketryProto_DCMotorInit, AUTO)
PB_BIND(RocketryProto_DCMotorControl, RocketryProto_DCMotorControl, AUTO)
PB_BIND(RocketryProto_StepperMotorControl, RocketryProto_StepperMotorControl, AUTO)
PB_BIND(RocketryProto_ArduinoIn, RocketryProto_ArduinoIn, AUTO)
PB_BIND(RocketryProto_EventMessage, RocketryProto_EventMessage, AUTO)
PB_BIND(RocketryProto_ErrorMessage, RocketryProto_ErrorMessage, AUTO)
PB_BIND(RocketryProto_ServoState, RocketryProto_ServoState, AUTO)
PB_BIND(RocketryProto_DigitalState, RocketryProto_DigitalState, AUTO)
PB_BIND(RocketryProto_DCMotorState, RocketryProto_DCMotorState, AUTO)
PB_BIND(RocketryProto_StepperMotorState, RocketryProto_StepperMotorState, AUTO)
PB_BIND(RocketryProto_LoadCellState, RocketryProto_LoadCellState, AUTO)
PB_BIND(RocketryProto_ArduinoOut, RocketryProto_ArduinoOut, AUTO)
}  // namespace nanopb_bound

namespace {

using tether::ByteView;
using namespace tether::proxy::device;
using Bytes = std::vector<std::uint8_t>;

struct Bound {
  const char* name;
  const pb_msgdesc_t* flash;    // rocketry.pb.c's, bound by nanopb_descriptors_in_flash.h
  const pb_msgdesc_t* nanopb;   // nanopb_bound's
  std::size_t field_info_words;  // of nanopb's table, its closing 0 included
};

#define TETHER_BOUND(message)                                                   \
  Bound {                                                                       \
    #message, &message##_msg, &nanopb_bound::message##_msg,                      \
        sizeof(nanopb_bound::message##_field_info) / sizeof(std::uint32_t)       \
  }

const std::vector<Bound>& every_message() {
  static const std::vector<Bound> bound = {
      TETHER_BOUND(RocketryProto_ServoInit),        TETHER_BOUND(RocketryProto_ServoControl),
      TETHER_BOUND(RocketryProto_DigitalInit),      TETHER_BOUND(RocketryProto_DigitalControl),
      TETHER_BOUND(RocketryProto_Reset),            TETHER_BOUND(RocketryProto_DCMotorInit),
      TETHER_BOUND(RocketryProto_DCMotorControl),   TETHER_BOUND(RocketryProto_StepperMotorControl),
      TETHER_BOUND(RocketryProto_ArduinoIn),        TETHER_BOUND(RocketryProto_EventMessage),
      TETHER_BOUND(RocketryProto_ErrorMessage),     TETHER_BOUND(RocketryProto_ServoState),
      TETHER_BOUND(RocketryProto_DigitalState),     TETHER_BOUND(RocketryProto_DCMotorState),
      TETHER_BOUND(RocketryProto_StepperMotorState), TETHER_BOUND(RocketryProto_LoadCellState),
      TETHER_BOUND(RocketryProto_ArduinoOut)};
  return bound;
}

// The flash-bound descriptor standing for nanopb-bound `descriptor` (nullptr for nullptr and strangers).
const pb_msgdesc_t* flash_twin(const pb_msgdesc_t* descriptor) {
  for (const Bound& bound : every_message()) {
    if (bound.nanopb == descriptor) return bound.flash;
  }
  return nullptr;
}

TEST(DescriptorsInFlash, BindsWhatNanopbBinds) {
  for (const Bound& bound : every_message()) {
    SCOPED_TRACE(bound.name);
    const pb_msgdesc_t& flash = *bound.flash;
    const pb_msgdesc_t& nanopb = *bound.nanopb;
    EXPECT_EQ(flash.field_count, nanopb.field_count);
    EXPECT_EQ(flash.required_field_count, nanopb.required_field_count);
    EXPECT_EQ(flash.largest_tag, nanopb.largest_tag);
    EXPECT_EQ(flash.default_value, nanopb.default_value);
    EXPECT_EQ(flash.field_callback, nanopb.field_callback);
    for (std::size_t word = 0; word < bound.field_info_words; ++word) {
      EXPECT_EQ(flash.field_info[word], nanopb.field_info[word]) << "field_info[" << word << "]";
    }
    std::size_t entry = 0;
    for (; nanopb.submsg_info[entry] != nullptr; ++entry) {
      EXPECT_EQ(flash.submsg_info[entry], flash_twin(nanopb.submsg_info[entry])) << "submsg_info[" << entry << "]";
    }
    EXPECT_EQ(flash.submsg_info[entry], nullptr) << "submsg_info[" << entry << "] ends the list";
  }
}

TEST(DescriptorsInFlash, TheSubmessageFieldsAreCountedFromTheFieldList) {
  static_assert(TETHER_PB_SUBMESSAGE_FIELDS(RocketryProto_ArduinoIn) == 8, "ArduinoIn: 8 submessage fields");
  static_assert(TETHER_PB_SUBMESSAGE_FIELDS(RocketryProto_ArduinoOut) == 7, "ArduinoOut: 7 submessage fields");
  static_assert(TETHER_PB_SUBMESSAGE_FIELDS(RocketryProto_ServoInit) == 0, "ServoInit: none");
  SUCCEED();
}

// The copy has the original's values, its own lists, and every copy of a submessage the original's values
// with an empty list.
void expect_copy_of(const pb_msgdesc_t* copy, const pb_msgdesc_t* original, const void* storage_begin,
                    const void* storage_end) {
  ASSERT_NE(copy, nullptr);
  const auto inside = [&](const void* pointer) { return pointer >= storage_begin && pointer < storage_end; };
  EXPECT_TRUE(inside(copy));
  EXPECT_EQ(copy->field_info, original->field_info);  // the field tables are read where they are
  EXPECT_EQ(copy->field_count, original->field_count);
  EXPECT_EQ(copy->largest_tag, original->largest_tag);
  EXPECT_EQ(copy->field_callback, original->field_callback);
  EXPECT_EQ(copy->default_value, original->default_value);
  EXPECT_TRUE(inside(copy->submsg_info));
  std::size_t entry = 0;
  for (; original->submsg_info[entry] != nullptr; ++entry) {
    const pb_msgdesc_t* sub = copy->submsg_info[entry];
    ASSERT_NE(sub, nullptr) << "entry " << entry;
    EXPECT_TRUE(inside(sub));
    EXPECT_EQ(sub->field_info, original->submsg_info[entry]->field_info);
    EXPECT_EQ(sub->field_count, original->submsg_info[entry]->field_count);
    EXPECT_EQ(sub->largest_tag, original->submsg_info[entry]->largest_tag);
    EXPECT_TRUE(inside(sub->submsg_info));
    EXPECT_EQ(sub->submsg_info[0], nullptr);
  }
  EXPECT_EQ(copy->submsg_info[entry], nullptr);
}

TEST(DescriptorsInFlash, ACopyHasTheMessageAndItsSubmessagesInItsOwnStorage) {
  const DescriptorCopy<TETHER_PB_SUBMESSAGE_FIELDS(RocketryProto_ArduinoIn)> in(
      FlashDescriptor{RocketryProto_ArduinoIn_fields});
  expect_copy_of(in.get(), RocketryProto_ArduinoIn_fields, &in, &in + 1);
  const DescriptorCopy<TETHER_PB_SUBMESSAGE_FIELDS(RocketryProto_ArduinoOut)> out(
      FlashDescriptor{RocketryProto_ArduinoOut_fields});
  expect_copy_of(out.get(), RocketryProto_ArduinoOut_fields, &out, &out + 1);
  const DescriptorCopy<0> leaf(FlashDescriptor{RocketryProto_ServoInit_fields});
  expect_copy_of(leaf.get(), RocketryProto_ServoInit_fields, &leaf, &leaf + 1);
  // Room for more submessages than there are: fits, the list ends after the last.
  const DescriptorCopy<10> roomy(FlashDescriptor{RocketryProto_ArduinoOut_fields});
  expect_copy_of(roomy.get(), RocketryProto_ArduinoOut_fields, &roomy, &roomy + 1);
}

TEST(DescriptorsInFlash, WhatDoesNotFitIsNoCopy) {
  const DescriptorCopy<7> short_by_one(FlashDescriptor{RocketryProto_ArduinoIn_fields});
  EXPECT_EQ(short_by_one.get(), nullptr);
  const DescriptorCopy<0> none(FlashDescriptor{RocketryProto_ArduinoOut_fields});
  EXPECT_EQ(none.get(), nullptr);
  // A submessage with a submessage of its own (none in rocketry.proto): refused, not half copied.
  const pb_msgdesc_t* const no_submessages[] = {nullptr};
  const pb_msgdesc_t leaf{RocketryProto_ServoInit_msg.field_info, no_submessages, nullptr, nullptr, 2, 0, 2};
  const pb_msgdesc_t* const leaf_list[] = {&leaf, nullptr};
  const pb_msgdesc_t middle{RocketryProto_ServoInit_msg.field_info, leaf_list, nullptr, nullptr, 2, 0, 2};
  const pb_msgdesc_t* const middle_list[] = {&middle, nullptr};
  const pb_msgdesc_t root{RocketryProto_ServoInit_msg.field_info, middle_list, nullptr, nullptr, 2, 0, 2};
  const DescriptorCopy<4> deep(FlashDescriptor{&root});
  EXPECT_EQ(deep.get(), nullptr);
  const DescriptorCopy<1> shallow(FlashDescriptor{&middle});
  EXPECT_NE(shallow.get(), nullptr);
  EXPECT_EQ(decode_message(nullptr, ByteView(), nullptr), false);
}

Bytes encode(const pb_msgdesc_t* fields, const void* message) {
  std::uint8_t buffer[128];
  pb_ostream_t stream = pb_ostream_from_buffer(buffer, sizeof buffer);
  EXPECT_TRUE(pb_encode(&stream, fields, message));
  return Bytes(buffer, buffer + stream.bytes_written);
}

// Every oneof case of both top-level messages, with every field set (non-zero), encoded through a copy:
// the bytes the original descriptors give; decoded through a copy: the message again.
TEST(DescriptorsInFlash, EveryRocketryMessageRoundTripsThroughACopy) {
  std::vector<RocketryProto_ArduinoIn> ins(8, RocketryProto_ArduinoIn(RocketryProto_ArduinoIn_init_zero));
  ins[0].which_data = RocketryProto_ArduinoIn_servoInit_tag;
  ins[0].data.servoInit = {9, -90};
  ins[1].which_data = RocketryProto_ArduinoIn_servoControl_tag;
  ins[1].data.servoControl = {19, 2400};
  ins[2].which_data = RocketryProto_ArduinoIn_digitalInit_tag;
  ins[2].data.digitalInit = {13, 1};
  ins[3].which_data = RocketryProto_ArduinoIn_digitalControl_tag;
  ins[3].data.digitalControl = {7, true};
  ins[4].which_data = RocketryProto_ArduinoIn_reset_tag;
  ins[5].which_data = RocketryProto_ArduinoIn_dcMotorInit_tag;
  ins[5].data.dcMotorInit = {2, 4, 14, 5, 6, 300};
  ins[6].which_data = RocketryProto_ArduinoIn_dcMotorControl_tag;
  ins[6].data.dcMotorControl = {5, 6, -1023};
  ins[7].which_data = RocketryProto_ArduinoIn_stepperMotorControl_tag;
  ins[7].data.stepperMotorControl = {100000};
  const DescriptorCopy<TETHER_PB_SUBMESSAGE_FIELDS(RocketryProto_ArduinoIn)> in_fields(
      FlashDescriptor{RocketryProto_ArduinoIn_fields});
  for (const RocketryProto_ArduinoIn& in : ins) {
    SCOPED_TRACE("ArduinoIn case " + std::to_string(in.which_data));
    const Bytes bytes = encode(RocketryProto_ArduinoIn_fields, &in);
    EXPECT_EQ(encode(in_fields.get(), &in), bytes);
    RocketryProto_ArduinoIn decoded = RocketryProto_ArduinoIn_init_zero;
    ASSERT_TRUE(decode_message(in_fields.get(), ByteView(bytes.data(), bytes.size()), &decoded));
    EXPECT_EQ(decoded.which_data, in.which_data);
    EXPECT_EQ(encode(RocketryProto_ArduinoIn_fields, &decoded), bytes);  // every field came back
  }

  std::vector<RocketryProto_ArduinoOut> outs(7, RocketryProto_ArduinoOut(RocketryProto_ArduinoOut_init_zero));
  outs[0].which_data = RocketryProto_ArduinoOut_eventMessage_tag;
  outs[0].data.eventMessage = {RocketryProto_EventTypes_DC_MOTOR_CONTROL, 13};
  outs[1].which_data = RocketryProto_ArduinoOut_errorMessage_tag;
  outs[1].data.errorMessage = {RocketryProto_ErrorTypes_PIN_NOT_INITIALIZED, -7};
  outs[2].which_data = RocketryProto_ArduinoOut_servoState_tag;
  outs[2].data.servoState = {3, 999};
  outs[3].which_data = RocketryProto_ArduinoOut_digitalState_tag;
  outs[3].data.digitalState = {12, true};
  outs[4].which_data = RocketryProto_ArduinoOut_dcMotorState_tag;
  outs[4].data.dcMotorState = {5, 6, 512, -1, true, true};
  outs[5].which_data = RocketryProto_ArduinoOut_stepperMotorState_tag;
  outs[5].data.stepperMotorState = {2, 3, 4000, -4000, 100, 1};
  outs[6].which_data = RocketryProto_ArduinoOut_loadCellState_tag;
  outs[6].data.loadCellState = {0xFFFFFFu};
  const DescriptorCopy<TETHER_PB_SUBMESSAGE_FIELDS(RocketryProto_ArduinoOut)> out_fields(
      FlashDescriptor{RocketryProto_ArduinoOut_fields});
  for (const RocketryProto_ArduinoOut& out : outs) {
    SCOPED_TRACE("ArduinoOut case " + std::to_string(out.which_data));
    const Bytes bytes = encode(RocketryProto_ArduinoOut_fields, &out);
    EXPECT_EQ(encode(out_fields.get(), &out), bytes);
    RocketryProto_ArduinoOut decoded = RocketryProto_ArduinoOut_init_zero;
    ASSERT_TRUE(decode_message(out_fields.get(), ByteView(bytes.data(), bytes.size()), &decoded));
    EXPECT_EQ(decoded.which_data, out.which_data);
    EXPECT_EQ(encode(RocketryProto_ArduinoOut_fields, &decoded), bytes);
  }
}

}  // namespace
