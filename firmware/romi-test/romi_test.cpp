// Romi test image: the handler table the interop tests drive through the virtual Uno.
// 115200 8N1, no banner; the first byte the host sees is the response to its first request.
//
// | opcode | integers | string | behaviour                                                        |
// |--------|----------|--------|------------------------------------------------------------------|
// | a      | 0        | no     | send_ok: `[0]`                                                   |
// | b      | 0        | no     | sends nothing: the device answers `[-20]`                        |
// | c      | 2        | no     | send_ok                                                          |
// | d      | 0        | yes    | send_ok                                                          |
// | e      | 0        | no     | send("[0,1,2]")                                                  |
// | f      | 0        | no     | send_error(101, "I will try again tomorrow")                     |
// | m      | 12       | no     | send_ok                                                          |
// | s      | 2        | no     | `[0,sum]`, the sum computed in 32 bits (32767+1 gives 32768)     |
// | t      | 0        | yes    | echoes the string: `[0,"<string>"]`                              |
// | w      | 1        | no     | busy-waits n ms (n <= 0: none), servicing nothing, then send_ok  |
// | g      | 1        | no     | sends n log lines `#!log 1:xxxx\r\n` .. `#!log n:xxxx\r\n`, then send_ok |
//
// Spec vectors (../shared/specs/romi.md): `#a:xxxx` -> `#a[0]:00e7`, `#a[1]:xxxx` -> `#a[-17]:00ac`,
// `#z:xxxx` -> `#z[-16]:0001`, `#e:xxxx` -> `#e[0,1,2]:00dc`,
// `#f:32dd` -> `#f[101,"I will try again tomorrow"]:32c3`.
#include "RomiSerial.h"
#include "tether/core/time.hpp"
#include "tether/firmware/runtime.hpp"
#include "tether/romi/device/uart_stream.hpp"

using namespace romiserial;

namespace {

// RX 128: the host may send requests (retries, the next test step) while `w` busy-waits; a request is
// at most 66 bytes, so two fit. TX 128: `g` writes log lines faster than the line drains them.
using Serial = tether::firmware::Uart0<128, 128>;
constexpr uint32_t kBaud = 115200;

void ok(IRomiSerial* romi, int16_t*, const char*) { romi->send_ok(); }

void silent(IRomiSerial*, int16_t*, const char*) {}

void values(IRomiSerial* romi, int16_t*, const char*) { romi->send("[0,1,2]"); }

void fail(IRomiSerial* romi, int16_t*, const char*) { romi->send_error(101, "I will try again tomorrow"); }

void sum(IRomiSerial* romi, int16_t* args, const char*) {
  ArrayText<16> reply;
  reply.add_int(0).add_int(static_cast<int32_t>(args[0]) + static_cast<int32_t>(args[1]));
  romi->send(reply.c_str());
}

void echo_text(IRomiSerial* romi, int16_t*, const char* string_arg) {
  ArrayText<40> reply;  // "[0,\"" + 32 characters + "\"]" + NUL = 39
  reply.add_int(0).add_string(string_arg);
  romi->send(reply.c_str());
}

void wait(IRomiSerial* romi, int16_t* args, const char*) {
  if (args[0] > 0) {
    const tether::Millis until = tether::firmware::millis() + static_cast<tether::Millis>(args[0]);
    while (!tether::tick_reached(tether::firmware::millis(), until)) {
    }
  }
  romi->send_ok();
}

void logs(IRomiSerial* romi, int16_t* args, const char*) {
  for (int16_t i = 1; i <= args[0]; ++i) {
    char text[12] = "log ";
    const uint8_t length = tether::romi::device::format_decimal(i, text + 4);
    text[4 + length] = '\0';
    romi->log(text);
  }
  romi->send_ok();
}

const MessageHandler handlers[] = {
    {'a', 0, false, ok},
    {'b', 0, false, silent},
    {'c', 2, false, ok},
    {'d', 0, true, ok},
    {'e', 0, false, values},
    {'f', 0, false, fail},
    {'m', 12, false, ok},
    {'s', 2, false, sum},
    {'t', 0, true, echo_text},
    {'w', 1, false, wait},
    {'g', 1, false, logs},
};

tether::romi::device::UartStream<Serial> serial;
RomiSerial romi_serial(serial, serial, handlers, sizeof(handlers) / sizeof(MessageHandler));

}  // namespace

TETHER_UART0_ISRS(Serial);

int main() {
  tether::firmware::runtime_init<Serial>(kBaud);
  for (;;) {
    romi_serial.handle_input();
    tether::firmware::idle<Serial>();
  }
}
