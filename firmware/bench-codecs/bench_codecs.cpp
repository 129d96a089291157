// bench-codecs: runs each codec operation once between two writes to GPIOR0 (the row id of
// bench_rows.hpp before it, 0 after it), so the host takes the operation's exact CPU cycles from the
// cycles of the two writes (benchmarks/avr_cycle_report.cpp watches GPIOR0 on the virtual Uno). The
// kBaseline row measures nothing: the markers' own cost, subtracted from every row. No interrupts run;
// input comes from memory and output goes to memory.
//   Romi: decode + parse a request, encode a response, and whole requests through a RomiSerial device
//   (romi-bench's four handlers; request in memory -> reply in memory, clock read as shipped).
//   proxy: decode (in runs, as the proxy device: ProxyDevice::handle_bytes) / encode a frame of 12 B
//   (ServoControl) and 32 B payload; CRC-16 and CRC-8 over 64 B.
//   Elcano (Decoder<96>, RingNode<96, 256, 4> like the elcano-node image), drive D{s 50}{a 25} and segment
//   X{n 4}{s 160}{b 80}{p 3200,-64000}: read and write them in generation B and D, RingNode forwarding
//   (B, D) and capture (B).
// `bench_wire_bytes[row]` holds the bytes each operation reads or writes, as the encoders produced them
// (0 when the operation did not do its job): the host reads it through the ELF symbol table.
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "tether/core/crc.hpp"
#include "tether/elcano/encoder.hpp"
#include "tether/elcano/message.hpp"
#include "tether/elcano/decoder.hpp"
#include "tether/elcano/ring_node.hpp"
#include "tether/proxy/decoder.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/romi/decoder.hpp"
#include "tether/romi/request_parser.hpp"
#include "bench_rows.hpp"
#include "../romi-bench/romi_bench_handlers.hpp"

using namespace tether_bench;

extern "C" {
/// Bytes on the wire of the operation of each row (0: not run, or it did not do its job).
__attribute__((used, externally_visible)) volatile uint8_t bench_wire_bytes[kRowCount];
}

namespace {

namespace elcano = tether::elcano;

// Results go to a volatile sink so the compiler cannot drop the work.
volatile uint16_t sink;

const uint8_t kRequest[] = "#s[1234,-567]:0788\r\n";
const uint8_t kServoControl[] = {0x08, 0xf8, 0xac, 0xd1, 0x91, 0x01, 0x22, 0x04, 0x08, 0x09, 0x10, 0x7b};
uint8_t frame[48];
uint8_t input[48];
uint8_t data[64];

using Node = elcano::RingNode<96, 256, 4>;  // the elcano-node image's node

// The byte count to record for an operation: 0 (flagged by the report) when it did not do its job.
uint8_t bytes_if(bool ok, size_t bytes) { return ok ? static_cast<uint8_t>(bytes) : static_cast<uint8_t>(0); }

// The memory barriers keep the compiler from moving the work across the markers.
template <typename Work>
void measure(Row row, Work work) {
  asm volatile("" ::: "memory");
  GPIOR0 = row;
  asm volatile("" ::: "memory");
  work();
  asm volatile("" ::: "memory");
  GPIOR0 = 0;
  asm volatile("" ::: "memory");
}

// --- Romi device in memory --------------------------------------------------------------------------
// Input: the bytes of one request; output: a bounded buffer.
class MemoryInput final : public tether::romi::device::IInputStream {
 public:
  void set(const uint8_t* bytes, uint8_t size) {
    next_ = bytes;
    end_ = bytes + size;
  }
  bool available() override { return next_ != end_; }
  bool read(char& c) override {
    if (next_ == end_) return false;
    c = static_cast<char>(*next_++);
    return true;
  }
  // Like UartStream's (one copy per batch; the pointers in registers, an 8-bit count).
  uint8_t read_some(uint8_t* bytes, uint8_t capacity) override {
    const uint8_t* next = next_;
    const uint8_t waiting = static_cast<uint8_t>(end_ - next);
    const uint8_t count = waiting < capacity ? waiting : capacity;
    for (uint8_t i = count; i != 0; --i) *bytes++ = *next++;
    next_ = next;
    return count;
  }

