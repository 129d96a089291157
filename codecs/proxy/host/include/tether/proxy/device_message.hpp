/// @file device_message.hpp
/// Parsing what a device sent without losing a message to bad text. libprotobuf refuses a proto3 message
/// one of whose `string` fields is not UTF-8 (and logs a line on stderr), but a device's `Error.text` is
/// whatever bytes its firmware wrote: a message that says something went wrong must not vanish because
/// of how it says it. `parse_device_message` keeps such a message, the bytes that are not UTF-8 written
/// as `\xNN`, and never logs.
#pragma once

#include <google/protobuf/message.h>

#include "tether/core/bytes.hpp"

namespace tether::proxy {

/// Parses `payload` into `message` (cleared first). A `string` field, at any depth, whose bytes are not
/// UTF-8 is kept with each such byte replaced by the four characters `\xNN` (lowercase hex); valid UTF-8
/// is kept as it is. False when the bytes are not a message of that type for any other reason.
bool parse_device_message(google::protobuf::Message& message, ByteView payload);

}  // namespace tether::proxy
