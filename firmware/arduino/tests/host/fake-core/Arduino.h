// Host stand-in for the Arduino AVR core's Arduino.h (arduino_glue_test): Print, Stream and a HardwareSerial
// with the AVR core's members (names, types, ring rules: the head is the interrupt's, the tail the
// reader's, one slot stays free) over fake UART registers, so the libraries' glue compiles on the host
// against the same class layout and its ring handling can be checked byte by byte. Written for these
// tests from the core's documented behaviour; it is not the core's code.
#pragma once

#include <stddef.h>
#include <stdint.h>

// ARDUINO and ARDUINO_ARCH_AVR come from the command line, as the Arduino builder passes them.

#define _BV(bit) (1u << (bit))
// UCSR0A / UCSR0B bits of the ATmega328P.
#define MPCM0 0
#define U2X0 1
#define UDRE0 5
#define TXC0 6
#define UDRIE0 5

#ifndef SERIAL_RX_BUFFER_SIZE
#define SERIAL_RX_BUFFER_SIZE 64
#endif
#ifndef SERIAL_TX_BUFFER_SIZE
#define SERIAL_TX_BUFFER_SIZE 64
#endif
typedef uint8_t rx_buffer_index_t;
typedef uint8_t tx_buffer_index_t;

#define HIGH 1
#define LOW 0

/// The fake clock: what millis() returns (tests set it). 32 bits, as the AVR's unsigned long.
extern uint32_t fake_millis;
inline uint32_t millis() { return fake_millis; }

class Print {
 public:
  virtual ~Print() = default;
  virtual size_t write(uint8_t byte) = 0;
  virtual size_t write(const uint8_t* buffer, size_t size) {
    size_t written = 0;
    while (written < size && write(buffer[written]) == 1) ++written;
    return written;
  }
  virtual int availableForWrite() { return 0; }
  virtual void flush() {}
};

class Stream : public Print {
 public:
  virtual int available() = 0;
  virtual int read() = 0;
  virtual int peek() = 0;
};

/// The UART registers a HardwareSerial drives. Plain memory: writing UCSR0A the core's way (TXC set, the
/// other bits kept or zeroed) also clears UDRE here, which stands for "the data register holds a byte"
/// until `shift()` moves it to the wire (fake_core.hpp).
struct FakeUart {
  volatile uint8_t ubrrh = 0, ubrrl = 0, ucsra = _BV(UDRE0), ucsrb = 0, ucsrc = 0, udr = 0;
};

class HardwareSerial : public Stream {
 protected:
  volatile uint8_t* const _ubrrh;
  volatile uint8_t* const _ubrrl;
  volatile uint8_t* const _ucsra;
  volatile uint8_t* const _ucsrb;
  volatile uint8_t* const _ucsrc;
  volatile uint8_t* const _udr;
  bool _written;

  volatile rx_buffer_index_t _rx_buffer_head;
  volatile rx_buffer_index_t _rx_buffer_tail;
  volatile tx_buffer_index_t _tx_buffer_head;
  volatile tx_buffer_index_t _tx_buffer_tail;

  unsigned char _rx_buffer[SERIAL_RX_BUFFER_SIZE];
  unsigned char _tx_buffer[SERIAL_TX_BUFFER_SIZE];

 public:
  explicit HardwareSerial(FakeUart& uart)
      : _ubrrh(&uart.ubrrh), _ubrrl(&uart.ubrrl), _ucsra(&uart.ucsra), _ucsrb(&uart.ucsrb), _ucsrc(&uart.ucsrc),
        _udr(&uart.udr), _written(false), _rx_buffer_head(0), _rx_buffer_tail(0), _tx_buffer_head(0),
        _tx_buffer_tail(0), _rx_buffer(), _tx_buffer() {}

  int available() override {
    return static_cast<int>((SERIAL_RX_BUFFER_SIZE + _rx_buffer_head - _rx_buffer_tail) % SERIAL_RX_BUFFER_SIZE);
  }
  int peek() override { return _rx_buffer_head == _rx_buffer_tail ? -1 : _rx_buffer[_rx_buffer_tail]; }
  int read() override {
    if (_rx_buffer_head == _rx_buffer_tail) return -1;
    const unsigned char c = _rx_buffer[_rx_buffer_tail];
    _rx_buffer_tail = static_cast<rx_buffer_index_t>((_rx_buffer_tail + 1u) % SERIAL_RX_BUFFER_SIZE);
    return c;
  }
  int availableForWrite() override {
    const unsigned head = _tx_buffer_head, tail = _tx_buffer_tail;
    return static_cast<int>(head >= tail ? SERIAL_TX_BUFFER_SIZE - 1u - head + tail : tail - head - 1u);
  }
  void flush() override {}
  size_t write(uint8_t c) override;
  using Print::write;

  /// The receive interrupt: the byte that arrived (dropped when the ring is full, as the core does).
  void _rx_complete_irq(uint8_t c) {
    const rx_buffer_index_t next = static_cast<rx_buffer_index_t>((_rx_buffer_head + 1u) % SERIAL_RX_BUFFER_SIZE);
    if (next == _rx_buffer_tail) return;
    _rx_buffer[_rx_buffer_head] = c;
    _rx_buffer_head = next;
  }
  /// The data-register-empty interrupt: the next queued byte to the data register.
  void _tx_udr_empty_irq();

  // --- for the tests ---
  /// The UART takes the byte in its data register (if one was written: UDRE clear, TXC set) onto the
  /// wire (fake_core::wire); the data register is empty again.
  void fake_shift();
  bool written() const { return _written; }
  rx_buffer_index_t rx_tail() const { return _rx_buffer_tail; }
  tx_buffer_index_t tx_queued() const {
    return static_cast<tx_buffer_index_t>((SERIAL_TX_BUFFER_SIZE + _tx_buffer_head - _tx_buffer_tail) % SERIAL_TX_BUFFER_SIZE);
  }
  /// Starts the ring at `index` (a test of the wrap-around), empty.
  void reset_rings(uint8_t rx_index, uint8_t tx_index) {
    _rx_buffer_head = rx_index;
    _rx_buffer_tail = rx_index;
    _tx_buffer_head = tx_index;
    _tx_buffer_tail = tx_index;
  }
};

/// The core's first port, as the AVR core declares it (HardwareSerial.h): its UART is `fake_core::serial_uart`.
extern HardwareSerial Serial;
#define HAVE_HWSERIAL0
