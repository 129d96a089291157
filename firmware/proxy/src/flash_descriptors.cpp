// Descriptor copies from flash: see tether/proxy/device/flash_descriptors.hpp.
#include "tether/proxy/device/flash_descriptors.hpp"

#include <string.h>

#include <pb_decode.h>

#if defined(__AVR__)
#include <avr/pgmspace.h>
#endif

namespace tether {
namespace proxy {
namespace device {

namespace {

// Flash addresses below 64 KiB (the ATmega328P has 32 KiB): the near program-memory reads reach them.
const pb_msgdesc_t* read_flash_pointer(const pb_msgdesc_t* const* from) {
#if defined(__AVR__)
  return reinterpret_cast<const pb_msgdesc_t*>(pgm_read_word(from));
#else
  return *from;
#endif
}

void read_flash_descriptor(pb_msgdesc_t* to, const pb_msgdesc_t* from) {
#if defined(__AVR__)
  memcpy_P(to, from, sizeof *to);
#else
  memcpy(to, from, sizeof *to);
#endif
}

}  // namespace

const pb_msgdesc_t* copy_descriptors(FlashDescriptor descriptor, pb_msgdesc_t* descriptors, const pb_msgdesc_t** list,
                                     uint8_t submessages) {
  pb_msgdesc_t* const root = descriptors;
  read_flash_descriptor(root, descriptor.address);
  const pb_msgdesc_t* const* from = root->submsg_info;
  root->submsg_info = list;
  const pb_msgdesc_t** const last = list + submessages;
  *last = nullptr;  // ends the message's list; also the (empty) list of every copy below
  for (const pb_msgdesc_t* submessage; (submessage = read_flash_pointer(from++)) != nullptr;) {
    if (list == last) return nullptr;  // more submessage fields than room
    pb_msgdesc_t* const copy = ++descriptors;
    read_flash_descriptor(copy, submessage);
    if (read_flash_pointer(copy->submsg_info) != nullptr) return nullptr;  // a submessage with submessages
    copy->submsg_info = last;
    *list++ = copy;
  }
  *list = nullptr;
  return root;
}

bool decode_message(const pb_msgdesc_t* fields, ByteView payload, void* message) {
  if (fields == nullptr) return false;
  pb_istream_t stream = pb_istream_from_buffer(payload.data(), payload.size());
  return pb_decode(&stream, fields, message);
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
