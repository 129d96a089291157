/// @file encoder.hpp
/// The Elcano message writer (the wire format: message.hpp; the reader: decoder.hpp).
#pragma once

#include <stddef.h>

#include "tether/core/bytes.hpp"
#include "tether/core/status.hpp"
#include "tether/elcano/message.hpp"

namespace tether {
namespace elcano {

/// Writes `message` (with its trailing `\n`) in `generation`. `Status::invalid_argument` when a required
/// field is missing or the type is unknown; `Status::buffer_too_small`.
Result<size_t> encode_message(const Message& message, Generation generation, MutableByteView out);


}  // namespace elcano
}  // namespace tether
