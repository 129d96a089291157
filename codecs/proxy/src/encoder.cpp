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

#if defined(__AVR__)
// The loop below on the AVR: COBS and CRC-16/MCRF4XX (avr-libc's _crc_ccitt_update step) of `payload`
// after the two reserved bytes, in assembly: 30 cycles a byte against the compiler's ~38 (its loop moved
// its pointers between register pairs on every byte). A block's code byte is found from where the output
// is and the code itself (`out - code`), so the loop needs no third pointer. Returns the CRC, and in
// `encoded` the size written.
uint16_t encode_checked_loop(ByteView payload, uint8_t* cobs, size_t& encoded) {
  uint16_t crc = 0xFFFF;
  const uint8_t* in = payload.data();
  uint8_t* out = cobs + 3;  // the first code byte, the CRC's two reserved
  uint8_t code = 3;
  uint16_t left = static_cast<uint16_t>(payload.size());
  if (left != 0) {
    uint8_t byte;
    const uint8_t* saved;
    __asm__ __volatile__(
        "1:\n\t"
        "ld %[byte], Z+\n\t"
        "eor %A[crc], %[byte]\n\t"  // crc = _crc_ccitt_update(crc, byte)
        "mov __tmp_reg__, %A[crc]\n\t"
        "swap %A[crc]\n\t"
        "andi %A[crc], 0xf0\n\t"
        "eor %A[crc], __tmp_reg__\n\t"
        "mov __tmp_reg__, %B[crc]\n\t"
        "mov %B[crc], %A[crc]\n\t"
        "swap %A[crc]\n\t"
        "andi %A[crc], 0x0f\n\t"
        "eor __tmp_reg__, %A[crc]\n\t"
        "lsr %A[crc]\n\t"
        "eor %B[crc], %A[crc]\n\t"
        "eor %A[crc], %B[crc]\n\t"
        "lsl %A[crc]\n\t"
        "lsl %A[crc]\n\t"
        "lsl %A[crc]\n\t"
        "eor %A[crc], __tmp_reg__\n\t"
        "tst %[byte]\n\t"
        "breq 3f\n\t"
        "st X+, %[byte]\n\t"
        "inc %[code]\n\t"
        "cpi %[code], 0xFF\n\t"
        "breq 3f\n\t"  // a full block: 254 data bytes, no zero after them
        "2:\n\t"
        "sbiw %[left], 1\n\t"
        "brne 1b\n\t"
        "rjmp 4f\n\t"
        "3:\n\t"  // the block ends: its code at out - code, the next block's code byte at out
        "movw %[saved], r30\n\t"
        "movw r30, r26\n\t"
        "sub r30, %[code]\n\t"
        "sbc r31, __zero_reg__\n\t"
        "st Z, %[code]\n\t"
        "movw r30, %[saved]\n\t"
        "adiw r26, 1\n\t"
        "ldi %[code], 1\n\t"
        "rjmp 2b\n\t"
        "4:"
        : [crc] "+d"(crc), [in] "+z"(in), [out] "+x"(out), [code] "+d"(code), [left] "+w"(left), [byte] "=&r"(byte),
          [saved] "=&r"(saved)
        :
        : "memory");
  }
  *(out - code) = code;  // the last block's
  encoded = static_cast<size_t>(out - cobs);
  return crc;
}
#endif

// COBS(crc ‖ payload) into `cobs` in one pass: COBS and the CRC in the same byte loop. Out of line so
// that the loop has the registers to itself wherever encode_frame is inlined (on the AVR).
__attribute__((noinline)) size_t encode_checked(ByteView payload, uint8_t* cobs) {
#if defined(__AVR__)
  size_t encoded;
  const uint16_t crc = encode_checked_loop(payload, cobs, encoded);
#else
  detail::CobsWriter writer(cobs);
  Crc16Mcrf4xx crc_register;
  writer.reserve(2);
  for (const uint8_t byte : payload) {
    crc_register.update(byte);
    writer.put(byte);
  }
  const size_t encoded = writer.finish();
  const uint16_t crc = crc_register.value();
#endif
  // Rare: a first block of 252 payload bytes without a zero, and a zero CRC byte.
  return patch_crc(cobs, crc) ? encoded : encode_with_crc(payload, crc, cobs);
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
