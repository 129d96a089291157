/// @file errors.hpp
/// Why an Elcano message was dropped: the reference reader's outcome names, plus Tether's. The decoder
/// sets bad_type .. too_long; a ring node adds timed_out and queue_full.
#pragma once

#include <stdint.h>

namespace tether {
namespace elcano {

/// A dropped message's cause (the decoder's and the ring node's `error()`).
enum class Error : uint8_t {
  success = 0,  ///< A complete, valid message.
  bad_type,     ///< The header is not D, S, G or X.
  bad_lcurly,   ///< Expected `{` (or the end of the message).
  bad_attrib,   ///< Unknown attribute letter.
  bad_number,   ///< Malformed number, or outside int32 (never wrapped).
  inval_comb,   ///< A field the type requires is missing.
  bad_crc,      ///< Generation D: the checksum does not match.
  too_long,     ///< More bytes than the decoder holds.
  timed_out,    ///< A partial message older than its deadline was dropped (set by the node, not the decoder).
  queue_full,   ///< A message to forward found the node's output queue full (set by the node).
};

/// Short name of `error` (the reference's where it has one: `bad_crc`, ...); never null.
const char* describe(Error error);


}  // namespace elcano
}  // namespace tether
