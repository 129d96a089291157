// The device's message codec (message_codec.hpp) against nanopb on the same structs: the codec test's
// schema (schemas/codec.proto) decoded and encoded both ways. Shared by the unit test and the fuzz target.
#pragma once

#include <pb_decode.h>
#include <pb_encode.h>

#include <cstdint>
#include <cstring>
#include <string>

#include "codec.pb.h"
#include "tether/rpc/device/envelope.hpp"
#include "tether/rpc/device/message_codec.hpp"
#include "tether_rpc.pb.h"

TETHER_RPC_MESSAGE_DECLARE(codec_Inner)
TETHER_RPC_MESSAGE_DECLARE(codec_Deep)
TETHER_RPC_MESSAGE_DECLARE(codec_All)

namespace codec_check {

/// What differed between nanopb and the codec on one input (empty: nothing).
struct Difference {
  std::string what;
  explicit operator bool() const { return !what.empty(); }
};

/// Encodes `message` both ways into `capacity` bytes: the same success and, on success, the same bytes.
template <class M>
Difference compare_encode(const pb_msgdesc_t* fields, bool (*ours)(tether::rpc::device::wire::Writer&, const void*),
                          const M& message, std::size_t capacity) {
  std::uint8_t theirs_out[1024];
  std::uint8_t ours_out[1024];
  if (capacity > sizeof theirs_out) capacity = sizeof theirs_out;
  pb_ostream_t stream = pb_ostream_from_buffer(theirs_out, capacity);
  const bool theirs_ok = pb_encode(&stream, fields, &message);
  tether::rpc::device::wire::Writer writer(ours_out, capacity);
  const bool ours_ok = ours(writer, &message);
  if (theirs_ok != ours_ok) {
    return {std::string("encode: nanopb ") + (theirs_ok ? "accepts" : "refuses") + ", the codec " +
            (ours_ok ? "accepts" : "refuses") + " (capacity " + std::to_string(capacity) + ")"};
  }
  if (theirs_ok && (stream.bytes_written != writer.size() ||
                    std::memcmp(theirs_out, ours_out, stream.bytes_written) != 0)) {
    return {"encode: different bytes (" + std::to_string(stream.bytes_written) + " by nanopb, " +
            std::to_string(writer.size()) + " by the codec)"};
  }
  return {};
}

/// Decodes `data` both ways (each from a zeroed struct): the same outcome and, when accepted, the same
/// struct; then encodes it both ways, with room and with less than needed.
template <class M>
Difference compare(const pb_msgdesc_t* fields, bool (*decode)(const std::uint8_t*, std::size_t, void*),
                   bool (*encode)(tether::rpc::device::wire::Writer&, const void*), const std::uint8_t* data,
                   std::size_t size, std::size_t short_capacity) {
  M theirs;
  M ours;
  std::memset(&theirs, 0, sizeof theirs);
  std::memset(&ours, 0xA5, sizeof ours);  // the codec starts from zero itself
  pb_istream_t stream = pb_istream_from_buffer(data, size);
  const bool theirs_ok = pb_decode(&stream, fields, &theirs);
  const bool ours_ok = decode(data, size, &ours);
  if (theirs_ok != ours_ok) {
    return {std::string("decode: nanopb ") + (theirs_ok ? "accepts" : "refuses") + ", the codec " +
            (ours_ok ? "accepts" : "refuses")};
  }
  if (!theirs_ok) return {};
  if (std::memcmp(&theirs, &ours, sizeof theirs) != 0) return {"decode: different structs"};
  if (Difference d = compare_encode(fields, encode, theirs, sizeof(std::uint8_t[1024]))) return d;
  return compare_encode(fields, encode, theirs, short_capacity);
}

/// The envelope's hand-written decoder (envelope.hpp) against nanopb's on one input: the same outcome and,
/// when accepted, the same struct.
inline Difference compare_envelope(const std::uint8_t* data, std::size_t size) {
  tether_rpc_wire_HostMessage theirs;
  tether_rpc_wire_HostMessage ours;
  std::memset(&theirs, 0, sizeof theirs);
  std::memset(&ours, 0xA5, sizeof ours);  // the decoder starts from zero itself
  pb_istream_t stream = pb_istream_from_buffer(data, size);
  const bool theirs_ok = pb_decode(&stream, tether_rpc_wire_HostMessage_fields, &theirs);
  const bool ours_ok = tether::rpc::device::decode_host_message(data, size, ours);
  if (theirs_ok != ours_ok) {
    return {std::string("HostMessage: nanopb ") + (theirs_ok ? "accepts" : "refuses") + ", the decoder " +
            (ours_ok ? "accepts" : "refuses")};
  }
  if (theirs_ok && std::memcmp(&theirs, &ours, sizeof theirs) != 0) return {"HostMessage: different structs"};
  return {};
}

/// Every message type of the schema, and the envelope, on one input.
inline Difference compare_all(const std::uint8_t* data, std::size_t size, std::size_t short_capacity) {
  if (Difference d = compare<codec_All>(codec_All_fields, &tether_rpc_decode_codec_All, &tether_rpc_encode_codec_All,
                                        data, size, short_capacity)) {
    return {"All: " + d.what};
  }
  if (Difference d = compare<codec_Inner>(codec_Inner_fields, &tether_rpc_decode_codec_Inner,
                                          &tether_rpc_encode_codec_Inner, data, size, short_capacity)) {
    return {"Inner: " + d.what};
  }
  if (Difference d = compare<codec_Deep>(codec_Deep_fields, &tether_rpc_decode_codec_Deep,
                                         &tether_rpc_encode_codec_Deep, data, size, short_capacity)) {
    return {"Deep: " + d.what};
  }
  return compare_envelope(data, size);
}

}  // namespace codec_check
