// Fuzz target of the proxy device library (firmware/proxy): the frame decoder, nanopb decode and dispatch
// of ProxyDevice (primary) and CompatDevice (the deployed variant), with the fake pin drivers and a fake
// clock. Byte 0 picks the device (even: primary, odd: compat); then each byte is a byte from the host or,
// after an escape 0xFF, a command:
//   0x00..0x7F  the clock advances by (command * 100) ms (past the 10 s failsafe), then `poll`;
//   0x80..0xBF  `poll` at the same time;
//   0xC0..0xFF  the next (command - 0xC0) bytes are a payload the target frames itself (COBS, and the
//               CRC-16 in primary mode) and feeds, so the fuzzer reaches nanopb and the dispatch without
//               having to guess checksums.
// Invariants: no crash or sanitizer finding; everything the device sends is whole frames whose payloads
// decode as the mode's ArduinoOut; no message fails to encode; primary: every decoded ArduinoIn is acked
// exactly once (executed, or a re-send acked without running again) and executed messages never exceed
// them; after Reset the device restarts (begins a new session) and stays consistent.
#include <pb_decode.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <vector>

#include "fake_hardware.hpp"
#include "rocketry.pb.h"
#include "tether/proxy/device/compat_device.hpp"
#include "tether/proxy/device/proxy_device.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/testing/fuzz_target.hpp"
#include "tether_proxy.pb.h"

namespace {

using namespace tether;
using namespace tether::proxy;
using namespace tether::proxy::device;

// What the device sent, read as a host reads it.
struct HostView {
  explicit HostView(Integrity mode) : integrity(mode), decoder(mode, counters) {}
  Integrity integrity;
  LinkCounters counters;
  Decoder<128> decoder;
  uint32_t messages = 0;
  uint32_t acks = 0;
  bool restart_requested = false;

  static void write(void* self, ByteView frame) {
    auto& view = *static_cast<HostView*>(self);
    for (const uint8_t byte : frame) view.feed(byte);
    TETHER_FUZZ_CHECK(!view.decoder.in_frame());  // the sink gets whole frames
  }
  static void restart(void* self) { static_cast<HostView*>(self)->restart_requested = true; }
  FrameSink sink() { return FrameSink{&HostView::write, this}; }

  void feed(uint8_t byte) {
    const DecodeStatus status = decoder.feed(byte);
    TETHER_FUZZ_CHECK(status != DecodeStatus::error);
    if (status != DecodeStatus::frame) return;
    ++messages;
    const ByteView payload = decoder.frame();
    pb_istream_t stream = pb_istream_from_buffer(payload.data(), payload.size());
    if (integrity == Integrity::crc16) {
      tether_proxy_ArduinoOut out = tether_proxy_ArduinoOut_init_zero;
      TETHER_FUZZ_CHECK(pb_decode(&stream, tether_proxy_ArduinoOut_fields, &out));
      if (out.which_data == tether_proxy_ArduinoOut_ack_tag) ++acks;
    } else {
      RocketryProto_ArduinoOut out = RocketryProto_ArduinoOut_init_zero;
      TETHER_FUZZ_CHECK(pb_decode(&stream, RocketryProto_ArduinoOut_fields, &out));
    }
  }
};

// Frames `payload` as a host would (the escape command's payloads).
std::vector<uint8_t> framed(const uint8_t* payload, size_t size, Integrity integrity) {
  std::vector<uint8_t> frame(size + 16);
  const auto encoded = encode_frame(ByteView(payload, size), integrity, false, MutableByteView(frame.data(), frame.size()));
  TETHER_FUZZ_CHECK(encoded.ok());
  frame.resize(encoded.value());
  return frame;
}

void fuzz_primary(const uint8_t* data, size_t size) {
  Millis now = 0xFFFF0000u;  // cross the clock's wrap on long inputs
  std::optional<OutputTable> outputs;
  HostView host(Integrity::crc16);
  std::optional<ProxyDevice> device;
  uint32_t session = 1;
  uint32_t acks_expected = 0;  // acks of earlier sessions
  const auto boot = [&] {
    device.reset();
    outputs.emplace();  // a reboot forgets every pin
    device.emplace(*outputs, host.sink(), &HostView::restart, &host);
    device->begin(session++, now);
  };
  const auto check = [&] {
    const ProxyDeviceCounters& c = device->counters();
    TETHER_FUZZ_CHECK(c.send_failures == 0);
    const uint32_t decoded = c.link.frames_ok - c.decode_errors;
    TETHER_FUZZ_CHECK(host.acks == acks_expected + decoded);
    TETHER_FUZZ_CHECK(c.executed + c.link.duplicates == decoded);
    TETHER_FUZZ_CHECK(c.refused <= c.executed);
    if (host.restart_requested) {  // Reset: the real device reboots here
      host.restart_requested = false;
      acks_expected = host.acks;
      boot();
    }
  };
  boot();
  const auto feed = [&](uint8_t byte) {
    device->handle_byte(byte, now);
    check();
  };
  for (size_t i = 1; i < size; ++i) {
    if (data[i] != 0xFF || i + 1 >= size) {
      feed(data[i]);
      continue;
    }
    const uint8_t command = data[++i];
    if (command < 0xC0) {
      if (command < 0x80) now += command * 100u;
      device->poll(now);
      check();
      continue;
    }
    const size_t length = std::min<size_t>(command - 0xC0u, size - i - 1);
    for (const uint8_t byte : framed(data + i + 1, length, Integrity::crc16)) feed(byte);
    i += length;
  }
  now += ProxyDevice::kPingSilenceMs;
  device->poll(now);
  check();
}

void fuzz_compat(const uint8_t* data, size_t size) {
  Millis now = 0xFFFF0000u;
  HostView host(Integrity::none);
  CompatDevice device(host.sink(), &HostView::restart, &host);
  device.begin(now);
  const auto check = [&] {
    TETHER_FUZZ_CHECK(device.counters().send_failures == 0);
    TETHER_FUZZ_CHECK(device.counters().refused <= device.counters().executed);
  };
  for (size_t i = 1; i < size; ++i) {
    if (data[i] != 0xFF || i + 1 >= size) {
      device.handle_byte(data[i]);
      check();
      continue;
    }
    const uint8_t command = data[++i];
    if (command < 0xC0) {
      if (command < 0x80) now += command * 100u;
      device.poll(now);
      check();
      continue;
    }
    const size_t length = std::min<size_t>(command - 0xC0u, size - i - 1);
    for (const uint8_t byte : framed(data + i + 1, length, Integrity::none)) device.handle_byte(byte);
    check();
    i += length;
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  if (size == 0) return 0;
  fake::reset();
  if ((data[0] & 1u) == 0) {
    fuzz_primary(data, size);
  } else {
    fuzz_compat(data, size);
  }
  return 0;
}
