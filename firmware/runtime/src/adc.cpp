// One-shot ADC conversions; see adc.hpp.
#include "tether/firmware/adc.hpp"

#include <avr/io.h>

namespace tether {
namespace firmware {
namespace adc {

void begin(uint8_t channel_mask) {
  ADMUX = _BV(REFS0);                                        // AVcc reference, right-adjusted, ADC0
  ADCSRA = _BV(ADEN) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);  // enabled, clock / 128
  DIDR0 = static_cast<uint8_t>(channel_mask & 0x3Fu);        // only ADC0..5 have digital buffers
}

uint16_t read(uint8_t channel) {
  ADMUX = static_cast<uint8_t>(_BV(REFS0) | (channel & 0x07u));
  ADCSRA = static_cast<uint8_t>(ADCSRA | _BV(ADSC));
  while ((ADCSRA & _BV(ADSC)) != 0) {
  }
  return ADC;  // ADCL then ADCH, as the data sheet requires
}

}  // namespace adc
}  // namespace firmware
}  // namespace tether
