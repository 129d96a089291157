// The fake core's out-of-line parts (see Arduino.h here) and the bytes its UART sent.
#include "fake_core.hpp"

uint32_t fake_millis = 0;

namespace fake_core {
std::vector<uint8_t> wire;
FakeUart serial_uart;
}  // namespace fake_core

HardwareSerial Serial(fake_core::serial_uart);

void HardwareSerial::fake_shift() {
  if ((*_ucsra & _BV(UDRE0)) != 0) return;
  if ((*_ucsra & _BV(TXC0)) != 0) fake_core::wire.push_back(static_cast<uint8_t>(*_udr));
  *_ucsra = static_cast<uint8_t>((*_ucsra | _BV(UDRE0)) & ~_BV(TXC0));
}

size_t HardwareSerial::write(uint8_t c) {
  _written = true;
  if (_tx_buffer_head == _tx_buffer_tail && (*_ucsra & _BV(UDRE0)) != 0) {
    *_udr = c;
    *_ucsra = static_cast<uint8_t>((*_ucsra & (_BV(U2X0) | _BV(MPCM0))) | _BV(TXC0));
    return 1;
  }
  const tx_buffer_index_t next = static_cast<tx_buffer_index_t>((_tx_buffer_head + 1u) % SERIAL_TX_BUFFER_SIZE);
  while (next == _tx_buffer_tail) {  // the core polls the UART when it must wait
    fake_shift();
    _tx_udr_empty_irq();
  }
  _tx_buffer[_tx_buffer_head] = c;
  _tx_buffer_head = next;
  *_ucsrb = static_cast<uint8_t>(*_ucsrb | _BV(UDRIE0));
  return 1;
}

void HardwareSerial::_tx_udr_empty_irq() {
  const unsigned char c = _tx_buffer[_tx_buffer_tail];
  _tx_buffer_tail = static_cast<tx_buffer_index_t>((_tx_buffer_tail + 1u) % SERIAL_TX_BUFFER_SIZE);
  *_udr = c;
  *_ucsra = static_cast<uint8_t>((*_ucsra & (_BV(U2X0) | _BV(MPCM0))) | _BV(TXC0));
  if (_tx_buffer_head == _tx_buffer_tail) *_ucsrb = static_cast<uint8_t>(*_ucsrb & ~_BV(UDRIE0));
}

namespace fake_core {

void transmit(HardwareSerial& serial, FakeUart& uart) {
  serial.fake_shift();
  while ((uart.ucsrb & _BV(UDRIE0)) != 0) {
    serial._tx_udr_empty_irq();
    serial.fake_shift();
  }
}

}  // namespace fake_core
