// Compile-only gate of the AVR build: every public header of the proxy device library with the project's
// warnings, so a header that stops compiling with avr-gcc fails the build even if no image uses it yet.
// Never linked into an image.
#include "tether/proxy/device.hpp"

namespace tether {
namespace proxy {
namespace device {

static_assert(servo_pulse_us(0) == 1000 && servo_pulse_us(90) == 1500 && servo_pulse_us(180) == 2000,
              "servo pulses: 1000 + degrees * 1000 / 180 us");

}  // namespace device
}  // namespace proxy
}  // namespace tether
