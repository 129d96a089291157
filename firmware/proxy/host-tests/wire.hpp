// Test helpers: a device's output collected as frames, and host messages built with nanopb.
#pragma once

#include <pb_decode.h>
#include <pb_encode.h>

#include <cstdint>
#include <stdexcept>
#include <vector>

#include "tether/core/bytes.hpp"
#include "tether/core/counters.hpp"
#include "tether/proxy/device/io.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"

namespace wire {

using Bytes = std::vector<uint8_t>;

/// Collects what a device writes; `sink()` is its FrameSink, `restarts` counts the restart hook.
struct Recorder {
  Bytes bytes;
  std::vector<Bytes> frames;  // one entry per FrameSink::write call
  int restarts = 0;
  size_t bytes_at_restart = 0;

  tether::proxy::device::FrameSink sink() { return tether::proxy::device::FrameSink{&Recorder::write, this}; }
  static void write(void* self, tether::ByteView frame) {
    auto& recorder = *static_cast<Recorder*>(self);
    recorder.bytes.insert(recorder.bytes.end(), frame.begin(), frame.end());
    recorder.frames.emplace_back(frame.begin(), frame.end());
  }
  static void restart(void* self) {
    auto& recorder = *static_cast<Recorder*>(self);
    ++recorder.restarts;
    recorder.bytes_at_restart = recorder.bytes.size();
  }
  void clear() {
    bytes.clear();
    frames.clear();
  }
};

/// nanopb-encodes `message`.
inline Bytes encode(const pb_msgdesc_t* fields, const void* message) {
  uint8_t buffer[256];
  pb_ostream_t stream = pb_ostream_from_buffer(buffer, sizeof(buffer));
  if (!pb_encode(&stream, fields, message)) throw std::runtime_error("nanopb encode failed");
  return Bytes(buffer, buffer + stream.bytes_written);
}

/// The frame of `payload` (no leading delimiter unless asked).
inline Bytes frame(const Bytes& payload, tether::proxy::Integrity integrity, bool leading = false) {
  uint8_t buffer[600];
  const auto framed = tether::proxy::encode_frame(tether::ByteView(payload.data(), payload.size()), integrity,
                                                  leading, tether::MutableByteView(buffer));
  if (!framed.ok()) throw std::runtime_error("encode_frame failed");
  return Bytes(buffer, buffer + framed.value());
}

/// Decodes every frame in `bytes` as `Message` (nanopb); throws on a bad frame or message.
template <typename Message>
std::vector<Message> decode_all(const Bytes& bytes, tether::proxy::Integrity integrity, const pb_msgdesc_t* fields) {
  tether::LinkCounters counters;
  tether::proxy::Decoder<128> decoder(integrity, counters);
  std::vector<Message> messages;
  for (const uint8_t byte : bytes) {
    const tether::DecodeStatus status = decoder.feed(byte);
    if (status == tether::DecodeStatus::error) throw std::runtime_error("bad frame from device");
    if (status != tether::DecodeStatus::frame) continue;
    Message message{};
    pb_istream_t stream = pb_istream_from_buffer(decoder.frame().data(), decoder.frame().size());
    if (!pb_decode(&stream, fields, &message)) throw std::runtime_error("device sent an undecodable message");
    messages.push_back(message);
  }
  if (decoder.in_frame()) throw std::runtime_error("device output ends inside a frame");
  return messages;
}

}  // namespace wire
