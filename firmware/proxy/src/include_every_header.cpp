// Compile-only gate of the AVR build: every public header of the proxy device library with the project's
// warnings, so a header that stops compiling with avr-gcc fails the build even if no image uses it yet.
// Never linked into an image.
#include "tether/proxy/device.hpp"

namespace tether {
namespace proxy {
namespace device {

static_assert(servo_pulse_us(0) == 1000 && servo_pulse_us(90) == 1500 && servo_pulse_us(180) == 2000,
              "servo pulses: 1000 + degrees * 1000 / 180 us");

// The images rely on their static ProxyDevice being constant-initialised (no constructor code at startup,
// proxy_device.hpp): this stops compiling with avr-gcc if a member's constructor stops being constexpr.
OutputTable g_gate_outputs;
constexpr ProxyDevice kConstantInitialisedDevice(g_gate_outputs, FrameSink{nullptr, nullptr});

}  // namespace device
}  // namespace proxy
}  // namespace tether
