/// @file read_exactly.hpp
/// Reading a known number of bytes from a stream in a test (an echo, a banner).
#pragma once

#include <chrono>
#include <cstddef>
#include <string>

#include "tether/transports/byte_stream.hpp"

namespace tether::transports::testing {

/// Reads exactly `size` bytes from `stream`, each blocking read waiting at most `timeout` (throws
/// `boost::system::system_error` when one times out).
inline std::string read_exactly(ByteStream& stream, std::size_t size, std::chrono::milliseconds timeout) {
  std::string result(size, '\0');
  std::size_t total = 0;
  while (total < size) total += stream.read_some(asio::buffer(result.data() + total, size - total), timeout);
  return result;
}

}  // namespace tether::transports::testing
