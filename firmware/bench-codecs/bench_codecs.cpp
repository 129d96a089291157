// bench-codecs: runs each codec operation once between a rising and a falling edge of its own pin, so the
// host measures the operation's CPU cycles from the pin's pulse width in simulated time
// (benchmarks/avr_cycle_report.cpp). D2 carries an empty pulse: the baseline to subtract.
//   D2 baseline | D3 Romi: decode + parse a request | D4 Romi: encode a response | D5 proxy: decode a frame
//   D6 proxy: encode a frame | D7 CRC-16 over 64 bytes | D8 CRC-8 over 64 bytes
//   Elcano (Decoder<96>, RingNode<96, 256, 4> like the elcano-node image), drive D{s 50}{a 25} and segment
//   X{n 4}{s 160}{b 80}{p 3200,-64000}: D9/D10 read a drive message (generation B/D), D11/D12 read a
//   segment message (B/D), D13/A0 write a drive message (B/D), A1/A2 write a segment message (B/D),
//   A3/A4 RingNode feed + take_output of a forwarded drive message (B/D), A5 RingNode feed of a captured
//   drive message (B).
// `bench_wire_bytes[pin]` holds the bytes each operation reads or writes, as the encoders produced them:
// the host reads it through the ELF symbol table.
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

extern "C" {
/// Bytes on the wire of the operation measured on each Arduino pin (0: no operation on that pin).
__attribute__((used, externally_visible)) volatile uint8_t bench_wire_bytes[20];
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

template <typename Work>
void measure(uint8_t pin_bit_d, uint8_t pin_bit_b, uint8_t pin_bit_c, Work work) {
  if (pin_bit_d) PORTD |= pin_bit_d;
  if (pin_bit_b) PORTB |= pin_bit_b;
  if (pin_bit_c) PORTC |= pin_bit_c;
  work();
  if (pin_bit_d) PORTD &= static_cast<uint8_t>(~pin_bit_d);
  if (pin_bit_b) PORTB &= static_cast<uint8_t>(~pin_bit_b);
  if (pin_bit_c) PORTC &= static_cast<uint8_t>(~pin_bit_c);
}

elcano::Message drive_message() {
  elcano::Message m;
  m.type = elcano::Type::drive;
  m.speed = 50;
  m.angle = 25;
  return m;
}

elcano::Message segment_message() {
  elcano::Message m;
  m.type = elcano::Type::segment;
  m.number = 4;
  m.speed = 160;
  m.bearing = 80;
  m.east = 3200;
  m.north = -64000;
  return m;
}

// The byte count to record for an operation: 0 (flagged by the report) when it did not do its job.
uint8_t bytes_if(bool ok, size_t bytes) { return ok ? static_cast<uint8_t>(bytes) : static_cast<uint8_t>(0); }

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

// Reads `size` bytes of `input` with a fresh Decoder<96>, as an elcano-node board would; true when they
// made one message of `type`.
bool read_input(elcano::Generation generation, uint8_t size, elcano::Type type, tether::LinkCounters& counters) {
  elcano::Decoder<96> reader(generation, counters);
  bool read = false;
  for (uint8_t i = 0; i < size; ++i) {
    if (reader.feed(input[i]) == tether::DecodeStatus::frame) {
      sink = static_cast<uint16_t>(reader.frame().speed + static_cast<int32_t>(reader.forward().size()));
      read = reader.frame().type == type;
    }
  }
  return read;
}

// Feeds `size` bytes of `input` to `node` and takes its output (the forwarded message, when any); `kind` is
// the last event the bytes produced. Returns the output's size.
uint8_t node_pass(Node& node, uint8_t size, elcano::RingEvent::Kind& kind) {
  for (uint8_t i = 0; i < size; ++i) {
    const elcano::RingEvent::Kind event = node.consume(input[i], 0);  // the fast path, as elcano-node uses
    if (event != elcano::RingEvent::Kind::none) kind = event;
  }
  return static_cast<uint8_t>(node.take_output(frame, 0));
}

}  // namespace

