// bench-codecs: runs each codec operation once between a rising and a falling edge of its own pin, so the
// host measures the operation's CPU cycles from the pin's pulse width in simulated time
// (benchmarks/avr_cycle_report.cpp). D2 carries an empty pulse: the baseline to subtract.
//   D2 baseline | D3 Romi: decode + parse a request | D4 Romi: encode a response | D5 proxy: decode a frame
//   D6 proxy: encode a frame | D7 CRC-16 over 64 bytes | D8 CRC-8 over 64 bytes
#include <avr/interrupt.h>
#include <avr/io.h>
#include <avr/sleep.h>

#include "tether/core/crc.hpp"
#include "tether/proxy/frame.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/romi/envelope_decoder.hpp"
#include "tether/romi/request_parser.hpp"

namespace {

// Results go to a volatile sink so the compiler cannot drop the work.
volatile uint16_t sink;

const uint8_t kRequest[] = "#s[1234,-567]:0788\r\n";
const uint8_t kServoControl[] = {0x08, 0xf8, 0xac, 0xd1, 0x91, 0x01, 0x22, 0x04, 0x08, 0x09, 0x10, 0x7b};
uint8_t frame[40];
uint8_t data[64];

template <typename Work>
void measure(uint8_t pin_bit_d, uint8_t pin_bit_b, Work work) {
  if (pin_bit_d) PORTD |= pin_bit_d;
  if (pin_bit_b) PORTB |= pin_bit_b;
  work();
  if (pin_bit_d) PORTD &= static_cast<uint8_t>(~pin_bit_d);
  if (pin_bit_b) PORTB &= static_cast<uint8_t>(~pin_bit_b);
}

}  // namespace

int main() {
  DDRD = _BV(PD2) | _BV(PD3) | _BV(PD4) | _BV(PD5) | _BV(PD6) | _BV(PD7);
  DDRB = _BV(PB0);
  for (uint8_t i = 0; i < sizeof data; ++i) data[i] = static_cast<uint8_t>(i * 37u + 11u);
  tether::LinkCounters counters;

  measure(_BV(PD2), 0, [] {});
  measure(_BV(PD3), 0, [&] {
    tether::romi::EnvelopeDecoder<tether::romi::kDeviceDecoderCapacity> decoder(counters);
    tether::romi::Request request;
    for (size_t i = 0; i + 1 < sizeof kRequest; ++i) {
      const tether::romi::EnvelopeEvent event = decoder.feed(kRequest[i]);
      if (event.kind == tether::romi::EnvelopeEvent::Kind::frame) {
        const int16_t parsed = static_cast<int16_t>(tether::romi::parse_request(event.payload, request));
        sink = static_cast<uint16_t>(parsed + request.arguments[1]);
      }
    }
  });
  measure(_BV(PD4), 0, [&] {
    sink = static_cast<uint16_t>(
        tether::romi::encode_response('s', tether::ByteView::from_literal("[0,667]"), 7, frame).value());
  });
  const size_t framed = tether::proxy::encode_frame(tether::ByteView(kServoControl, sizeof kServoControl),
                                                    tether::proxy::Integrity::crc16, true, frame)
                            .value();
  measure(_BV(PD5), 0, [&] {
    tether::proxy::FrameDecoder<32> decoder(tether::proxy::Integrity::crc16, counters);
    for (size_t i = 0; i < framed; ++i) {
      if (decoder.feed(frame[i]).kind == tether::proxy::FrameEvent::Kind::payload) sink = 1;
    }
  });
  measure(_BV(PD6), 0, [&] {
    sink = static_cast<uint16_t>(tether::proxy::encode_frame(tether::ByteView(kServoControl, sizeof kServoControl),
                                                             tether::proxy::Integrity::crc16, true, frame)
                                     .value());
  });
  measure(_BV(PD7), 0, [&] { sink = tether::Crc16Mcrf4xx::compute(tether::ByteView(data, sizeof data)); });
  measure(0, _BV(PB0), [&] { sink = tether::Crc8Smbus::compute(tether::ByteView(data, sizeof data)); });

  cli();
  sleep_cpu();  // done: the simulator stops here
  for (;;) {
  }
}
