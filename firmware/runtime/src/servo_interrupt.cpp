// Timer1 compare-A interrupt servo driver (any pin); see servo_interrupt.hpp.
#include "tether/firmware/servo_interrupt.hpp"

#include <avr/interrupt.h>
#include <avr/io.h>
#include <util/atomic.h>

#include "tether/firmware/pin_registers.hpp"

namespace tether {
namespace firmware {
namespace servo_interrupt {

namespace {

struct Channel {
  volatile uint8_t* port;  // g_idle_port for D0/D1 (the UART's): the slot is timed, the pin untouched
  uint8_t mask;
  uint8_t pin;
  uint16_t ticks;
};

// Channels 0..count-1, then a sentinel at [count] whose port is `g_idle_port`: the routine below always
// does one ending and one starting write, so every edge comes the same number of cycles after its compare.
volatile uint8_t g_idle_port = 0;
Channel g_channels[kMaxChannels + 1] = {{&g_idle_port, 0, 0xFF, 0}};
volatile uint8_t g_count = 0;
// Channel whose pulse runs now; g_count between frames (the next compare starts channel 0).
volatile uint8_t g_current = 0;
uint16_t g_frame_start = 0;

Channel* find(uint8_t pin) {
  for (uint8_t i = 0; i < g_count; ++i) {
    if (g_channels[i].pin == pin) return &g_channels[i];
  }
  return nullptr;
}

void start_timer() {
  TCCR1A = 0;  // normal mode, compare outputs disconnected (the ISR drives the pins)
  TCCR1B = 0;
  g_current = g_count;  // between frames
  g_frame_start = static_cast<uint16_t>(TCNT1 + 64u + kLeadTicks);
  OCR1A = static_cast<uint16_t>(g_frame_start - kLeadTicks);
  TIFR1 = _BV(OCF1A);   // drop a stale match
  TIMSK1 = static_cast<uint8_t>(TIMSK1 | _BV(OCIE1A));
  TCCR1B = _BV(CS11);   // clk/8: 0.5 us per tick
}

// One compare per edge pair: the running pulse (or the sentinel, between frames) ends and the next (or the
// sentinel, after the last channel) starts. The compare comes kLeadTicks before the edges' tick; the routine
// computes both port values, waits for that tick on TCNT1 and stores them back to back (the ending edge,
// then the starting one 3 cycles later as compiled), the same instructions every time. So an edge is late
// only by the wait loop's phase against the tick (0..5 cycles) unless the routine itself was held off for
// longer than the lead. Reading the ports before the wait is safe: interrupts stay off in this routine, so
// nothing else writes them in between.
inline void on_compare() {
  const uint8_t current = g_current;
  const uint8_t count = g_count;
  const uint16_t edge = static_cast<uint16_t>(OCR1A + kLeadTicks);
  const uint8_t next = current < count ? static_cast<uint8_t>(current + 1u) : 0;
  const Channel& ending = g_channels[current];
  const Channel& starting = g_channels[next];
  volatile uint8_t* const ending_port = ending.port;
  volatile uint8_t* const starting_port = starting.port;
  const uint8_t ending_value = static_cast<uint8_t>(*ending_port & static_cast<uint8_t>(~ending.mask));
  const uint8_t starting_value =
      static_cast<uint8_t>((starting_port == ending_port ? ending_value : *starting_port) | starting.mask);
  // Within the lead the distance fits the low byte, whose read makes the shortest loop; past the edges'
  // tick (held off for longer than the lead) there is nothing to wait for.
  if (static_cast<int16_t>(TCNT1 - edge) < 0) {
    const uint8_t edge_low = static_cast<uint8_t>(edge);
    while (static_cast<int8_t>(static_cast<uint8_t>(TCNT1L - edge_low)) < 0) {
    }
  }
  *ending_port = ending_value;
  *starting_port = starting_value;
  if (current >= count) g_frame_start = edge;  // this compare started a new frame
  uint16_t next_edge;
  if (next < count) {
    next_edge = static_cast<uint16_t>(edge + starting.ticks);
    g_current = next;
  } else {
    const uint16_t used = static_cast<uint16_t>(edge - g_frame_start);
    next_edge = static_cast<uint16_t>(used + kMinGapTicks <= kFrameTicks ? g_frame_start + kFrameTicks
                                                                          : edge + kMinGapTicks);
    g_current = count;  // between frames
  }
  OCR1A = static_cast<uint16_t>(next_edge - kLeadTicks);
}

}  // namespace

bool attach(uint8_t pin, uint16_t pulse_us) {
  if (pin >= 20) return false;
  bool ok = true;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    Channel* channel = find(pin);
    if (channel != nullptr) {
      channel->ticks = ticks_for(pulse_us);
    } else if (g_count == kMaxChannels) {
      ok = false;
    } else {
      const PinRegisters bit = pin_registers(pin);
      const bool uart = pin < 2;
      if (!uart) {
        write_bits(bit.port, bit.mask, false);  // low between pulses
        write_bits(bit.ddr, bit.mask, true);
      }
      g_channels[g_count] = Channel{uart ? &g_idle_port : bit.port, bit.mask, pin, ticks_for(pulse_us)};
      g_channels[g_count + 1] = Channel{&g_idle_port, 0, 0xFF, 0};  // the sentinel moves up
      const bool first = g_count == 0;
      // Between frames the new channel joins the next frame; inside one, the current index stays valid.
      if (g_current == g_count) g_current = static_cast<uint8_t>(g_count + 1u);
      g_count = static_cast<uint8_t>(g_count + 1u);
      if (first) start_timer();
    }
  }
  return ok;
}

void write(uint8_t pin, uint16_t pulse_us) {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    Channel* channel = find(pin);
    if (channel != nullptr) channel->ticks = ticks_for(pulse_us);
  }
}

bool attached(uint8_t pin) {
  bool found = false;
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) { found = find(pin) != nullptr; }
  return found;
}

}  // namespace servo_interrupt
}  // namespace firmware
}  // namespace tether

ISR(TIMER1_COMPA_vect) { tether::firmware::servo_interrupt::on_compare(); }
