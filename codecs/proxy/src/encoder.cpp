#include "tether/proxy/encoder.hpp"

#include "tether/core/crc.hpp"

namespace tether {
namespace proxy {

Result<size_t> encode_frame(ByteView payload, Integrity integrity, bool leading_delimiter, MutableByteView out) {
  // COBS works on crc ‖ payload: stage those bytes in the output's tail and encode them forward into the
  // head of the same buffer (no second buffer, which matters on the AVR).
  const size_t crc_size = integrity == Integrity::crc16 ? 2 : 0;
  const size_t raw_size = crc_size + payload.size();
  const size_t lead = leading_delimiter ? 1 : 0;
  const size_t worst = lead + cobs_max_encoded_size(raw_size) + 1;
  if (out.size() < worst) return Status::buffer_too_small;
  // Stage the raw bytes at the end of the buffer; COBS output never overtakes its input when the input
  // sits at least one byte (plus one per 254) behind, which the worst-case sizing above guarantees.
  uint8_t* raw = out.data() + (out.size() - raw_size);
  for (size_t i = payload.size(); i > 0; --i) raw[crc_size + i - 1] = payload[i - 1];
  if (crc_size != 0) {
    const uint16_t crc = Crc16Mcrf4xx::compute(payload);
    raw[0] = static_cast<uint8_t>(crc & 0xFF);
    raw[1] = static_cast<uint8_t>(crc >> 8);
  }
  if (lead != 0) out[0] = 0x00;
  const Result<size_t> encoded =
      cobs_encode(ByteView(raw, raw_size), MutableByteView(out.data() + lead, out.size() - lead - 1));
  if (!encoded.ok()) return encoded.status();
  out[lead + encoded.value()] = 0x00;
  return lead + encoded.value() + 1;
}

}  // namespace proxy
}  // namespace tether