 private:
  const uint8_t* next_ = nullptr;
  const uint8_t* end_ = nullptr;
};

class MemoryOutput final : public tether::romi::device::IOutputStream {
 public:
  bool write(char c) override {
    if (size_ == sizeof bytes_) return false;
    bytes_[size_++] = static_cast<uint8_t>(c);
    return true;
  }
  // Like UartStream's (one copy per batch; the pointers in registers, an 8-bit count).
  void write_all(const uint8_t* bytes, uint8_t size) override {
    const uint8_t room = static_cast<uint8_t>(sizeof bytes_ - size_);
    const uint8_t count = size < room ? size : room;
    uint8_t* next = bytes_ + size_;
    for (uint8_t i = count; i != 0; --i) *next++ = *bytes++;
    size_ = static_cast<uint8_t>(size_ + count);
  }
  void clear() { size_ = 0; }
  const uint8_t* data() const { return bytes_; }
  uint8_t size() const { return size_; }

 private:
  uint8_t bytes_[80];
  uint8_t size_ = 0;
};

MemoryInput romi_input;
MemoryOutput romi_output;
romiserial::RomiSerial romi_device(romi_input, romi_output, romi_bench::kHandlers, romi_bench::kHandlerCount);
uint8_t romi_request[72];
uint8_t romi_expected[80];

// Runs one request (`payload` with `id`) through the device; records request + reply bytes when the
// reply is `body` byte for byte.
void romi_call(Row row, const char* payload, const char* body, uint8_t id) {
  const tether::ByteView payload_view(reinterpret_cast<const uint8_t*>(payload), __builtin_strlen(payload));
  const size_t in = tether::romi::encode_request(payload_view, id, romi_request).value();
  const tether::ByteView body_view(reinterpret_cast<const uint8_t*>(body), __builtin_strlen(body));
  const size_t expected = tether::romi::encode_response(payload[0], body_view, id, romi_expected).value();
  romi_input.set(romi_request, static_cast<uint8_t>(in));
  romi_output.clear();
  measure(row, [] { romi_device.handle_input(); });
  const bool ok = romi_output.size() == expected && __builtin_memcmp(romi_output.data(), romi_expected, expected) == 0;
  bench_wire_bytes[row] = bytes_if(ok, in + expected);
}

// The proxy device's decoder (ProxyDevice: Decoder<64>, crc16), long-lived as on the device: built once,
// outside the measurements.
tether::LinkCounters proxy_counters;
tether::proxy::Decoder<64> proxy_decoder(tether::proxy::Integrity::crc16, proxy_counters);

// Decodes the `size` bytes of `frame` as the proxy device does (ProxyDevice::handle_bytes): the bytes its
// UART ring holds, handed over as runs (one here: the whole frame is there), each fed to the decoder up to
// the event it completes. True when they made one frame of `payload` bytes.
bool proxy_decode(size_t size, size_t payload) {
  bool read = false;
  size_t used = 0;
  while (used < size) {
    const tether::FeedResult fed = proxy_decoder.feed(tether::ByteView(frame + used, size - used));
    used += fed.consumed;
    if (fed.status == tether::DecodeStatus::frame) read = proxy_decoder.frame().size() == payload;
  }
  return read;
}


// Writes `message` into `input` (outside any measurement); returns its size.
uint8_t prepare_input(const elcano::Message& message, elcano::Generation generation) {
  return static_cast<uint8_t>(encode_message(message, generation, input).value());
}

// Bytes of `input` other than spaces: what a node forwards of a generation B message.
uint8_t without_spaces(uint8_t size) {
  uint8_t count = 0;
  for (uint8_t i = 0; i < size; ++i) count = static_cast<uint8_t>(count + (input[i] != ' ' ? 1u : 0u));
  return count;
}

// Reads `size` bytes of `input` with `reader` as one span (feed(bytes): the run of bytes a UART read returns,
// what RingNode::consume hands its reader); true when they made one message of `type`.
bool read_input(elcano::Decoder<96>& reader, uint8_t size, elcano::Type type) {
  bool read = false;
  const uint8_t* const end = input + size;
  for (const uint8_t* next = input; next != end;) {  // as elcano-node walks a UART read
    const tether::FeedResult fed = reader.feed(tether::ByteView(next, static_cast<size_t>(end - next)));
    if (fed.status == tether::DecodeStatus::frame) {
      sink = static_cast<uint16_t>(reader.frame().speed + static_cast<int32_t>(reader.forward().size()));
      read = reader.frame().type == type;
    }
    next += fed.consumed;
  }
  return read;
}

// Feeds `size` bytes of `input` to `node` and takes its output (the forwarded message, when any); `kind` is
// the last event the bytes produced. Returns the output's size.
uint8_t node_pass(Node& node, uint8_t size, elcano::RingEvent::Kind& kind) {
  const uint8_t* const end = input + size;
  for (const uint8_t* next = input; next != end;) {  // one span, as elcano-node feeds a UART read
    size_t used = 0;
    const elcano::RingEvent::Kind event = node.consume(tether::ByteView(next, static_cast<size_t>(end - next)), 0, used);
    if (event != elcano::RingEvent::Kind::none) kind = event;
    next += used;
  }
  return static_cast<uint8_t>(node.take_output(frame, 0));
}

// The rows in three groups, each its own frame: all of them inlined into main() took a 760-byte frame,
// and with the codecs' own frames below it the stack ran into .bss (bench_wire_bytes, the input data) on
// the 2 KB Uno. `ctest -R avr_cycle_report` fails when a row's byte count is lost.
__attribute__((noinline)) void romi_and_proxy_rows(tether::LinkCounters& counters) {
  bool read = false;  // the decoders' outcome: a row's byte count is recorded only when they did their job

  // Whole requests through the device (ids differ: no request repeats the previous one).
  romi_call(kRomiRequestA, "a", "[0]", 1);
  romi_call(kRomiRequestE, "e", "[0,1,2]", 2);
  romi_call(kRomiRequestC, "c[1000,-2000]", "[0]", 3);
  romi_call(kRomiRequestD, "d[\"Hello there\"]", "[0]", 4);
  measure(kRomiDecodeParse, [&] {
    tether::romi::Decoder<tether::romi::kDeviceDecoderCapacity> decoder(counters);
    tether::romi::ParsedRequest request;  // what the device parses into (its string stays in the frame)
    for (size_t i = 0; i + 1 < sizeof kRequest; ++i) {
      if (decoder.feed(kRequest[i]) == tether::DecodeStatus::frame) {
        const int16_t parsed = static_cast<int16_t>(tether::romi::parse_request(decoder.frame().payload, request));
        sink = static_cast<uint16_t>(parsed + request.arguments[1]);
        read = parsed == 0 && request.arguments[1] == -567;
      }
    }
  });
  bench_wire_bytes[kRomiDecodeParse] = bytes_if(read, sizeof kRequest - 1);
  size_t written = 0;
  measure(kRomiEncodeResponse, [&] {
    written = tether::romi::encode_response('s', tether::ByteView::from_literal("[0,667]"), 7, frame).value();
  });
  bench_wire_bytes[kRomiEncodeResponse] = static_cast<uint8_t>(written);
  const size_t framed = tether::proxy::encode_frame(tether::ByteView(kServoControl, sizeof kServoControl),
                                                    tether::proxy::Integrity::crc16, true, frame)
                            .value();
  read = false;
  measure(kProxyDecode12, [&] { read = proxy_decode(framed, sizeof kServoControl); });
  bench_wire_bytes[kProxyDecode12] = bytes_if(read, framed);
  measure(kProxyEncode12, [&] {
    written = tether::proxy::encode_frame(tether::ByteView(kServoControl, sizeof kServoControl),
                                          tether::proxy::Integrity::crc16, true, frame)
                  .value();
  });
  bench_wire_bytes[kProxyEncode12] = static_cast<uint8_t>(written);
  uint8_t payload32[32];
  for (uint8_t i = 0; i < sizeof payload32; ++i) payload32[i] = data[i];
  const tether::ByteView payload32_view(payload32, sizeof payload32);
  measure(kProxyEncode32, [&] {
    written = tether::proxy::encode_frame(payload32_view, tether::proxy::Integrity::crc16, true, frame).value();
  });
  bench_wire_bytes[kProxyEncode32] = static_cast<uint8_t>(written);
  const size_t framed32 = written;
  read = false;
  measure(kProxyDecode32, [&] { read = proxy_decode(framed32, 32); });
  bench_wire_bytes[kProxyDecode32] = bytes_if(read, framed32);
  measure(kCrc16, [&] { sink = tether::Crc16Mcrf4xx::compute(tether::ByteView(data, sizeof data)); });
  bench_wire_bytes[kCrc16] = sizeof data;
  measure(kCrc8, [&] { sink = tether::Crc8Smbus::compute(tether::ByteView(data, sizeof data)); });
  bench_wire_bytes[kCrc8] = sizeof data;

}

__attribute__((noinline)) void elcano_rows(tether::LinkCounters& counters) {
  bool read = false;
  size_t written = 0;
  const elcano::Message drive = elcano::Message::drive(50, 25);
  const elcano::Message segment = elcano::Message::segment(4, 160, 80, 3200, -64000);
  // One decoder per generation, built outside the measurements and kept from message to message, as a node
  // keeps its reader (RingNode holds one for its lifetime): a row is what a message costs the node.
  {
    elcano::Decoder<96> reader(elcano::Generation::b, counters);
    uint8_t size = prepare_input(drive, elcano::Generation::b);
    measure(kElcanoReadDriveB, [&] { read = read_input(reader, size, elcano::Type::drive); });
    bench_wire_bytes[kElcanoReadDriveB] = bytes_if(read, size);
    size = prepare_input(segment, elcano::Generation::b);
    measure(kElcanoReadSegmentB, [&] { read = read_input(reader, size, elcano::Type::segment); });
    bench_wire_bytes[kElcanoReadSegmentB] = bytes_if(read, size);
  }
  {
    elcano::Decoder<96> reader(elcano::Generation::d, counters);
    uint8_t size = prepare_input(drive, elcano::Generation::d);
    measure(kElcanoReadDriveD, [&] { read = read_input(reader, size, elcano::Type::drive); });
    bench_wire_bytes[kElcanoReadDriveD] = bytes_if(read, size);
    size = prepare_input(segment, elcano::Generation::d);
    measure(kElcanoReadSegmentD, [&] { read = read_input(reader, size, elcano::Type::segment); });
    bench_wire_bytes[kElcanoReadSegmentD] = bytes_if(read, size);
  }

  measure(kElcanoWriteDriveB, [&] { written = encode_message(drive, elcano::Generation::b, frame).value(); });
  bench_wire_bytes[kElcanoWriteDriveB] = static_cast<uint8_t>(written);
  measure(kElcanoWriteDriveD, [&] { written = encode_message(drive, elcano::Generation::d, frame).value(); });
  bench_wire_bytes[kElcanoWriteDriveD] = static_cast<uint8_t>(written);
  measure(kElcanoWriteSegmentB, [&] { written = encode_message(segment, elcano::Generation::b, frame).value(); });
  bench_wire_bytes[kElcanoWriteSegmentB] = static_cast<uint8_t>(written);
  measure(kElcanoWriteSegmentD, [&] { written = encode_message(segment, elcano::Generation::d, frame).value(); });
  bench_wire_bytes[kElcanoWriteSegmentD] = static_cast<uint8_t>(written);

}

__attribute__((noinline)) void elcano_ring_rows(tether::LinkCounters& counters) {
  const elcano::Message drive = elcano::Message::drive(50, 25);
  uint8_t size = 0;
  // Ring nodes are built outside the measurement (their construction is a boot cost, not a per-message one).
  tether::elcano::RingCounters ring;
  elcano::RingEvent::Kind kind = elcano::RingEvent::Kind::none;
  uint8_t out = 0;
  {
    elcano::RingNodeConfig config;
    config.generation = elcano::Generation::b;
    Node node(config, 0, counters, ring);
    size = prepare_input(drive, elcano::Generation::b);
    measure(kElcanoRingForwardB, [&] { out = node_pass(node, size, kind); });
    const bool ok = kind == elcano::RingEvent::Kind::forwarded && out == without_spaces(size);
    bench_wire_bytes[kElcanoRingForwardB] = bytes_if(ok, size);
  }
  {
    elcano::RingNodeConfig config;
    config.generation = elcano::Generation::d;
    Node node(config, 0, counters, ring);
    size = prepare_input(drive, elcano::Generation::d);
    measure(kElcanoRingForwardD, [&] { out = node_pass(node, size, kind); });
    const bool ok = kind == elcano::RingEvent::Kind::forwarded && out == size;
    bench_wire_bytes[kElcanoRingForwardD] = bytes_if(ok, size);
  }
  {
    elcano::RingNodeConfig config;
    config.generation = elcano::Generation::b;
    config.capture = elcano::TypeSet::of(elcano::Type::drive);
    Node node(config, 0, counters, ring);
    size = prepare_input(drive, elcano::Generation::b);
    measure(kElcanoRingCaptureB, [&] { out = node_pass(node, size, kind); });
    const bool ok = kind == elcano::RingEvent::Kind::captured && out == 0;
    bench_wire_bytes[kElcanoRingCaptureB] = bytes_if(ok, size);
  }
}

}  // namespace

int main() {
  for (uint8_t i = 0; i < sizeof data; ++i) data[i] = static_cast<uint8_t>(i * 37u + 11u);
  tether::LinkCounters counters;
  measure(kBaseline, [] {});
  bench_wire_bytes[kBaseline] = 1;
  romi_and_proxy_rows(counters);
  elcano_rows(counters);
  elcano_ring_rows(counters);

  cli();
  sleep_cpu();  // done: the simulator stops here
  for (;;) {
  }
}
