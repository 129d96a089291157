#include "tether/proxy/errors.hpp"

namespace tether {
namespace proxy {

const char* describe(FrameError error) {
  switch (error) {
    case FrameError::none: return "no error";
    case FrameError::frame_too_long: return "frame too long";
    case FrameError::framing_error: return "framing error";
    case FrameError::crc_mismatch: return "CRC mismatch";
  }
  return "unknown error";
}

}  // namespace proxy
}  // namespace tether
