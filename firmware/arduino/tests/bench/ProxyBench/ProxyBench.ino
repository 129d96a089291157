// TetherProxy's Proxy example (primary mode over Serial), for tether_avr_cycle_report: the host puts a whole
// frame into Serial's receive ring, then writes a row id to GPIOR1; the next loop pass runs one poll()
// between two GPIOR0 writes (the row id, then 0) with interrupts held (bench/README.md). Row id 255 asks
// for the encode measurement instead: a frame of a 32-byte payload encoded (COBS + CRC-16, as the device
// frames what it sends) and handed to the device's frame sink, which queues it on Serial.
#include <TetherProxy.h>

TetherProxy proxy(Serial);

const uint8_t kEncodeRow = 255;
uint8_t payload[32];
uint8_t frame[40];

void encode_and_send() {
  const tether::Result<size_t> size = tether::proxy::encode_frame(
      tether::ByteView(payload, sizeof payload), tether::proxy::Integrity::crc16, true,
      tether::MutableByteView(frame, sizeof frame));
  if (size.ok()) tether::arduino::write_frame_hardware(&Serial, tether::ByteView(frame, size.value()));  // proxy(Serial)'s sink
}

void setup() {
  Serial.begin(115200);
  proxy.begin();  // sends ResetEvent with this boot's sessionId
  for (uint8_t i = 0; i < sizeof payload; ++i) payload[i] = static_cast<uint8_t>(i * 37 + 1);
}

void loop() {
  const uint8_t row = GPIOR1;
  if (row == 0) return;
  GPIOR1 = 0;
  cli();
  if (row == kEncodeRow) {
    GPIOR0 = row;
    encode_and_send();
    GPIOR0 = 0;
  } else {
    GPIOR0 = row;
    proxy.poll();
    GPIOR0 = 0;
  }
  sei();
}
