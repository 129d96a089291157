/// @file service.hpp
/// A schema's service as the device runtime sees it: one entry per method, in the schema's order, each
/// with its request's decoder, its reply's encoder (message_codec.hpp: `tether_rpc_decode_<T>`,
/// `tether_rpc_encode_<T>`) and the application's handler. `tether generate` writes this table
/// for a schema (with a thunk per method that calls the sketch's `<Service>_<Method>` with its typed
/// structs, so that a missing handler is a link error naming it); tests write it by hand. The Service and
/// its Method table are declared `TETHER_IN_FLASH` (text.hpp): the runtime reads them with
/// `copy_from_flash`, and on the AVR they take no RAM.
#pragma once

#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "tether/proxy/device/text.hpp"
#include "tether/rpc/device/message_codec.hpp"
#include "tether/rpc/device/status.hpp"

namespace tether {
namespace rpc {
namespace device {

/// A method's handler on untyped structs: `request` is the decoded request (the method's input type),
/// `reply` a zeroed struct of its output type to fill in. For a streaming method it is called once per
/// period with the stream's request and fills in the next message.
using Handler = Status (*)(const void* request, void* reply);

/// Decodes `size` bytes into a zeroed struct of a message type; false when they are refused.
using DecodeFunction = bool (*)(const uint8_t* data, size_t size, void* message);
/// Encodes a struct of a message type; false when it did not fit or a field is over its bound.
using EncodeFunction = bool (*)(wire::Writer& out, const void* message);

/// Copies `size` bytes of an object declared `TETHER_IN_FLASH` (`memcpy_P` on the AVR).
inline void copy_from_flash(void* out, const void* in_flash, size_t size) {
#if defined(__AVR__)
  memcpy_P(out, in_flash, size);
#else
  memcpy(out, in_flash, size);
#endif
}

/// One method.
struct Method {
  DecodeFunction decode_request;  ///< The input type's decoder.
  EncodeFunction encode_reply;    ///< The output type's encoder.
  Handler handler;              ///< The application's handler.
  bool streaming;               ///< Server streaming (`returns (stream T)`).
};

/// The service: its methods (the structs they decode into and fill are on the device's stack, sized by its
/// limits: rpc_device.hpp).
struct Service {
  uint64_t schema_hash;  ///< `tether::rpc::schema_hash` of the schema (host side: schema.hpp).
  const Method* methods;  ///< In the schema's order: the wire's method index (in flash).
  uint8_t method_count;   ///< Entries of `methods`.
};

}  // namespace device
}  // namespace rpc
}  // namespace tether
