/// @file io.hpp
/// How a proxy device engine reaches the outside world: a frame sink, a restart hook, message sending.
///
/// The engines (proxy_device.hpp, compat_device.hpp) are sans-I/O: bytes come in through
/// `handle_byte`, time through `now` arguments, and everything they send goes through a `FrameSink`
/// as complete frames. The images bind the sink to their UART (`Uart0::write`, which waits while the TX
/// ring is full) and the restart hook to `flush()` + `system_reset()`; the host tests bind both to
/// recorders.
#pragma once

#include <stddef.h>
#include <stdint.h>

#include <pb.h>

#include "tether/core/bytes.hpp"
#include "tether/proxy/device/flash_descriptors.hpp"
#include "tether/proxy/encoder.hpp"

namespace tether {
namespace proxy {
namespace device {

/// Where a device writes its frames: `write(context, frame)`, one call per complete frame.
struct FrameSink {
  void (*write)(void* context, ByteView frame);  ///< Must accept the whole frame (may wait).
  void* context;                                  ///< Passed back to `write`.
};

/// Restarts the device for real; on the AVR: flush the UART (the last ack must leave) then
/// `system_reset()`, never returning. Host tests record the call and return.
using RestartFunction = void (*)(void* context);

/// Largest encoded message the devices send (ArduinoOut of either schema fits: static_asserts in the
/// engines' sources).
constexpr size_t kMaxOutPayload = 64;

/// Encodes `message` (a nanopb struct described by `fields`) and writes its frame, `COBS(crc16 ‖ pb) ‖ 00`
/// or `COBS(pb) ‖ 00` per `integrity`, with a leading 00 when `leading_delimiter`. False (nothing sent)
/// when the message does not encode into kMaxOutPayload bytes. Stack: ~160 bytes plus nanopb's (~250).
bool send_message(const FrameSink& sink, Integrity integrity, bool leading_delimiter, const pb_msgdesc_t* fields,
                  const void* message);

/// `send_message` for a message whose descriptors are in flash (flash_descriptors.hpp), with
/// `kSubmessages` = TETHER_PB_SUBMESSAGE_FIELDS(message): nanopb encodes through a copy of them on the
/// stack. False (nothing sent) also when the descriptors do not fit the copy.
template <uint8_t kSubmessages>
bool send_message(const FrameSink& sink, Integrity integrity, bool leading_delimiter, FlashDescriptor fields,
                  const void* message) {
  const DescriptorCopy<kSubmessages> copy(fields);
  return copy.get() != nullptr && send_message(sink, integrity, leading_delimiter, copy.get(), message);
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
