// Arduino glue of the proxy device: see TetherProxy.h.
#include <avr/io.h>
#include <util/atomic.h>

#include "TetherProxy.h"
#include "tether/firmware/reset.hpp"

namespace tether {
namespace arduino {

void release_timer1() {
  ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
    TCCR1B = 0;  // clock stopped: the servo drivers find it so and configure their own mode
    TCCR1A = 0;  // compare outputs disconnected from D9/D10
    TIMSK1 = 0;
  }
}

void write_frame(void* stream, ByteView frame) { static_cast<Stream*>(stream)->write(frame.data(), frame.size()); }

void write_frame_hardware(void* serial, ByteView frame) {
  write_all(*static_cast<HardwareSerial*>(serial), frame.data(), frame.size());
}

void restart(void* stream) {
  static_cast<Stream*>(stream)->flush();
  firmware::system_reset();
}

}  // namespace arduino
}  // namespace tether
