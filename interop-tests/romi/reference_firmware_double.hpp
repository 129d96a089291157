/// @file reference_firmware_double.hpp
/// A test double that behaves like the deployed reference RomiSerial firmware, defects included, so the
/// Tether host client is checked against what it meets in the field (../shared/specs/romi.md):
///   - envelope: the payload ends at the FIRST ':'; 57 payload characters fit (58-byte buffer with NUL);
///   - B1: a 58-character payload is answered twice: `-1`, then `[0]` without running the handler;
///   - "last id" starts at 255 (B6): a request with the last id gets -15 duplicate and is not executed; a
///     manual request sets the last id to 0;
///   - error replies echo the opcode of the last successfully parsed message (`_` if none) and the id
///     parsed so far;
///   - dispatch order: -16 unknown opcode, -17 argument count, -18 missing string, -19 unexpected string,
///     handler, -20 when the handler sent nothing;
///   - four diagnostic log lines before every envelope or parse error reply, in the shape measured on the
///     reference (../shared/specs/romi.md): `#!error:xxxx`, `#!<offending byte>:xxxx` (which can be a
///     `#` or a CR; `#!crc=FC:xxxx` for a CRC mismatch), `#!<code>:xxxx`, `#!<payload so far>:xxxx`.
///     The exact texts are the double's; a host must take any such lines in its stride.
/// Sans-I/O: `feed` takes bytes from the host and returns the bytes the firmware would send.
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "tether/core/crc.hpp"

namespace tether::romi::testing {

/// Emulated reference firmware.
class ReferenceFirmwareDouble {
 public:
  /// A handler: returns the reply body (`[0]`, `[0,1,2]`, `[101,"msg"]`) or "" to send nothing.
  using Reply = std::function<std::string(const std::vector<int16_t>& args, const std::string& text)>;
  /// One row of the handler table.
  struct Handler {
    char opcode;
    uint8_t arguments;
    bool requires_string;
    Reply reply;
  };

  explicit ReferenceFirmwareDouble(std::vector<Handler> handlers);

  /// Consumes host bytes; returns what the firmware sends in answer.
  std::string feed(std::string_view bytes);
  /// How often the handler of `opcode` ran.
  int executions(char opcode) const;

 private:
  enum class State { wait_start, payload, metadata, expect_cr, expect_lf };
  std::string reply(int16_t code, uint8_t id);
  std::string diagnostics(const std::string& detail, int16_t code) const;
  std::string respond(const std::string& body, char opcode, uint8_t id);
  void error(int16_t code, std::string& out, char offending);
  void complete(std::string& out);

  std::vector<Handler> handlers_;
  std::map<char, int> executions_;
  State state_ = State::wait_start;
  std::string payload_;
  std::string metadata_;
  bool overflowed_ = false;
  Crc8Smbus running_crc_;
  uint8_t last_id_ = 255;
  char last_opcode_ = '_';
};

}  // namespace tether::romi::testing
