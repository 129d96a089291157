/// @file exactly_once.hpp
/// Exactly-once, measured: what the host was told about each command (confirmed or failed) against what
/// the device executed, read from the firmware's execution witness (tether/core/execution_witness.hpp).
///
/// `ExecutionWitness` reads the log of a virtual Uno whose image links the recorder; `ExactlyOnceLedger`
/// attributes each execution to a command. Attribution works by key: each command's key is its parameters,
/// which the workload changes every operation, so the newest command sent with that key among the last
/// `kAttributionWindow` ones is the one that ran (keys repeat only after hundreds of operations, and
/// executions show up within a few operations of their command). An execution whose key matches no
/// recent command is counted apart (`executed_unsent`: e.g. values corrupted on a link without a CRC).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <optional>
#include <vector>

namespace tether::transports {
class VirtualUno;
}

namespace tether::demo {

/// The exactly-once figures of one device over a run (commands: what the device executes one by one,
/// e.g. one Romi call, or each of a proxy operation's ServoControl messages).
struct ExactlyOnce {
  std::uint64_t commands = 0;     ///< Commands the host issued.
  std::uint64_t confirmed = 0;    ///< Of those, confirmed to the caller (unconfirmed protocols: written).
  std::uint64_t executed = 0;     ///< Commands the device executed at least once.
  std::uint64_t executed_twice = 0;          ///< Commands executed more than once.
  std::uint64_t executed_but_failed = 0;     ///< Executed, but the caller was told it failed.
  std::uint64_t confirmed_not_executed = 0;  ///< Confirmed to the caller, never executed.
  std::uint64_t executed_unsent = 0;  ///< Executions matching no command sent (corrupted values).
  std::uint64_t unobserved = 0;       ///< Executions counted by the device whose keys the log lost.
};

/// Reader of a virtual Uno's execution witness. Not thread-safe.
class ExecutionWitness {
 public:
  /// Nullopt when the board's image has no recorder (no `tether_execution_witness` symbol).
  static std::optional<ExecutionWitness> attach(transports::VirtualUno& board);

  /// What the device executed since the last read.
  struct Reading {
    std::vector<std::uint32_t> keys;  ///< Keys of the new executions, oldest first.
    std::uint32_t unobserved = 0;     ///< New executions whose slots were overwritten before this read.
    bool rebooted = false;            ///< The device booted since the last read (its count restarted).
  };
  /// Reads the new executions and marks the record as read. Read before injecting a reset: what ran
  /// between the last read and a reboot is lost with the SRAM.
  Reading read();

 private:
  ExecutionWitness(transports::VirtualUno& board, std::uint16_t address) : board_(&board), address_(address) {}
  transports::VirtualUno* board_;
  std::uint16_t address_;
  std::uint8_t seen_ = 0;  // the device's `executed` at the last read
};

/// Attribution of executions to commands, and the figures.
class ExactlyOnceLedger {
 public:
  /// How many of the newest commands an execution may belong to.
  static constexpr std::size_t kAttributionWindow = 64;

  /// A command was issued with witness key `key`; returns its index for `outcome`.
  std::uint64_t issued(std::uint32_t key);
  /// How command `index` ended for the caller (call once per command).
  void outcome(std::uint64_t index, bool confirmed);
  /// The device executed a command with `key`.
  void executed(std::uint32_t key);
  /// Adds a witness reading (its keys and unobserved executions).
  void add(const ExecutionWitness::Reading& reading);
  /// The figures so far (a command still inside the window counts with what is known now).
  ExactlyOnce figures() const;

 private:
  struct Command {
    std::uint32_t key = 0;
    bool confirmed = false;
    bool ended = false;
    std::uint32_t executions = 0;
  };
  void count(const Command& command, ExactlyOnce& into) const;
  std::deque<Command> recent_;     // the attribution window, oldest first
  std::uint64_t first_index_ = 0;  // index of recent_.front()
  ExactlyOnce retired_;            // figures of the commands that left the window
  std::uint64_t unsent_ = 0;
  std::uint64_t unobserved_ = 0;
};

}  // namespace tether::demo
