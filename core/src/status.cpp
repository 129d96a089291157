#include "tether/core/status.hpp"

namespace tether {

const char* to_string(Status status) {
  switch (status) {
    case Status::ok: return "ok";
    case Status::busy: return "busy: no free slot";
    case Status::buffer_too_small: return "buffer too small";
    case Status::frame_too_long: return "frame too long";
    case Status::crc_mismatch: return "CRC mismatch";
    case Status::framing_error: return "framing error";
    case Status::invalid_argument: return "invalid argument";
    case Status::not_found: return "not found";
    case Status::remote_error: return "remote error";
  }
  return "unknown status";
}

}  // namespace tether
