/// @file flash_descriptors.hpp
/// Encoding and decoding with nanopb message descriptors kept in flash.
///
/// A schema whose `.options` includes nanopb_descriptors_in_flash.h has every table of its descriptors in
/// flash on the AVR (no RAM at all; `RocketryProto_*_msg` of rocketry.proto, ~300 B of the proxy-compat
/// image's RAM before). nanopb's runtime reads a descriptor and its submessage list with ordinary loads,
/// so it must never see their flash addresses: for each encode or decode, `DescriptorCopy` copies the
/// message's descriptor and the descriptors of its submessages from flash onto the stack (14 bytes each,
/// plus one pointer per submessage; the field tables stay in flash, where nanopb reads them anyway) and
/// hands nanopb the copy, whose lists point at the copies. On the host the "flash" is ordinary memory and
/// the copy is a memcpy: the host tests run the same code.
///
/// Cost of one copy (ATmega328P): (kSubmessages + 1) * 16 + 2 bytes of stack, for the time of the encode
/// or decode (RocketryProto.ArduinoOut: 130 B, ArduinoIn: 146 B), and about 200 cycles a descriptor (a
/// ServoControl's decode and its event's encode together: ~3500 cycles, measured in simavr).
#pragma once

#include <stddef.h>
#include <stdint.h>

#include <pb.h>

#include "tether/core/bytes.hpp"

namespace tether {
namespace proxy {
namespace device {

/// The address of a descriptor bound in flash (`<Message>_fields` of a schema that includes
/// nanopb_descriptors_in_flash.h). Never a pointer to pass to nanopb itself: the type says so.
struct FlashDescriptor {
  const pb_msgdesc_t* address;  ///< In program memory on the AVR.
};

/// Copies the descriptor at `descriptor` and the descriptors of its submessage fields from flash into
/// `descriptors[0..submessages]`, with the message's list of submessages in `list[0..submessages]`;
/// returns the copy of `descriptor`, or nullptr when the message has more than `submessages` submessage
/// fields or one of its submessages has submessages of its own (not supported: rocketry.proto has none).
const pb_msgdesc_t* copy_descriptors(FlashDescriptor descriptor, pb_msgdesc_t* descriptors, const pb_msgdesc_t** list,
                                     uint8_t submessages);

/// pb_decode of `payload` into `message` with `fields` (a RAM descriptor, e.g. `DescriptorCopy::get()`);
/// false when it fails or `fields` is nullptr.
bool decode_message(const pb_msgdesc_t* fields, ByteView payload, void* message);

/// A RAM copy of a flash descriptor and of its submessages' descriptors, for nanopb, for the copy's
/// lifetime (a local of the function that encodes or decodes). `kSubmessages`: the message's submessage
/// fields, TETHER_PB_SUBMESSAGE_FIELDS(message). `get()` is nullptr when the message does not fit (a
/// submessage with submessages of its own).
template <uint8_t kSubmessages>
class DescriptorCopy {
 public:
  explicit DescriptorCopy(FlashDescriptor descriptor)
      : root_(copy_descriptors(descriptor, descriptors_, list_, kSubmessages)) {}
  DescriptorCopy(const DescriptorCopy&) = delete;
  DescriptorCopy& operator=(const DescriptorCopy&) = delete;

  /// The copy of the descriptor, for nanopb; nullptr when the message did not fit.
  const pb_msgdesc_t* get() const { return root_; }

 private:
  pb_msgdesc_t descriptors_[kSubmessages + 1];
  const pb_msgdesc_t* list_[kSubmessages + 1];
  const pb_msgdesc_t* root_;
};

/// For the field list X-macro of a generated message: 1 for a submessage field, 0 otherwise.
#define TETHER_PB_SUBMESSAGE_FIELD(structname, atype, htype, ltype, fieldname, tag) \
  +(PB_LTYPE_IS_SUBMSG(PB_LTYPE_MAP_##ltype) ? 1 : 0)
/// The number of submessage fields of generated message `message` (e.g. RocketryProto_ArduinoIn), a
/// constant expression: `DescriptorCopy<TETHER_PB_SUBMESSAGE_FIELDS(RocketryProto_ArduinoIn)>`.
#define TETHER_PB_SUBMESSAGE_FIELDS(message) (0 message##_FIELDLIST(TETHER_PB_SUBMESSAGE_FIELD, message))

}  // namespace device
}  // namespace proxy
}  // namespace tether
