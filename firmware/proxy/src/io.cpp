// Message sending: see tether/proxy/device/io.hpp.
#include "tether/proxy/device/io.hpp"

#include <pb_encode.h>

namespace tether {
namespace proxy {
namespace device {

bool send_message(const FrameSink& sink, Integrity integrity, bool leading_delimiter, const pb_msgdesc_t* fields,
                  const void* message) {
  uint8_t payload[kMaxOutPayload];
  pb_ostream_t stream = pb_ostream_from_buffer(payload, sizeof(payload));
  if (!pb_encode(&stream, fields, message)) return false;
  uint8_t frame[max_frame_size(kMaxOutPayload)];
  const Result<size_t> framed =
      encode_frame(ByteView(payload, stream.bytes_written), integrity, leading_delimiter, MutableByteView(frame));
  if (!framed.ok()) return false;
  sink.write(sink.context, ByteView(frame, framed.value()));
  return true;
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
