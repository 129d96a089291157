// Exactly-once figures from the firmware's execution witness; see exactly_once.hpp.
#include "tether/demo/exactly_once.hpp"

#include <array>

#include "tether/core/execution_witness.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::demo {

std::optional<ExecutionWitness> ExecutionWitness::attach(transports::VirtualUno& board) {
  const std::optional<transports::FirmwareSymbol> symbol = board.symbol("tether_execution_witness");
  if (!symbol || symbol->space != transports::FirmwareSymbol::Space::data || symbol->size != kWitnessRecordSize) {
    return std::nullopt;
  }
  return ExecutionWitness(board, static_cast<std::uint16_t>(symbol->address));
}

ExecutionWitness::Reading ExecutionWitness::read() {
  const std::vector<std::uint8_t> record = board_->read_memory(address_, kWitnessRecordSize);
  Reading reading;
  const std::uint8_t executed = record[kWitnessExecutedOffset];
  // A boot clears .bss byte by byte, `executed` (offset 0) before the mark (offset 1): a read between the
  // two sees a count of 0 under a mark still set. More fresh commands than the log holds, from a count of
  // 0, is that torn record (the demo reads after every operation): nothing is counted, and the next read
  // sees the zero mark and the restarted count.
  if (executed == 0 && record[kWitnessHostMarkOffset] != 0 &&
      static_cast<std::uint8_t>(executed - seen_) > kWitnessLogSize) {
    return reading;
  }
  // A zero mark: the SRAM was cleared by a boot since the last read, and the count restarted from 0.
  reading.rebooted = record[kWitnessHostMarkOffset] == 0;
  if (reading.rebooted) seen_ = 0;
  const auto fresh = static_cast<std::uint8_t>(executed - seen_);
  const std::uint8_t kept = fresh > kWitnessLogSize ? kWitnessLogSize : fresh;
  reading.unobserved = static_cast<std::uint32_t>(fresh - kept);
  for (std::uint8_t n = 0; n < kept; ++n) {
    const auto number = static_cast<std::uint8_t>(executed - kept + n);
    const std::size_t slot = kWitnessLogOffset + 4u * (number % kWitnessLogSize);
    reading.keys.push_back(static_cast<std::uint32_t>(record[slot]) | static_cast<std::uint32_t>(record[slot + 1]) << 8 |
                           static_cast<std::uint32_t>(record[slot + 2]) << 16 |
                           static_cast<std::uint32_t>(record[slot + 3]) << 24);
  }
  seen_ = executed;
  if (reading.rebooted) {
    const std::array<std::uint8_t, 1> mark{1};
    board_->write_memory(static_cast<std::uint16_t>(address_ + kWitnessHostMarkOffset), mark);
  }
  return reading;
}

std::uint64_t ExactlyOnceLedger::issued(std::uint32_t key) {
  if (recent_.size() == kAttributionWindow) {
    count(recent_.front(), retired_);
    recent_.pop_front();
    ++first_index_;
  }
  recent_.push_back(Command{key, false, false, 0});
  return first_index_ + recent_.size() - 1;
}

void ExactlyOnceLedger::outcome(std::uint64_t index, bool confirmed) {
  if (index < first_index_ || index - first_index_ >= recent_.size()) return;  // left the window already
  Command& command = recent_[static_cast<std::size_t>(index - first_index_)];
  command.ended = true;
  command.confirmed = confirmed;
}

void ExactlyOnceLedger::executed(std::uint32_t key) {
  for (auto command = recent_.rbegin(); command != recent_.rend(); ++command) {
    if (command->key == key) {
      ++command->executions;
      return;
    }
  }
  ++unsent_;
}

void ExactlyOnceLedger::add(const ExecutionWitness::Reading& reading) {
  for (const std::uint32_t key : reading.keys) executed(key);
  unobserved_ += reading.unobserved;
}

void ExactlyOnceLedger::count(const Command& command, ExactlyOnce& into) const {
  ++into.commands;
  if (command.confirmed) ++into.confirmed;
  if (command.executions > 0) ++into.executed;
  if (command.executions > 1) ++into.executed_twice;
  if (command.executions > 0 && command.ended && !command.confirmed) ++into.executed_but_failed;
  if (command.executions == 0 && command.confirmed) ++into.confirmed_not_executed;
}

ExactlyOnce ExactlyOnceLedger::figures() const {
  ExactlyOnce figures = retired_;
  for (const Command& command : recent_) count(command, figures);
  figures.executed_unsent = unsent_;
  figures.unobserved = unobserved_;
  return figures;
}

}  // namespace tether::demo
