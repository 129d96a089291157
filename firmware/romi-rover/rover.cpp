// Romi rover: the Romi device of the virtual rover (`tether demo`, docs/examples/rover-virtual.json): an
// actuator and a sensor behind the Romi protocol, the same job the proxy and Elcano devices do in the demo.
//
//   S[throttle_us,steering_us] -> servo pulses on D9 (throttle) and D10 (steering), each 1000..2000 us;
//                                 replies [0], or [1,"pulse out of range"] without touching the outputs.
//   A[channel]                 -> replies [0,value]: one 10-bit conversion of A<channel> (0..5), AVcc reference;
//                                 [2,"no such channel"] otherwise.
//   L[throttle_us,steering_us,"label"] -> S with a manoeuvre label (up to the protocol's 32 chars): the servos
//                                 move as for S; replies [0,label length] (`tether bench --payload large`: a
//                                 request near the 64-byte frame limit that the image really parses and runs).
//   R                          -> replies [0,a0,...,a5]: one conversion of each of A0..A5 (the large reading).
//
// Every S that moves the servos is recorded in the execution witness with key (throttle_us << 16 | steering_us)
// (tether/core/execution_witness.hpp): `tether demo` checks that each confirmed call ran exactly once.
//
// 115200 8N1, no banner. At boot both servos are driven at 1500 us (neutral), like an ESC expects.
#include <string.h>

#include "RomiSerial.h"
#include "tether/core/execution_witness.hpp"
#include "tether/firmware/adc.hpp"
#include "tether/firmware/runtime.hpp"
#include "tether/firmware/servo_timer1.hpp"
#include "tether/romi/device/uart_stream.hpp"

using namespace romiserial;
using tether::firmware::servo_timer1::Output;

namespace {

// A request is at most 66 bytes; 128 bytes of RX absorb a host that sends the next one early.
using Serial = tether::firmware::Uart0<128, 64>;
constexpr uint32_t kBaud = 115200;
constexpr int16_t kMinPulseUs = 1000;
constexpr int16_t kMaxPulseUs = 2000;
constexpr uint16_t kNeutralUs = 1500;

bool valid_pulse(int16_t us) { return us >= kMinPulseUs && us <= kMaxPulseUs; }

// Moves both servos; false (and the error sent) when a pulse is out of range.
bool drive_servos(IRomiSerial* romi, const int16_t* args) {
  if (!valid_pulse(args[0]) || !valid_pulse(args[1])) {
    romi->send_error(1, "pulse out of range");
    return false;
  }
  tether::firmware::servo_timer1::write(Output::d9, static_cast<uint16_t>(args[0]));
  tether::firmware::servo_timer1::write(Output::d10, static_cast<uint16_t>(args[1]));
  tether::witness_executed(tether::witness_key(static_cast<uint16_t>(args[0]), static_cast<uint16_t>(args[1])));
  return true;
}

void set_servos(IRomiSerial* romi, int16_t* args, const char*) {
  if (drive_servos(romi, args)) romi->send_ok();
}

void set_servos_labelled(IRomiSerial* romi, int16_t* args, const char* label) {
  if (!drive_servos(romi, args)) return;
  ArrayText<16> reply;
  reply.add_int(0).add_int(static_cast<int32_t>(strlen(label)));
  romi->send(reply.c_str());
}

void read_analog(IRomiSerial* romi, int16_t* args, const char*) {
  if (args[0] < 0 || args[0] > 5) {
    romi->send_error(2, "no such channel");
    return;
  }
  ArrayText<16> reply;
  reply.add_int(0).add_int(tether::firmware::adc::read(static_cast<uint8_t>(args[0])));
  romi->send(reply.c_str());
}

void read_all_analog(IRomiSerial* romi, int16_t*, const char*) {
  ArrayText<48> reply;  // "[0" + 6 x ",1023" + "]"
  reply.add_int(0);
  for (uint8_t channel = 0; channel < 6; ++channel) reply.add_int(tether::firmware::adc::read(channel));
  romi->send(reply.c_str());
}

const MessageHandler handlers[] = {
    {'S', 2, false, set_servos},
    {'A', 1, false, read_analog},
    {'L', 2, true, set_servos_labelled},
    {'R', 0, false, read_all_analog},
};

tether::romi::device::UartStream<Serial> serial;
RomiSerial romi_serial(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  tether::firmware::adc::begin(0x3F);  // A0..A5 are analog inputs here
  tether::firmware::servo_timer1::attach(Output::d9, kNeutralUs);
  tether::firmware::servo_timer1::attach(Output::d10, kNeutralUs);
  tether::firmware::runtime_init<Serial>(kBaud);
  for (;;) {
    romi_serial.handle_input();
    tether::firmware::idle<Serial>();
  }
}
