// Host tests of the proxy device library's pure logic: pin map and servo arithmetic, the text builder,
// the sessionId derivation, and the output table over the fake pin drivers.
#include <gtest/gtest.h>

#include <cstring>
#include <set>
#include <string>
#include <vector>

#include "fake_hardware.hpp"
#include "tether/firmware/servo_timer1.hpp"
#include "tether/proxy/device/outputs.hpp"
#include "tether/proxy/device/pins.hpp"
#include "tether/proxy/device/session_id.hpp"
#include "tether/proxy/device/text.hpp"

namespace {

using namespace tether::proxy::device;

// --- pins and servo arithmetic -------------------------------------------------------------------------

TEST(Pins, Classes) {
  EXPECT_TRUE(pin_exists(0));
  EXPECT_TRUE(pin_exists(19));
  EXPECT_FALSE(pin_exists(20));
  EXPECT_FALSE(pin_exists(1823));
  EXPECT_TRUE(is_uart_pin(0));
  EXPECT_TRUE(is_uart_pin(1));
  EXPECT_FALSE(is_uart_pin(2));
  EXPECT_FALSE(can_drive_digital(1));
  EXPECT_TRUE(can_drive_digital(2));
  EXPECT_TRUE(can_drive_digital(13));
  EXPECT_TRUE(can_drive_digital(19));
  EXPECT_FALSE(can_drive_digital(20));
  for (uint32_t pin = 0; pin < 40; ++pin) EXPECT_EQ(can_drive_servo(pin), pin == 9 || pin == 10) << pin;
}

TEST(Pins, ServoPulseIsDegreesToMicroseconds) {
  EXPECT_EQ(servo_pulse_us(0), 1000);
  EXPECT_EQ(servo_pulse_us(90), 1500);
  EXPECT_EQ(servo_pulse_us(180), 2000);
  EXPECT_EQ(servo_pulse_us(1), 1005);    // 1000 / 180 = 5.55: integer division
  EXPECT_EQ(servo_pulse_us(45), 1250);
  EXPECT_EQ(servo_pulse_us(-1), 1000);   // clamped
  EXPECT_EQ(servo_pulse_us(-2147483647 - 1), 1000);
  EXPECT_EQ(servo_pulse_us(181), 2000);
  EXPECT_EQ(servo_pulse_us(1231), 2000);
  EXPECT_EQ(servo_pulse_us(2147483647), 2000);
  for (int32_t degrees = 0; degrees <= 180; ++degrees) {
    EXPECT_EQ(servo_pulse_us(degrees), 1000 + degrees * 1000 / 180);
  }
}

TEST(ServoTimer1, CompareValueGivesThePulseInHalfMicrosecondTicks) {
  // The runtime's Timer1 driver (firmware/runtime), mode 14: high for OCR1x + 1 ticks of 0.5 us.
  using tether::firmware::servo_timer1::compare_value;
  using tether::firmware::servo_timer1::kTop;
  EXPECT_EQ(compare_value(1000), 1999);
  EXPECT_EQ(compare_value(1500), 2999);
  EXPECT_EQ(compare_value(2000), 3999);
  EXPECT_LT(compare_value(2000), kTop);
  EXPECT_EQ(kTop, 39999);  // (39999 + 1) * 0.5 us = 20 ms
}

// --- text ------------------------------------------------------------------------------------------------

TEST(Text, WordsAndNumbers) {
  char buffer[48];
  TextBuilder text(buffer, sizeof(buffer));
  text.text("pin ").number(0).text(" / ").number(1823).text(" / ").number(4294967295u);
  EXPECT_STREQ(buffer, "pin 0 / 1823 / 4294967295");
  EXPECT_FALSE(text.truncated());
  EXPECT_EQ(text.size(), std::strlen(buffer));
}

TEST(Text, NumbersAtEveryDigitCountAndItsEdges) {
  // number() subtracts powers of ten: every digit count, zeros inside, the edges around each power.
  const uint32_t values[] = {0u, 9u, 10u, 99u, 100u, 101u, 1000000000u, 999999999u, 1000000001u,
                             4000000000u, 4294967295u, 2147483648u, 1020304050u, 7u, 70u, 700000u};
  for (const uint32_t value : values) {
    char buffer[12];
    TextBuilder text(buffer, sizeof(buffer));
    text.number(value);
    EXPECT_EQ(std::string(buffer), std::to_string(value));
  }
  for (uint32_t value = 0; value < 100000; value += 7) {
    char buffer[12];
    TextBuilder text(buffer, sizeof(buffer));
    text.number(value);
    ASSERT_EQ(std::string(buffer), std::to_string(value));
  }
}

TEST(Text, TruncatesAndStaysTerminated) {
  char buffer[8];
  TextBuilder text(buffer, sizeof(buffer));
  text.text("abcdefghijk");
  EXPECT_STREQ(buffer, "abcdefg");
  EXPECT_TRUE(text.truncated());
  char small[6];
  TextBuilder numbers(small, sizeof(small));
  numbers.text("ab").number(123456);  // the number does not fit whole: left out
  EXPECT_STREQ(small, "ab");
  EXPECT_TRUE(numbers.truncated());
}

// --- sessionId -------------------------------------------------------------------------------------------

TEST(SessionId, NeverZeroNeverThePrevious) {
  for (uint32_t count = 0; count < 2000; ++count) {
    for (uint32_t entropy : {0u, 1u, 0xDEADBEEFu}) {
      const uint32_t first = derive_session_id(count, entropy, 0);
      EXPECT_NE(first, 0u);
      EXPECT_NE(derive_session_id(count, entropy, first), first);  // the same inputs cannot repeat it
      EXPECT_NE(derive_session_id(count, entropy, first), 0u);
    }
  }
  // The fallback paths: the hash hits the previous id, and previous + 1 wraps.
  const uint32_t hash = derive_session_id(7, 7, 0);
  EXPECT_EQ(derive_session_id(7, 7, hash), hash + 1u);
  EXPECT_NE(derive_session_id(7, 7, 0xFFFFFFFFu), 0u);
}

TEST(SessionId, ConsecutiveBootsWithIdenticalNoiseDiffer) {
  // The simulator's warm reset: same SRAM, same ADC readings; only the EEPROM counter moves.
  std::set<uint32_t> seen;
  uint32_t previous = 0xFFFFFFFFu;  // erased EEPROM
  for (uint32_t count = 0; count < 10000; ++count) {
    const uint32_t id = derive_session_id(count, 0x12345678u, previous);
    EXPECT_NE(id, previous);
    seen.insert(id);
    previous = id;
  }
  EXPECT_EQ(seen.size(), 10000u);  // not required, but the mix is a bijection of the counter here
}

TEST(SessionId, PoolDependsOnEveryByte) {
  EntropyPool a;
  EntropyPool b;
  const uint8_t bytes[] = {1, 2, 3, 4};
  a.add(tether::ByteView(bytes, sizeof(bytes)));
  b.add_word(0x04030201u);
  EXPECT_EQ(a.value(), b.value());  // little-endian words
  EntropyPool c;
  const uint8_t other[] = {1, 2, 3, 5};
  c.add(tether::ByteView(other, sizeof(other)));
  EXPECT_NE(a.value(), c.value());
  EXPECT_EQ(EntropyPool().value(), 2166136261u);
  EXPECT_NE(mix32(1), mix32(2));
  EXPECT_EQ(mix32(0), 0u);  // why derive_session_id never feeds it a bare 0 counter
}

// --- output table ----------------------------------------------------------------------------------------

class OutputsTest : public ::testing::Test {
 protected:
  void SetUp() override { fake::reset(); }
  fake::Hardware& hw() { return fake::hardware(); }
  OutputTable outputs;
};

TEST_F(OutputsTest, ServoInitDrivesTheSafePositionAtOnce) {
  EXPECT_EQ(outputs.init_servo(9, 90), PinResult::ok);
  EXPECT_EQ(outputs.kind(9), OutputKind::servo);
  EXPECT_EQ(outputs.value(9), 90);
  EXPECT_EQ(outputs.safe_value(9), 90);
  EXPECT_TRUE(hw().pins[9].servo);
  EXPECT_EQ(hw().pins[9].pulse_us, 1500);
  EXPECT_EQ(outputs.control_servo(9, 180), PinResult::ok);
  EXPECT_EQ(hw().pins[9].pulse_us, 2000);
  EXPECT_EQ(outputs.control_servo(9, 0), PinResult::ok);
  EXPECT_EQ(hw().pins[9].pulse_us, 1000);
  EXPECT_EQ(hw().calls, (std::vector<std::string>{"attach 9 1500", "write 9 2000", "write 9 1000"}));
}

TEST_F(OutputsTest, ServoPositionsOutsideTheRangeAreRefusedNotClamped) {
  EXPECT_EQ(outputs.init_servo(9, 181), PinResult::out_of_range);
  EXPECT_EQ(outputs.init_servo(9, -1), PinResult::out_of_range);
  EXPECT_FALSE(outputs.initialised(9));
  EXPECT_EQ(outputs.init_servo(9, 90), PinResult::ok);
  EXPECT_EQ(outputs.control_servo(9, 999), PinResult::out_of_range);
  EXPECT_EQ(outputs.control_servo(9, -5), PinResult::out_of_range);
  EXPECT_EQ(outputs.value(9), 90);  // unchanged
  EXPECT_EQ(hw().calls, (std::vector<std::string>{"attach 9 1500"}));
  EXPECT_EQ(outputs.control_servo(9, 180), PinResult::ok);
  EXPECT_EQ(outputs.control_servo(9, 0), PinResult::ok);
}

TEST_F(OutputsTest, ServoOnlyOnTimer1Pins) {
  EXPECT_EQ(outputs.init_servo(10, 0), PinResult::ok);
  EXPECT_EQ(outputs.init_servo(5, 90), PinResult::not_servo_pin);
  EXPECT_EQ(outputs.init_servo(11, 90), PinResult::not_servo_pin);
  EXPECT_EQ(outputs.init_servo(0, 90), PinResult::uart_pin);
  EXPECT_EQ(outputs.init_servo(1823, 1231), PinResult::no_such_pin);
  EXPECT_EQ(outputs.kind(5), OutputKind::none);
  EXPECT_EQ(outputs.initialised_count(), 1);
  EXPECT_EQ(hw().calls, (std::vector<std::string>{"attach 10 1000"}));  // nothing for the refused ones
}

TEST_F(OutputsTest, DigitalOnTwoToNineteen) {
  EXPECT_EQ(outputs.init_digital(13, true), PinResult::ok);
  EXPECT_TRUE(hw().pins[13].output);
  EXPECT_TRUE(hw().pins[13].level);
  EXPECT_EQ(outputs.control_digital(13, false), PinResult::ok);
  EXPECT_FALSE(hw().pins[13].level);
  EXPECT_EQ(outputs.init_digital(2, false), PinResult::ok);
  EXPECT_EQ(outputs.init_digital(19, false), PinResult::ok);
  EXPECT_EQ(outputs.init_digital(1, false), PinResult::uart_pin);
  EXPECT_EQ(outputs.init_digital(0, false), PinResult::uart_pin);
  EXPECT_EQ(outputs.init_digital(20, false), PinResult::no_such_pin);
  EXPECT_EQ(outputs.initialised_count(), 3);
}

TEST_F(OutputsTest, ControlsNeedTheRightInit) {
  EXPECT_EQ(outputs.control_digital(13, true), PinResult::not_initialised);
  EXPECT_EQ(outputs.control_servo(9, 10), PinResult::not_initialised);
  EXPECT_EQ(outputs.control_servo(99, 10), PinResult::no_such_pin);
  EXPECT_EQ(outputs.control_digital(1, true), PinResult::uart_pin);
  outputs.init_digital(9, false);
  outputs.init_servo(10, 45);
  EXPECT_EQ(outputs.control_servo(9, 10), PinResult::wrong_kind);
  EXPECT_EQ(outputs.control_digital(10, true), PinResult::wrong_kind);
  EXPECT_EQ(hw().calls, (std::vector<std::string>{"init 9 0", "attach 10 1250"}));
}

TEST_F(OutputsTest, ReinitReplacesTheSafeValueAndKind) {
  outputs.init_servo(9, 90);
  outputs.control_servo(9, 10);
  EXPECT_EQ(outputs.init_servo(9, 30), PinResult::ok);  // again: new safe value, driven at once
  EXPECT_EQ(outputs.value(9), 30);
  EXPECT_EQ(outputs.safe_value(9), 30);
  EXPECT_EQ(outputs.init_digital(9, true), PinResult::ok);  // servo -> digital: pulses stop first
  EXPECT_EQ(outputs.kind(9), OutputKind::digital);
  EXPECT_FALSE(hw().pins[9].servo);
  EXPECT_TRUE(hw().pins[9].level);
  EXPECT_EQ(outputs.init_servo(9, 0), PinResult::ok);  // and back
  EXPECT_TRUE(hw().pins[9].servo);
  EXPECT_EQ(hw().calls, (std::vector<std::string>{"attach 9 1500", "write 9 1055", "write 9 1166", "init 9 1",
                                                  "detach 9 0", "attach 9 1000"}));
}

TEST_F(OutputsTest, DriveSafePutsEveryInitialisedPinAtItsSafeValue) {
  outputs.init_servo(9, 90);
  outputs.init_servo(10, 0);
  outputs.init_digital(13, false);
  outputs.init_digital(7, true);
  outputs.control_servo(9, 180);
  outputs.control_servo(10, 180);
  outputs.control_digital(13, true);
  outputs.control_digital(7, false);
  hw().calls.clear();
  outputs.drive_safe();
  EXPECT_EQ(outputs.value(9), 90);
  EXPECT_EQ(outputs.value(10), 0);
  EXPECT_EQ(outputs.value(13), 0);
  EXPECT_EQ(outputs.value(7), 1);
  EXPECT_EQ(hw().pins[9].pulse_us, 1500);
  EXPECT_EQ(hw().pins[10].pulse_us, 1000);
  EXPECT_FALSE(hw().pins[13].level);
  EXPECT_TRUE(hw().pins[7].level);
  EXPECT_EQ(hw().calls, (std::vector<std::string>{"set 7 1", "write 9 1500", "write 10 1000", "set 13 0"}));
}

}  // namespace
