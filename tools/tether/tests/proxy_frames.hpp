// A device's proxy message as the bytes on the wire (COBS, CRC-16, the closing 0x00), for the command tests
// that play a device or edit a capture.
#pragma once

#include <gtest/gtest.h>

#include <cstdint>
#include <string>

#include "tether/core/status.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether_proxy.pb.h"

namespace tether::cli::testing {

/// `message` encoded as a proxy frame (a test failure if it does not fit 64 payload bytes).
inline std::string proxy_frame(const proxy::ArduinoOut& message) {
  const std::string payload = message.SerializeAsString();
  std::uint8_t frame[proxy::max_frame_size(64)];
  const Result<std::size_t> written = proxy::encode_frame(ByteView::from_chars(payload.data(), payload.size()),
                                                          proxy::Integrity::crc16, false, MutableByteView(frame));
  EXPECT_TRUE(written.ok());
  return std::string(reinterpret_cast<const char*>(frame), written.ok() ? written.value() : 0);
}

}  // namespace tether::cli::testing
