// Arduino glue of the generated rpc libraries: see TetherRpcArduino.h.
#include "TetherRpcArduino.h"

#include "tether/firmware/reset.hpp"

namespace tether {
namespace arduino {

void rpc_write_frame(void* stream, ByteView frame) { static_cast<Stream*>(stream)->write(frame.data(), frame.size()); }

void rpc_write_frame_hardware(void* serial, ByteView frame) {
  write_all(*static_cast<HardwareSerial*>(serial), frame.data(), frame.size());
}

void rpc_restart(void* stream) {
  static_cast<Stream*>(stream)->flush();
  firmware::system_reset();
}

}  // namespace arduino
}  // namespace tether
