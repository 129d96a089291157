/// @file adc.hpp
/// One-shot 10-bit conversions of the ATmega328P's ADC (Arduino A0..A5 = channels 0..5), AVcc reference,
/// as the Arduino core's analogRead() does but without its code size.
///
/// Prescaler 128: a 125 kHz ADC clock at 16 MHz, within the 50..200 kHz of full resolution; a conversion
/// takes 13 ADC clocks (~104 us; the first after enabling, 25). `read` busy-waits on ADSC.
#pragma once

#include <stdint.h>

namespace tether {
namespace firmware {
namespace adc {

/// Enables the ADC and disables the digital input buffers of `channel_mask` (bit n: ADCn), which saves
/// power and noise on pins used as analog inputs.
void begin(uint8_t channel_mask);
/// One conversion of `channel` (0..7): 0..1023 over 0..AVcc.
uint16_t read(uint8_t channel);

}  // namespace adc
}  // namespace firmware
}  // namespace tether