int main() {
  DDRD = _BV(PD2) | _BV(PD3) | _BV(PD4) | _BV(PD5) | _BV(PD6) | _BV(PD7);
  DDRB = _BV(PB0) | _BV(PB1) | _BV(PB2) | _BV(PB3) | _BV(PB4) | _BV(PB5);
  DDRC = _BV(PC0) | _BV(PC1) | _BV(PC2) | _BV(PC3) | _BV(PC4) | _BV(PC5);
  for (uint8_t i = 0; i < sizeof data; ++i) data[i] = static_cast<uint8_t>(i * 37u + 11u);
  tether::LinkCounters counters;
  bool read = false;  // the decoders' outcome: a pin's byte count is recorded only when they did their job

  measure(_BV(PD2), 0, 0, [] {});
  measure(_BV(PD3), 0, 0, [&] {
    tether::romi::Decoder<tether::romi::kDeviceDecoderCapacity> decoder(counters);
    tether::romi::Request request;
    for (size_t i = 0; i + 1 < sizeof kRequest; ++i) {
      if (decoder.feed(kRequest[i]) == tether::DecodeStatus::frame) {
        const int16_t parsed = static_cast<int16_t>(tether::romi::parse_request(decoder.frame().payload, request));
        sink = static_cast<uint16_t>(parsed + request.arguments[1]);
        read = parsed == 0 && request.arguments[1] == -567;
      }
    }
  });
  bench_wire_bytes[3] = bytes_if(read, sizeof kRequest - 1);
  size_t written = 0;
  measure(_BV(PD4), 0, 0, [&] {
    written = tether::romi::encode_response('s', tether::ByteView::from_literal("[0,667]"), 7, frame).value();
  });
  bench_wire_bytes[4] = static_cast<uint8_t>(written);
  const size_t framed = tether::proxy::encode_frame(tether::ByteView(kServoControl, sizeof kServoControl),
                                                    tether::proxy::Integrity::crc16, true, frame)
                            .value();
  read = false;
  measure(_BV(PD5), 0, 0, [&] {
    tether::proxy::Decoder<32> decoder(tether::proxy::Integrity::crc16, counters);
    for (size_t i = 0; i < framed; ++i) {
      if (decoder.feed(frame[i]) == tether::DecodeStatus::frame) read = true;
    }
  });
  bench_wire_bytes[5] = bytes_if(read, framed);
  measure(_BV(PD6), 0, 0, [&] {
    written = tether::proxy::encode_frame(tether::ByteView(kServoControl, sizeof kServoControl),
                                          tether::proxy::Integrity::crc16, true, frame)
                  .value();
  });
  bench_wire_bytes[6] = static_cast<uint8_t>(written);
  measure(_BV(PD7), 0, 0, [&] { sink = tether::Crc16Mcrf4xx::compute(tether::ByteView(data, sizeof data)); });
  bench_wire_bytes[7] = sizeof data;
  measure(0, _BV(PB0), 0, [&] { sink = tether::Crc8Smbus::compute(tether::ByteView(data, sizeof data)); });
  bench_wire_bytes[8] = sizeof data;

  // --- Elcano -------------------------------------------------------------------------------------------
  const elcano::Message drive = drive_message();
  const elcano::Message segment = segment_message();
  uint8_t size = prepare_input(drive, elcano::Generation::b);
  measure(0, _BV(PB1), 0, [&] { read = read_input(elcano::Generation::b, size, elcano::Type::drive, counters); });
  bench_wire_bytes[9] = bytes_if(read, size);
  size = prepare_input(drive, elcano::Generation::d);
  measure(0, _BV(PB2), 0, [&] { read = read_input(elcano::Generation::d, size, elcano::Type::drive, counters); });
  bench_wire_bytes[10] = bytes_if(read, size);
  size = prepare_input(segment, elcano::Generation::b);
  measure(0, _BV(PB3), 0, [&] { read = read_input(elcano::Generation::b, size, elcano::Type::segment, counters); });
  bench_wire_bytes[11] = bytes_if(read, size);
  size = prepare_input(segment, elcano::Generation::d);
  measure(0, _BV(PB4), 0, [&] { read = read_input(elcano::Generation::d, size, elcano::Type::segment, counters); });
  bench_wire_bytes[12] = bytes_if(read, size);

  measure(0, _BV(PB5), 0, [&] { written = encode_message(drive, elcano::Generation::b, frame).value(); });
  bench_wire_bytes[13] = static_cast<uint8_t>(written);
  measure(0, 0, _BV(PC0), [&] { written = encode_message(drive, elcano::Generation::d, frame).value(); });
  bench_wire_bytes[14] = static_cast<uint8_t>(written);
  measure(0, 0, _BV(PC1), [&] { written = encode_message(segment, elcano::Generation::b, frame).value(); });
  bench_wire_bytes[15] = static_cast<uint8_t>(written);
  measure(0, 0, _BV(PC2), [&] { written = encode_message(segment, elcano::Generation::d, frame).value(); });
  bench_wire_bytes[16] = static_cast<uint8_t>(written);

  // Ring nodes are built outside the measurement (their construction is a boot cost, not a per-message one).
  tether::elcano::RingCounters ring;
  elcano::RingEvent::Kind kind = elcano::RingEvent::Kind::none;
  uint8_t out = 0;
  {
    elcano::RingNodeConfig config;
    config.generation = elcano::Generation::b;
    Node node(config, 0, counters, ring);
    size = prepare_input(drive, elcano::Generation::b);
    measure(0, 0, _BV(PC3), [&] { out = node_pass(node, size, kind); });
    const bool ok = kind == elcano::RingEvent::Kind::forwarded && out == without_spaces(size);
    bench_wire_bytes[17] = bytes_if(ok, size);
  }
  {
    elcano::RingNodeConfig config;
    config.generation = elcano::Generation::d;
    Node node(config, 0, counters, ring);
    size = prepare_input(drive, elcano::Generation::d);
    measure(0, 0, _BV(PC4), [&] { out = node_pass(node, size, kind); });
    const bool ok = kind == elcano::RingEvent::Kind::forwarded && out == size;
    bench_wire_bytes[18] = bytes_if(ok, size);
  }
  {
    elcano::RingNodeConfig config;
    config.generation = elcano::Generation::b;
    config.capture = elcano::TypeSet::of(elcano::Type::drive);
    Node node(config, 0, counters, ring);
    size = prepare_input(drive, elcano::Generation::b);
    measure(0, 0, _BV(PC5), [&] { out = node_pass(node, size, kind); });
    const bool ok = kind == elcano::RingEvent::Kind::captured && out == 0;
    bench_wire_bytes[19] = bytes_if(ok, size);
  }

  cli();
  sleep_cpu();  // done: the simulator stops here
  for (;;) {
  }
}
