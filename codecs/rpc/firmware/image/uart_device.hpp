// A bare-metal rpc image's whole main loop on UART0, for any service `tether-rpc-service` generated: an
// image is its schema's handlers and one call of run_uart_device (rpc_example.cpp, servos.cpp).
//
// The device is bound and begun at start with its boot's session id (tether/proxy/device/session_id.hpp,
// read first, from the untouched SRAM), its frames written to the UART, Reset through the watchdog. The loop
// hands what the RX ring holds to the device in place (a frame's bytes go through the decoder's run loop),
// polls it, and sleeps until a byte arrives or the clock ticks.
//
// RAM: the device runtime's static tables (the receive buffer, the exactly-once cache, the counters; the
// method table is in flash) and its stack at the deepest point (a call's request and reply structs, its
// answer being encoded and framed) leave little of the 2 KB: the UART rings are small (RX 32 bytes: the
// loop takes bytes as they come; TX 32 bytes: a stream message of a few fields, an ack or a short reply is
// queued at once, a longer frame waits for room in `write`, each byte sent waking it) and the device's
// entry points are out of line (below). The image defines the UART's interrupts:
// `TETHER_UART0_ISRS(tether::rpc::image::Uart);`.
#pragma once

#include "tether/core/bytes.hpp"
#include "tether/firmware/runtime.hpp"
#include "tether/proxy/device/session_id.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/rpc/device/rpc_device.hpp"

namespace tether {
namespace rpc {
namespace image {

/// UART0 with the images' rings: RX 32 bytes, TX 32.
using Uart = tether::firmware::Uart0<32, 32>;

/// The shortest stream period a device with `Limits` keeps at `baud`: one frame of its largest outgoing
/// message at the baud (10 bits a byte), rounded up, so that a stream never sends faster than the line
/// carries it.
template <typename Limits>
constexpr uint16_t min_period_ms(uint32_t baud) {
  return static_cast<uint16_t>(
      (static_cast<uint32_t>(tether::proxy::max_frame_size(Limits::kMaxOutPayload)) * 10u * 1000u + baud - 1u) / baud);
}

namespace detail {

inline void write_frame(void*, tether::ByteView frame) { Uart::write(frame); }

inline void restart(void*) {
  Uart::flush();  // the Reset's ack must leave the UART first
  tether::firmware::system_reset();
}

// The device's entry points out of line: each puts its answer buffers on the stack for its own run
// (rpc_device.hpp's Buffers); inlined into the loop, the compiler kept their room in main's frame for good,
// ~150 bytes each under the deepest point (a call's reply).
// The device is a template argument (a global object), not a parameter: it costs no pointer to pass, as
// the images' own functions on their global device did.
template <typename Service, typename Service::Device& device, uint32_t baud>
__attribute__((noinline)) void start(uint32_t session_id) {
  device.bind(Service::service(), tether::rpc::device::FrameSink{write_frame, nullptr}, restart);
  device.set_min_period_ms(min_period_ms<typename Service::Limits>(baud));
  device.begin(session_id, tether::firmware::millis());  // end of setup: ResetEvent
}
template <typename Service, typename Service::Device& device>
__attribute__((noinline)) size_t handle(tether::ByteView received) {
  return device.handle_bytes(received, tether::firmware::millis());
}
template <typename Service, typename Service::Device& device>
__attribute__((noinline)) void poll() {
  device.poll(tether::firmware::millis());
}

// Sleeps until a byte arrives or the clock ticks: a wake by the transmitter alone (one per byte sent,
// ~30 a stream message) goes back to sleep without a loop pass, as nothing can have come due. The tick
// is seen in the clock's low byte (one load, no interrupt lock: each of those wakes is cheaper).
inline void sleep_until_work() {
  const uint8_t at = tether::firmware::millis_low_byte();
  do {
    tether::firmware::idle<Uart>();
  } while (Uart::available() == 0 && tether::firmware::millis_low_byte() == at);
}

}  // namespace detail

/// Runs `device` (a global `Service::Device`, made without arguments so that it is all zeros in .bss) on
/// UART0 at `baud` 8N1, for good. Call it first in main: it reads the boot's session id from the SRAM
/// before anything else has written it.
template <typename Service, typename Service::Device& device, uint32_t baud>
__attribute__((always_inline, noreturn)) inline void run_uart_device() {
  const uint32_t session_id = tether::proxy::device::boot_session_id();
  tether::firmware::runtime_init<Uart>(baud);
  detail::start<Service, device, baud>(session_id);
  for (;;) {
    const tether::ByteView received = Uart::peek();
    if (!received.empty()) Uart::consume(static_cast<uint8_t>(detail::handle<Service, device>(received)));
    detail::poll<Service, device>();
    if (received.empty()) detail::sleep_until_work();
  }
}

}  // namespace image
}  // namespace rpc
}  // namespace tether
