// rover-service CONFIG [FIRMWARE_DIR]: a small rover service built against an installed Tether. Opens the
// rover of CONFIG (docs/config.md) and drives the first device of each codec once: the Romi device's
// servos (`S[1500,1500]`), a proxy servo (pin 9 to 90 degrees) and an Elcano drive request answered by the
// ring's sensor report. Prints one line per device driven; exit status 0 when every one answered, 1
// otherwise, 2 for a configuration that cannot be read or opened.
// A service includes asio for its own timers and sockets, and usually first: it must compile so.
#include <boost/asio.hpp>

#include <exception>
#include <iostream>
#include <string>
#include <variant>

#include <tether/devices/config.hpp>
#include <tether/devices/rover.hpp>
#include <tether/elcano/client.hpp>
#include <tether/elcano/message.hpp>
#include <tether/proxy/client.hpp>
#include <tether/romi/client.hpp>
#include <tether/transports/io_thread.hpp>
#ifdef ROVER_SERVICE_VIRTUAL_BOARDS
#include <tether/devices/virtual_boards.hpp>
#endif

namespace {

bool drive(const tether::devices::RoverDevice& device) {
  if (const auto romi = device.client.get<tether::romi::Client>()) {
    const tether::romi::RomiResponse answer = romi->call("S[1500,1500]");
    std::cout << device.name << " (romi): " << answer.values.dump() << "\n";
    return answer.code == 0;
  }
  if (const auto proxy = device.client.get<tether::proxy::Client>()) {
    const tether::proxy::SendResult sent = proxy->servo(9).set(90);  // the configuration's inits ran
    std::cout << device.name << " (proxy): servo 9 at 90, " << int(sent.attempts) << " attempt(s)"
              << (sent.acked ? ", acked" : "") << "\n";
    return true;
  }
  const auto ring = device.client.get<tether::elcano::RingClient>();
  const tether::elcano::Message drive = tether::elcano::Message::drive(50, 25);  // D{s 50}{a 25}
  const tether::elcano::Message report = ring->request(drive, tether::elcano::Type::sensor);
  std::cout << device.name << " (elcano): answered by " << tether::elcano::to_string(report.type) << "\n";
  return report.type == tether::elcano::Type::sensor;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    std::cerr << "usage: rover-service CONFIG [FIRMWARE_DIR]\n";
    return 2;
  }
#ifdef ROVER_SERVICE_VIRTUAL_BOARDS
  tether::devices::enable_virtual_boards();  // this build links Tether::virtual_uno
#endif
  tether::transports::IoThread io;
  tether::devices::Rover rover;
  try {
    tether::devices::ParseOptions where;
    if (argc == 3) where.firmware_dir = argv[2];  // only for virtual boards
    const tether::devices::RoverConfig config = tether::devices::load_config(argv[1], where);
    rover = tether::devices::open_rover(config, io.executor());
  } catch (const tether::devices::ConfigError& error) {
    std::cerr << "rover-service: " << error.what() << "\n";
    return 2;
  }
  bool romi = false, proxy = false, elcano = false, all_answered = true;
  try {
    for (const tether::devices::RoverDevice& device : rover.devices()) {
      bool& done = device.client.get<tether::romi::Client>()         ? romi
                   : device.client.get<tether::elcano::RingClient>() ? elcano
                                                                     : proxy;
      if (done) continue;
      done = true;
      all_answered = drive(device) && all_answered;
    }
  } catch (const std::exception& error) {
    std::cerr << "rover-service: " << error.what() << "\n";
    return 1;
  }
  rover.close();
  return all_answered ? 0 : 1;
}
