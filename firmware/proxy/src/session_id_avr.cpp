// Boot-time sessionId on the ATmega328P: see tether/proxy/device/session_id.hpp for the sources and costs.
#include <avr/eeprom.h>
#include <avr/io.h>

#include "tether/firmware/reset.hpp"
#include "tether/proxy/device/session_id.hpp"

extern "C" char __heap_start;  // avr-libc linker script: first byte after .data, .bss and .noinit

namespace tether {
namespace proxy {
namespace device {

namespace {

static_assert(kPreviousIdAddress + 4u == E2END + 1u, "the session bytes are the last 8 of the EEPROM");

// Left behind by each boot for the next one (not zeroed by the startup code: random after power-up).
uint8_t g_carry[16] __attribute__((section(".noinit")));

constexpr uint16_t kStackMargin = 64;  // bytes below the stack pointer left alone
constexpr uint8_t kAdcSamples = 16;

uint32_t* eeprom_word(uint16_t address) { return reinterpret_cast<uint32_t*>(address); }

void add_free_sram(EntropyPool& pool) {
  const uint16_t start = static_cast<uint16_t>(reinterpret_cast<uintptr_t>(&__heap_start));
  const uint16_t end = static_cast<uint16_t>(SP - kStackMargin);
  for (uint16_t address = start; address < end; ++address) {
    pool.add(*reinterpret_cast<const volatile uint8_t*>(address));
  }
  for (uint8_t i = 0; i < sizeof(g_carry); ++i) pool.add(g_carry[i]);
}

void add_adc_noise(EntropyPool& pool) {
  const uint8_t admux = ADMUX;
  const uint8_t adcsra = ADCSRA;
  ADMUX = _BV(REFS1) | _BV(REFS0) | _BV(MUX3);                  // internal 1.1 V, temperature sensor
  ADCSRA = _BV(ADEN) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);   // clk/128: 125 kHz
  for (uint8_t i = 0; i < kAdcSamples; ++i) {
    ADCSRA = static_cast<uint8_t>(ADCSRA | _BV(ADSC));
    while ((ADCSRA & _BV(ADSC)) != 0) {
    }
    pool.add(ADCL);  // ADCL first: it locks ADCH until read
    pool.add(ADCH);
  }
  ADCSRA = adcsra;
  ADMUX = admux;
}

}  // namespace

uint32_t boot_session_id() {
  const uint32_t count = eeprom_read_dword(eeprom_word(kBootCounterAddress)) + 1u;  // erased: 0xFFFFFFFF
  const uint32_t previous = eeprom_read_dword(eeprom_word(kPreviousIdAddress));
  EntropyPool pool;
  pool.add_word(count);
  pool.add(tether::firmware::reset_cause());
  add_free_sram(pool);
  add_adc_noise(pool);
  const uint32_t id = derive_session_id(count, pool.value(), previous);
  eeprom_update_dword(eeprom_word(kBootCounterAddress), count);
  eeprom_update_dword(eeprom_word(kPreviousIdAddress), id);
  EntropyPool carry;  // what the next warm boot finds in .noinit
  carry.add_word(pool.value());
  carry.add_word(id);
  for (uint8_t i = 0; i < sizeof(g_carry); ++i) {
    carry.add(i);
    g_carry[i] = static_cast<uint8_t>(carry.value() >> 8);
  }
  return id;
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
