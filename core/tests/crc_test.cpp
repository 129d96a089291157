// CRC back end tests on the host (Boost.CRC). The AVR back end (avr-libc) is checked against the same
// values and against random buffers by the avr-selftest, which runs the real AVR code under simavr
// (firmware/selftest, interop-tests/avr_selftest_test.cpp).
#include "tether/core/crc.hpp"

#include <gtest/gtest.h>

#include <random>
#include <string>
#include <vector>

#include "tether/testing/random_seed.hpp"

namespace tether {
namespace {

ByteView view_of(const std::string& text) { return ByteView::from_chars(text.data(), text.size()); }

TEST(Crc8Smbus, CheckValue) { EXPECT_EQ(Crc8Smbus::compute(view_of("123456789")), 0xF4); }

TEST(Crc16Mcrf4xx, CheckValue) { EXPECT_EQ(Crc16Mcrf4xx::compute(view_of("123456789")), 0x6F91); }

TEST(Crc8Smbus, RomiPublishedVectors) {
  // From the Romi protocol spec and its reference implementation.
  EXPECT_EQ(Crc8Smbus::compute(view_of("#e[0]:00")), 0x92);
  EXPECT_EQ(Crc8Smbus::compute(view_of("#e:7b")), 0x04);
  EXPECT_EQ(Crc8Smbus::compute(view_of("#e[0]:7b")), 0x40);
  EXPECT_EQ(Crc8Smbus::compute(view_of("#M[16,\"Shutdown\"]:7b")), 0xba);
  EXPECT_EQ(Crc8Smbus::compute(view_of("#M[1,\"Out of boundary\"]:7b")), 0xa7);
  EXPECT_EQ(Crc8Smbus::compute(view_of("Hello world!")), 0x27);
  EXPECT_EQ(Crc8Smbus::compute(view_of("#a:00")), 0x8e);
}

TEST(Crc8Smbus, ElcanoGenerationDVectors) {
  // Generation D trailers are the decimal CRC-8/SMBUS of the message body.
  EXPECT_EQ(Crc8Smbus::compute(view_of("D{s50}{a25}")), 74);
  EXPECT_EQ(Crc8Smbus::compute(view_of("D{s1500}{a60}")), 179);
  EXPECT_EQ(Crc8Smbus::compute(view_of("X{n4}{s160}{b80}{p3200}{q-64000}")), 243);
}

TEST(Crc16Mcrf4xx, ProxyWorkedExample) {
  const std::vector<uint8_t> payload = {0x0a, 0x06, 0x08, 0x9f, 0x0e, 0x10, 0xcf, 0x09};
  EXPECT_EQ(Crc16Mcrf4xx::compute(ByteView(payload.data(), payload.size())), 0x8857);
}

TEST(Crc, EmptyInputGivesInitialValue) {
  EXPECT_EQ(Crc8Smbus::compute(ByteView()), 0x00);
  EXPECT_EQ(Crc16Mcrf4xx::compute(ByteView()), 0xFFFF);
}

// Reference bitwise models straight from the algorithm parameters, independent of any library.
uint8_t model_crc8_smbus(const std::vector<uint8_t>& data) {
  uint8_t crc = 0;
  for (uint8_t byte : data) {
    crc = static_cast<uint8_t>(crc ^ byte);
    for (int bit = 0; bit < 8; ++bit) {
      crc = static_cast<uint8_t>((crc & 0x80) ? (crc << 1) ^ 0x07 : crc << 1);
    }
  }
  return crc;
}
uint16_t model_crc16_mcrf4xx(const std::vector<uint8_t>& data) {
  uint16_t crc = 0xFFFF;
  for (uint8_t byte : data) {
    crc = static_cast<uint16_t>(crc ^ byte);
    for (int bit = 0; bit < 8; ++bit) {
      crc = static_cast<uint16_t>((crc & 1) ? (crc >> 1) ^ 0x8408 : crc >> 1);
    }
  }
  return crc;
}

TEST(Crc, RandomBuffersMatchBitwiseModelInAnyChunking) {
  auto generator = testing::seeded_generator(1);
  std::uniform_int_distribution<int> byte(0, 255);
  std::uniform_int_distribution<size_t> length(0, 300);
  for (int round = 0; round < 500; ++round) {
    std::vector<uint8_t> data(length(generator));
    for (auto& b : data) b = static_cast<uint8_t>(byte(generator));
    Crc8Smbus crc8;
    Crc16Mcrf4xx crc16;
    size_t offset = 0;
    while (offset < data.size()) {
      const size_t chunk = std::uniform_int_distribution<size_t>(1, data.size() - offset)(generator);
      const ByteView part(data.data() + offset, chunk);
      if (chunk == 1) {
        crc8.update(part[0]);
        crc16.update(part[0]);
      } else {
        crc8.update(part);
        crc16.update(part);
      }
      offset += chunk;
    }
    ASSERT_EQ(crc8.value(), model_crc8_smbus(data)) << "round " << round;
    ASSERT_EQ(crc16.value(), model_crc16_mcrf4xx(data)) << "round " << round;
  }
}

// The host takes eight bytes per step and holds up to seven fed one by one (crc.hpp): every length
// around those blocks, split at every point into bytes fed one by one and a run (both orders), and the
// value read after every byte (it must not disturb what is held).
TEST(Crc, EveryLengthAndSplitAroundEightByteBlocksMatchesTheModel) {
  std::vector<uint8_t> all(41);
  for (size_t i = 0; i < all.size(); ++i) all[i] = static_cast<uint8_t>(i * 151u + 29u);
  for (size_t size = 0; size <= all.size(); ++size) {
    const std::vector<uint8_t> data(all.begin(), all.begin() + static_cast<std::ptrdiff_t>(size));
    const uint8_t want8 = model_crc8_smbus(data);
    const uint16_t want16 = model_crc16_mcrf4xx(data);
    for (size_t split = 0; split <= size; ++split) {
      Crc8Smbus bytes_then_run8;
      Crc16Mcrf4xx bytes_then_run16;
      Crc8Smbus run_then_bytes8;
      Crc16Mcrf4xx run_then_bytes16;
      run_then_bytes8.update(ByteView(data.data(), split));
      run_then_bytes16.update(ByteView(data.data(), split));
      for (size_t i = 0; i < split; ++i) {
        bytes_then_run8.update(data[i]);
        bytes_then_run16.update(data[i]);
      }
      for (size_t i = split; i < size; ++i) {
        run_then_bytes8.update(data[i]);
        run_then_bytes16.update(data[i]);
      }
      bytes_then_run8.update(ByteView(data.data() + split, size - split));
      bytes_then_run16.update(ByteView(data.data() + split, size - split));
      ASSERT_EQ(bytes_then_run8.value(), want8) << "size " << size << " split " << split;
      ASSERT_EQ(bytes_then_run16.value(), want16) << "size " << size << " split " << split;
      ASSERT_EQ(run_then_bytes8.value(), want8) << "size " << size << " split " << split;
      ASSERT_EQ(run_then_bytes16.value(), want16) << "size " << size << " split " << split;
    }
    Crc8Smbus crc8;
    Crc16Mcrf4xx crc16;
    for (size_t i = 0; i < size; ++i) {
      crc8.update(data[i]);
      crc16.update(data[i]);
      const std::vector<uint8_t> prefix(data.begin(), data.begin() + static_cast<std::ptrdiff_t>(i + 1));
      ASSERT_EQ(crc8.value(), model_crc8_smbus(prefix)) << "after byte " << i;
      ASSERT_EQ(crc16.value(), model_crc16_mcrf4xx(prefix)) << "after byte " << i;
    }
  }
}

TEST(Crc, ResetStartsOver) {
  Crc16Mcrf4xx crc;
  crc.update(view_of("garbage"));  // 7 bytes: held, not yet taken into the register on the host
  crc.reset();
  crc.update(view_of("123456789"));
  EXPECT_EQ(crc.value(), 0x6F91);
  Crc8Smbus crc8;
  crc8.update(view_of("garbage"));
  crc8.reset();
  crc8.update(view_of("123456789"));
  EXPECT_EQ(crc8.value(), 0xF4);
}

TEST(Crc, BackendIsBoostOnTheHost) { EXPECT_STREQ(crc_backend_name(), "boost"); }

}  // namespace
}  // namespace tether
