// The `rpc-servos` image: servos.proto's service (one unary method, one stream) on an Arduino Uno, on the
// bare-metal runtime, the device the rpc codec's footprint targets are stated for. UART0 at 115200 8N1;
// frames, session id and Reset as rpc-example's (uart_device.hpp). The servos are simulated and ideal:
// Move sets an angle at once, which Watch reports.
#include "ServosRpc_service.h"
#include "uart_device.hpp"

namespace {

constexpr uint32_t kBaud = 115200;
constexpr uint8_t kServos = 4;

int32_t angles[kServos];

const char kNoServo[] PROGMEM = "no servo";

// Bound at start, all zeros until then (.bss).
ServosRpcService::Device device;

}  // namespace

tether::rpc::Status Servos_Move(const servos_Target& request, servos_Reached& reply) {
  if (request.servo >= kServos) return tether::rpc::Status::error_P(1, kNoServo);
  angles[request.servo] = request.angle_cdeg;
  reply.angle_cdeg = request.angle_cdeg;
  return tether::rpc::Status::ok();
}

tether::rpc::Status Servos_Watch(const servos_WatchRequest&, servos_Telemetry& next) {
  next.angles_cdeg_count = kServos;
  for (uint8_t i = 0; i < kServos; ++i) next.angles_cdeg[i] = angles[i];
  next.millis = tether::firmware::millis();
  return tether::rpc::Status::ok();
}

TETHER_UART0_ISRS(tether::rpc::image::Uart);

int main() { tether::rpc::image::run_uart_device<ServosRpcService, device, kBaud>(); }
