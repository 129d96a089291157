// Runs firmware/selftest (avr-selftest.elf) on a simulated ATmega328P with the `simavr` command and checks
// what it reports: the avr-libc CRC back end against the check values and against the host's Boost back
// end on the same pseudo-random buffers (seeded through the EEPROM, from RANDOM_SEED), the session
// engine's device half running with AVR integer widths, the proxy frame writer's AVR loop and the Romi
// decoder's body run against its per-byte path.
#include <gtest/gtest.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "selftest_sequence.hpp"
#include "tether/core/crc.hpp"
#include "tether/testing/random_seed.hpp"

namespace tether {
namespace {

// One Intel HEX record: length, 16-bit address, type, data, two's-complement checksum.
std::string hex_record(uint16_t address, uint8_t type, const std::vector<uint8_t>& data) {
  std::vector<uint8_t> bytes = {static_cast<uint8_t>(data.size()), static_cast<uint8_t>(address >> 8),
                                static_cast<uint8_t>(address), type};
  bytes.insert(bytes.end(), data.begin(), data.end());
  unsigned sum = 0;
  std::string record = ":";
  char text[4];
  for (uint8_t byte : bytes) {
    std::snprintf(text, sizeof text, "%02X", byte);
    record += text;
    sum += byte;
  }
  std::snprintf(text, sizeof text, "%02X", (0x100 - (sum & 0xFF)) & 0xFF);
  return record + text + "\n";
}

// Intel HEX image with `seed` little-endian at EEPROM address 0 (what eeprom_read_dword reads). simavr
// maps EEPROM at 0x810000 (like avr-objcopy's .eeprom output), hence the extended linear address 0x0081.
std::string eeprom_hex(uint32_t seed) {
  return hex_record(0, 4, {0x00, 0x81}) +
         hex_record(0, 0,
                    {static_cast<uint8_t>(seed), static_cast<uint8_t>(seed >> 8), static_cast<uint8_t>(seed >> 16),
                     static_cast<uint8_t>(seed >> 24)}) +
         hex_record(0, 1, {});
}

// Runs the selftest with `seed`; returns its UART lines (simavr shows '\n' as '.' and colours lines).
std::vector<std::string> run_selftest(uint32_t seed) {
  const auto dir = std::filesystem::temp_directory_path() /
                   ("tether-selftest-" + std::to_string(::getpid()) + "-" + std::to_string(seed));
  std::filesystem::create_directories(dir);
  const auto hex = dir / "seed.hex";
  std::ofstream(hex) << eeprom_hex(seed);
  const std::string command = std::string("timeout 60 ") + TETHER_SIMAVR +
                              " -m atmega328p -f 16000000 " + TETHER_SELFTEST_ELF + " -ee " + hex.string() + " 2>&1";
  // The ELF must come first: `-ee FILE` after it loads FILE's chunks on top of the ELF's memory images.
  std::string output;
  if (FILE* pipe = ::popen(command.c_str(), "r")) {
    std::array<char, 4096> buffer;
    size_t got = 0;
    while ((got = std::fread(buffer.data(), 1, buffer.size(), pipe)) > 0) output.append(buffer.data(), got);
    ::pclose(pipe);
  }
  std::filesystem::remove_all(dir);
  output = std::regex_replace(output, std::regex("\x1b\\[[0-9;]*m"), "");
  std::vector<std::string> lines;
  std::istringstream stream(output);
  for (std::string line; std::getline(stream, line);) {
    if (!line.empty() && line.back() == '.') line.pop_back();
    if (!line.empty()) lines.push_back(line);
  }
  return lines;
}

class AvrSelftest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    seed_ = static_cast<uint32_t>(testing::random_seed());
    if (seed_ == 0 || seed_ == 0xFFFFFFFFu) seed_ = 1;
    lines_ = run_selftest(seed_);
  }
  static bool has_line(const std::string& text) {
    for (const auto& line : lines_) {
      if (line == text) return true;
    }
    return false;
  }
  static uint32_t seed_;
  static std::vector<std::string> lines_;
};
uint32_t AvrSelftest::seed_ = 0;
std::vector<std::string> AvrSelftest::lines_;

TEST_F(AvrSelftest, RanToTheEndWithoutFailures) {
  char expected[32];
  std::snprintf(expected, sizeof expected, "selftest begin seed %08x", seed_);
  EXPECT_TRUE(has_line(expected)) << "the seed did not reach the firmware through the EEPROM";
  EXPECT_TRUE(has_line("selftest end failures 00"));
}

TEST_F(AvrSelftest, AvrBackendGivesTheCheckValues) {
  EXPECT_TRUE(has_line("backend avr-libc"));
  EXPECT_TRUE(has_line("check crc8 f4 crc16 6f91"));
}

TEST_F(AvrSelftest, AvrBackendMatchesHostBackendOnRandomBuffers) {
  std::map<unsigned, std::string> reported;
  const std::regex pattern("buf ([0-9a-f]{2}) .*");
  for (const auto& line : lines_) {
    std::smatch match;
    if (std::regex_match(line, match, pattern)) reported[static_cast<unsigned>(std::stoul(match[1], nullptr, 16))] = line;
  }
  ASSERT_EQ(reported.size(), selftest::kBufferCount);
  selftest::Xorshift32 random(seed_);
  for (unsigned index = 0; index < selftest::kBufferCount; ++index) {
    std::vector<uint8_t> buffer(random.next_length());
    for (auto& byte : buffer) byte = random.next_byte();
    const ByteView view(buffer.data(), buffer.size());
    char expected[64];
    std::snprintf(expected, sizeof expected, "buf %02x %04zx %02x %04x", index, buffer.size(),
                  Crc8Smbus::compute(view), Crc16Mcrf4xx::compute(view));
    EXPECT_EQ(reported[index], expected) << "buffer " << index;
  }
}

TEST_F(AvrSelftest, EngineDeviceHalfRunsOnTheAvr) {
  for (const char* name : {"duplicate_filter", "failsafe_watchdog", "partial_frame_deadline", "request_ids",
                           "proxy_runs", "interrupt_counter"}) {
    EXPECT_TRUE(has_line(std::string("engine ") + name + " ok")) << name;
  }
}

// The frame writer's AVR assembly loop writes the bytes of the plain COBS encoding of crc16 ‖ payload.
TEST_F(AvrSelftest, FrameEncoderMatchesPlainCobsOnTheAvr) { EXPECT_TRUE(has_line("engine frame_encoder ok")); }

// The Romi decoder's body run (AVR assembly) gives what its per-byte path gives, damaged frames included.
TEST_F(AvrSelftest, RomiDecoderRunsMatchItsPerBytePathOnTheAvr) { EXPECT_TRUE(has_line("engine romi_runs ok")); }

// The Elcano decoder's run (AVR assembly for long numbers) gives what its per-byte path gives, both
// generations, damaged messages included.
TEST_F(AvrSelftest, ElcanoDecoderRunsMatchItsPerBytePathOnTheAvr) { EXPECT_TRUE(has_line("engine elcano_runs ok")); }

// The required-field test's AVR shortcut (the top byte first) says what the plain comparison says.
TEST_F(AvrSelftest, ElcanoRequiredFieldsTestMatchesThePlainComparisonOnTheAvr) {
  EXPECT_TRUE(has_line("engine elcano_required_fields ok"));
}

}  // namespace
}  // namespace tether
