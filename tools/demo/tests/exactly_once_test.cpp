// The exactly-once witness: attribution of executions to commands, and the firmware's record read back from
// a virtual Uno (romi-rover image), where a request repeated on the wire must run once.
#include "tether/demo/exactly_once.hpp"

#include <gtest/gtest.h>

#include <array>
#include <chrono>
#include <string>

#include "tether/core/execution_witness.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/testing/random_seed.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::demo {
namespace {

using namespace std::chrono_literals;

TEST(ExactlyOnceLedger, EachExecutionGoesToTheNewestCommandWithItsKey) {
  ExactlyOnceLedger ledger;
  const std::uint64_t a = ledger.issued(1);
  const std::uint64_t b = ledger.issued(2);
  const std::uint64_t c = ledger.issued(3);
  const std::uint64_t d = ledger.issued(4);
  ledger.outcome(a, true);   // confirmed, ran
  ledger.outcome(b, true);   // confirmed, never ran
  ledger.outcome(c, false);  // failed, but ran (twice)
  ledger.outcome(d, false);  // failed, never ran
  ledger.executed(1);
  ledger.executed(3);
  ledger.executed(3);
  ledger.executed(99);  // nothing sent with that key
  ExecutionWitness::Reading reading;
  reading.unobserved = 2;
  ledger.add(reading);
  const ExactlyOnce e = ledger.figures();
  EXPECT_EQ(e.commands, 4u);
  EXPECT_EQ(e.confirmed, 2u);
  EXPECT_EQ(e.executed, 2u);
  EXPECT_EQ(e.executed_twice, 1u);
  EXPECT_EQ(e.executed_but_failed, 1u);
  EXPECT_EQ(e.confirmed_not_executed, 1u);
  EXPECT_EQ(e.executed_unsent, 1u);
  EXPECT_EQ(e.unobserved, 2u);
}

TEST(ExactlyOnceLedger, ARepeatedKeyGoesToTheNewestCommandAndOldCommandsKeepTheirFigures) {
  ExactlyOnceLedger ledger;
  const std::uint64_t first = ledger.issued(7);
  ledger.outcome(first, true);
  ledger.executed(7);
  // Far more commands than the window: the first one retires with its figures.
  for (std::size_t i = 0; i < 2 * ExactlyOnceLedger::kAttributionWindow; ++i) {
    ledger.outcome(ledger.issued(static_cast<std::uint32_t>(1000 + i)), true);
    ledger.executed(static_cast<std::uint32_t>(1000 + i));
  }
  const std::uint64_t again = ledger.issued(7);
  ledger.outcome(again, true);
  ledger.executed(7);
  ledger.outcome(first, false);  // out of the window: ignored
  const ExactlyOnce e = ledger.figures();
  EXPECT_EQ(e.commands, 2 + 2 * ExactlyOnceLedger::kAttributionWindow);
  EXPECT_EQ(e.executed, e.commands);
  EXPECT_EQ(e.confirmed, e.commands);
  EXPECT_EQ(e.executed_twice, 0u);
  EXPECT_EQ(e.executed_unsent, 0u);
}

// The romi-rover image on a board this thread advances (simulated time only: deterministic).
class RomiRoverWitness : public ::testing::Test {
 protected:
  RomiRoverWitness() : board_(options()) {
    for (int i = 0; i < 2000 && !board_.uart().rx_enabled; ++i) board_.run_for(1ms);
  }
  static transports::VirtualUnoOptions options() {
    transports::VirtualUnoOptions options;
    options.firmware = TETHER_FIRMWARE_DIR "/romi-rover.elf";
    options.pacing = transports::Pacing::fast;
    options.seed = testing::random_seed();
    return options;
  }
  // Writes the request frame `payload` with `id` and gives the board time to answer it.
  void request(const std::string& payload, std::uint8_t id) {
    std::uint8_t frame[96];
    const Result<std::size_t> size = romi::encode_request(ByteView::from_chars(payload.data(), payload.size()), id,
                                                          MutableByteView(frame, sizeof frame));
    ASSERT_TRUE(size.ok());
    board_.write(std::span<const std::uint8_t>(frame, size.value()));
    board_.run_for(30ms);
  }
  transports::VirtualUno board_;
};

TEST_F(RomiRoverWitness, ARequestRepeatedOnTheWireRunsOnceAndTheWitnessCountsARealSecondRun) {
  ASSERT_TRUE(board_.uart().rx_enabled);
  std::optional<ExecutionWitness> witness = ExecutionWitness::attach(board_);
  ASSERT_TRUE(witness.has_value()) << "romi-rover links the execution witness";
  EXPECT_TRUE(witness->read().rebooted);  // the first read: nothing marked yet
  ExactlyOnceLedger ledger;
  ledger.outcome(ledger.issued(witness_key(1200, 1800)), true);
  request("S[1200,1800]", 7);
  request("S[1200,1800]", 7);  // the same frame again (a re-send): answered from the reply cache
  ExecutionWitness::Reading reading = witness->read();
  EXPECT_FALSE(reading.rebooted);
  EXPECT_EQ(reading.keys, (std::vector<std::uint32_t>{witness_key(1200, 1800)}));
  ledger.add(reading);
  EXPECT_EQ(ledger.figures().executed, 1u);
  EXPECT_EQ(ledger.figures().executed_twice, 0u) << "a repeated request ran again";

  // A new id with the same values is a new command and runs: the witness counts it even though the pins
  // cannot tell.
  request("S[1200,1800]", 8);
  ledger.add(witness->read());
  EXPECT_EQ(ledger.figures().executed_twice, 1u);

  // A reboot clears the record; the reader starts over from the new boot's count.
  board_.reset(transports::ResetKind::power_cycle, 10ms);
  board_.run_for(300ms);
  reading = witness->read();
  EXPECT_TRUE(reading.rebooted);
  EXPECT_TRUE(reading.keys.empty());
  request("S[1300,1700]", 9);
  reading = witness->read();
  EXPECT_FALSE(reading.rebooted);
  EXPECT_EQ(reading.keys, (std::vector<std::uint32_t>{witness_key(1300, 1700)}));
}

// A boot clears .bss a byte at a time: the count (offset 0) before the host's mark (offset 1). A read in
// between sees a count of 0 under a mark still set, which is no count the device ever had: left for the next
// read, not taken for ~250 executions the log lost.
TEST_F(RomiRoverWitness, ARecordTornByABootClearingItIsLeftForTheNextRead) {
  ASSERT_TRUE(board_.uart().rx_enabled);
  std::optional<ExecutionWitness> witness = ExecutionWitness::attach(board_);
  ASSERT_TRUE(witness.has_value());
  witness->read();
  request("S[1200,1800]", 7);
  request("S[1300,1700]", 8);
  request("S[1400,1600]", 9);
  ExecutionWitness::Reading reading = witness->read();
  ASSERT_EQ(reading.keys.size(), 3u);
  const std::optional<transports::FirmwareSymbol> record = board_.symbol("tether_execution_witness");
  ASSERT_TRUE(record.has_value());
  const auto address = static_cast<std::uint16_t>(record->address);

  const std::array<std::uint8_t, 1> zero{0};
  board_.write_memory(static_cast<std::uint16_t>(address + kWitnessExecutedOffset), zero);  // the boot's first byte
  reading = witness->read();
  EXPECT_FALSE(reading.rebooted);
  EXPECT_TRUE(reading.keys.empty());
  EXPECT_EQ(reading.unobserved, 0u) << "a torn record counted as lost executions";

  board_.write_memory(static_cast<std::uint16_t>(address + kWitnessHostMarkOffset), zero);  // and its second
  reading = witness->read();
  EXPECT_TRUE(reading.rebooted);
  EXPECT_TRUE(reading.keys.empty());
  EXPECT_EQ(reading.unobserved, 0u);
  ExactlyOnceLedger ledger;
  ledger.add(reading);
  EXPECT_EQ(ledger.figures().unobserved, 0u);
}

}  // namespace
}  // namespace tether::demo
