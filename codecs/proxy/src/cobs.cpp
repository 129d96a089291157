#include "tether/proxy/cobs.hpp"

namespace tether {
namespace proxy {

Result<size_t> cobs_encode(ByteView input, MutableByteView out) {
  if (out.size() < cobs_max_encoded_size(input.size())) {
    // Exact size check only when the worst case does not fit (most callers size for the worst case).
    size_t needed = 1;
    uint8_t run = 1;
    for (uint8_t byte : input) {
      if (byte == 0x00 || run == 0xFF) {
        ++needed;
        run = 1;
        if (byte == 0x00) continue;
      }
      ++needed;
      ++run;
    }
    if (needed > out.size()) return Status::buffer_too_small;
  }
  detail::CobsWriter writer(out.data());
  for (uint8_t byte : input) writer.put(byte);
  return writer.finish();
}

Result<size_t> cobs_decode(ByteView input, MutableByteView out) {
  size_t read = 0;
  size_t write = 0;
  while (read < input.size()) {
    const uint8_t code = input[read++];
    if (code == 0x00) return Status::framing_error;
    for (uint8_t i = 1; i < code; ++i) {
      if (read >= input.size() || input[read] == 0x00) return Status::framing_error;
      if (write >= out.size()) return Status::buffer_too_small;
      out[write++] = input[read++];
    }
    if (code != 0xFF && read < input.size()) {
      if (write >= out.size()) return Status::buffer_too_small;
      out[write++] = 0x00;
    }
  }
  return write;
}

}  // namespace proxy
}  // namespace tether
