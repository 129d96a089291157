// RomiSerial's README "Blink" in C++, written for Tether's compatibility headers: the program a RomiSerial
// user has builds unchanged. Turns the LED on pin 13 on and off every second through opcode 'L'.
// Usage: blink_app <serial-device> [iterations [delay-ms]]  (without iterations it blinks forever, as the
// README's does). Errors answered by the device go to stderr; the exit status is 1 if there was any.
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
    std::cerr << "usage: blink_app <serial-device> [iterations [delay-ms]]\n";
    return 2;
  }
  const std::string device = argv[1];
  const long iterations = argc > 2 ? std::strtol(argv[2], nullptr, 10) : -1;  // < 0: forever
  const long pause = argc > 3 ? std::strtol(argv[3], nullptr, 10) : 1000;

  try {
    auto log = std::make_shared<Console>();
    auto serial = std::make_shared<RSerial>(device, 115200, true, log);
    RomiSerialClient romiClient(serial, serial, log, 0, "blink");
    nlohmann::json response;
    bool failed = false;
    for (long i = 0; iterations < 0 || i < iterations; ++i) {
      for (const char* command : {"L[1]", "L[0]"}) {
        romiClient.send(command, response);
        if (response[kStatusCode] != 0) {
          std::cerr << command << ": " << response << "\n";
          failed = true;
        }
        delay(pause);
      }
    }
    return failed ? 1 : 0;
  } catch (const std::exception& error) {
    std::cerr << "blink_app: " << error.what() << "\n";
    return 1;
  }
}
