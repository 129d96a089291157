/* @file nanopb_descriptors_in_flash.h
 * Puts a schema's nanopb message descriptors in flash on the AVR (nanopb 0.4.7).
 *
 * A schema opts in with one line in its `<schema>.options` (next to the .proto):
 *
 *     <schema>.proto include:"<tether/proxy/device/nanopb_descriptors_in_flash.h>"
 *
 * The generator then includes this header in `<schema>.pb.h` right after <pb.h>, and every user of the
 * generated code gets it, whatever builds it: the AVR images' CMake build, the Arduino library (whose
 * nanopb code is generated from the same schema and .options) and the host tests. Here PB_BIND, which
 * `<schema>.pb.c` expands once per message, is nanopb's own (pb.h of 0.4.7) with PB_PROGMEM on all three
 * tables it defines; nanopb keeps only `_field_info` there and leaves `_submsg_info` and the `_msg`
 * descriptor in RAM (.data), 16 bytes or more per message. PB_PROGMEM is PROGMEM on the AVR and nothing
 * elsewhere: on the host the tables stay ordinary constants.
 *
 * nanopb's runtime reads `_field_info` with pgm_read_dword, but the descriptor and its `_submsg_info` with
 * ordinary loads: handing it `<Message>_fields` of such a schema reads RAM at a flash address. Code of
 * the device library passes these descriptors to nanopb only through a RAM copy of the message's
 * descriptor tree (flash_descriptors.hpp: `DescriptorCopy`, `send_message(..., FlashDescriptor, ...)`).
 * Since the header is included by the generated header, a C++ file that includes such a schema sees
 * TETHER_PB_DESCRIPTORS_IN_FLASH and can refuse to compile without it.
 *
 * PB_BIND below is pb.h's (nanopb 0.4.7) with `PB_PROGMEM` added to `_submsg_info` and `_msg`; the host
 * test `DescriptorsInFlash.BindsWhatNanopbBinds` compares every table it binds with what pb.h's PB_BIND
 * binds, so a nanopb whose PB_BIND differs fails there. */
#ifndef TETHER_PROXY_DEVICE_NANOPB_DESCRIPTORS_IN_FLASH_H
#define TETHER_PROXY_DEVICE_NANOPB_DESCRIPTORS_IN_FLASH_H

#include <pb.h>

#if PB_PROTO_HEADER_VERSION != 40
#error "nanopb_descriptors_in_flash.h redefines the PB_BIND of nanopb 0.4 (PB_PROTO_HEADER_VERSION 40)"
#endif

#define TETHER_PB_DESCRIPTORS_IN_FLASH 1

#undef PB_BIND
#define PB_BIND(msgname, structname, width) \
    const uint32_t structname ## _field_info[] PB_PROGMEM = \
    { \
        msgname ## _FIELDLIST(PB_GEN_FIELD_INFO_ ## width, structname) \
        0 \
    }; \
    const pb_msgdesc_t* const structname ## _submsg_info[] PB_PROGMEM = \
    { \
        msgname ## _FIELDLIST(PB_GEN_SUBMSG_INFO, structname) \
        NULL \
    }; \
    const pb_msgdesc_t structname ## _msg PB_PROGMEM = \
    { \
       structname ## _field_info, \
       structname ## _submsg_info, \
       msgname ## _DEFAULT, \
       msgname ## _CALLBACK, \
       0 msgname ## _FIELDLIST(PB_GEN_FIELD_COUNT, structname), \
       0 msgname ## _FIELDLIST(PB_GEN_REQ_FIELD_COUNT, structname), \
       0 msgname ## _FIELDLIST(PB_GEN_LARGEST_TAG, structname), \
    }; \
    msgname ## _FIELDLIST(PB_GEN_FIELD_INFO_ASSERT_ ## width, structname)

#endif
