// What an RSerial holds of Tether (private to the compat library): the port's stream and the thread that
// runs it, shared with the RomiSerialClient that takes the port over.
#pragma once

#include <chrono>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "RSerial.h"
#include "tether/transports/byte_stream.hpp"
#include "tether/transports/io_thread.hpp"

namespace romiserial {

struct RSerial::Link {
  std::string device;
  // Declared first: destroyed last, after the stream and any client running on it.
  tether::transports::IoThread io;
  std::shared_ptr<tether::transports::ByteStream> stream;
  std::mutex mutex;  // guards what follows (RSerial's own reads and writes, the hand-over)
  std::chrono::milliseconds timeout{100};
  std::optional<char> pending;  // the byte `available()` saw
  bool taken = false;           // a RomiSerialClient owns the stream's reading

  ~Link() {
    if (stream) {
      boost::system::error_code ignored;
      stream->close(ignored);
    }
  }
};

}  // namespace romiserial
