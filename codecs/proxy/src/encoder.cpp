#include "tether/proxy/encoder.hpp"

#include "tether/core/crc.hpp"

namespace tether {
namespace proxy {
namespace {

// The CRC goes in FRONT of the payload but is known only after it: the writer reserves its two bytes as
// if non-zero (the first block's code counts them) and they are patched afterwards. A zero CRC byte ends
// a block of its own: 1 (low is zero) or 2 (low, then high is zero), and the rest keeps the first block's
// end, one code byte per zero in the same positions. Not in place when the first block is full (code
// 0xFF, no zero after it): the shorter rest would need a zero that is not there; false then.
bool patch_crc(uint8_t* cobs, uint16_t crc) {
  const uint8_t low = static_cast<uint8_t>(crc & 0xFF);
  const uint8_t high = static_cast<uint8_t>(crc >> 8);
  const uint8_t first = cobs[0];
  if (low != 0 && high != 0) {
    cobs[1] = low;
    cobs[2] = high;
  } else if (first == 0xFF) {
    return false;
  } else if (low == 0) {
    cobs[0] = 1;
    cobs[1] = high == 0 ? 1 : static_cast<uint8_t>(first - 1);
    cobs[2] = high == 0 ? static_cast<uint8_t>(first - 2) : high;
  } else {
    cobs[0] = 2;
    cobs[1] = low;
    cobs[2] = static_cast<uint8_t>(first - 2);
  }
  return true;
}

// The whole frame body again, CRC known (see patch_crc); out of line: rare, and it keeps the main loop's
// registers free.
__attribute__((noinline)) size_t encode_with_crc(ByteView payload, uint16_t crc, uint8_t* cobs) {
  detail::CobsWriter writer(cobs);
  writer.put(static_cast<uint8_t>(crc & 0xFF));
  writer.put(static_cast<uint8_t>(crc >> 8));
  for (const uint8_t byte : payload) writer.put(byte);
  return writer.finish();
}

// COBS(crc ‖ payload) into `cobs` in one pass: COBS and the CRC in the same byte loop. Out of line so
// that the loop has the registers to itself wherever encode_frame is inlined (on the AVR).
__attribute__((noinline)) size_t encode_checked(ByteView payload, uint8_t* cobs) {
  detail::CobsWriter writer(cobs);
  Crc16Mcrf4xx crc;
  writer.reserve(2);
  for (const uint8_t byte : payload) {
    crc.update(byte);
    writer.put(byte);
  }
  const size_t encoded = writer.finish();
  // Rare: a first block of 252 payload bytes without a zero, and a zero CRC byte.
  return patch_crc(cobs, crc.value()) ? encoded : encode_with_crc(payload, crc.value(), cobs);
}

}  // namespace

Result<size_t> encode_frame(ByteView payload, Integrity integrity, bool leading_delimiter, MutableByteView out) {
  const bool checked = integrity == Integrity::crc16;
  const size_t raw_size = (checked ? 2 : 0) + payload.size();
  const size_t lead = leading_delimiter ? 1 : 0;
  if (out.size() < lead + cobs_max_encoded_size(raw_size) + 1) return Status::buffer_too_small;
  if (lead != 0) out[0] = 0x00;
  uint8_t* const cobs = out.data() + lead;
  size_t encoded = 0;
  if (checked) {
    encoded = encode_checked(payload, cobs);
  } else {
    detail::CobsWriter writer(cobs);
    for (const uint8_t byte : payload) writer.put(byte);
    encoded = writer.finish();
  }
  out[lead + encoded] = 0x00;
  return lead + encoded + 1;
}

}  // namespace proxy
}  // namespace tether
