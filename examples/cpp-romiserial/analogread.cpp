// RomiSerial's README "AnalogRead" in C++, written for Tether's compatibility headers: reads the sensor on
// A0 every second through opcode 'A' (answer `[0, value]`) and prints `Sensor value: <value>`.
// Usage: analogread_app <serial-device> [iterations [delay-ms]]  (without iterations it reads forever, as
// the README's does). An error answer is printed to stderr and makes the exit status 1.
#include <chrono>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <string>
#include <thread>

#include <Console.h>
#include <RSerial.h>
#include <RomiSerialClient.h>

using namespace romiserial;

static void delay(long milliseconds) { std::this_thread::sleep_for(std::chrono::milliseconds(milliseconds)); }

int main(int argc, char** argv) {
  if (argc < 2 || argc > 4) {
    std::cerr << "usage: analogread_app <serial-device> [iterations [delay-ms]]\n";
    return 2;
  }
  const std::string device = argv[1];
  const long iterations = argc > 2 ? std::strtol(argv[2], nullptr, 10) : -1;  // < 0: forever
  const long pause = argc > 3 ? std::strtol(argv[3], nullptr, 10) : 1000;

  try {
    auto log = std::make_shared<Console>();
    auto serial = std::make_shared<RSerial>(device, 115200, true, log);
    RomiSerialClient romiClient(serial, serial, log, 0, "analogread");
    nlohmann::json response;
    bool failed = false;
    for (long i = 0; iterations < 0 || i < iterations; ++i) {
      romiClient.send("A", response);
      if (response[kStatusCode] == 0) {
        std::cout << "Sensor value: " << response[1] << std::endl;
      } else {
        std::cerr << "A: " << response << "\n";
        failed = true;
      }
      delay(pause);
    }
    return failed ? 1 : 0;
  } catch (const std::exception& error) {
    std::cerr << "analogread_app: " << error.what() << "\n";
    return 1;
  }
}
