// The C++ side of python/benchmarks/calls.py: N blocking Romi calls to a virtual romi-test board, through
// its pty opened as a serial port (the path the Python client takes), timed from the first to the last.
// Usage: tether_python_calls_cpp IMAGE CALLS fast|real_time ; prints "calls_per_second <x>".
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <thread>

#include "tether/romi/client.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/virtual_uno.hpp"

int main(int argc, char** argv) {
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s IMAGE CALLS fast|real_time\n", argv[0]);
    return 2;
  }
  using namespace tether;
  transports::VirtualUnoOptions options;
  options.firmware = argv[1];
  options.pacing = std::string(argv[3]) == "fast" ? transports::Pacing::fast : transports::Pacing::real_time;
  const long calls = std::strtol(argv[2], nullptr, 10);
  transports::VirtualUno board(options);
  const std::string port = board.open_pty();
  board.start();
  while (!board.uart().rx_enabled) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  transports::IoThread io;
  transports::SerialOptions serial;  // a pty: no boot wait
  romi::Client client(transports::SerialPortStream::open(io.executor(), port, serial));
  client.call("a");  // warm-up
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0; i < calls; ++i) client.call("a");
  const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - start;
  std::printf("calls_per_second %.1f\n", static_cast<double>(calls) / elapsed.count());
  return 0;
}
