// The C++ side of python/benchmarks/calls.py.
//   tether_python_calls_cpp IMAGE CALLS fast|real_time
//     N blocking Romi calls to a virtual board running IMAGE, through its pty opened as a serial port (the
//     path the Python client takes), timed from the first to the last; prints "calls_per_second <x>
//     cpu_us_per_call <y>".
//   tether_python_calls_cpp --fake-device
//     A Romi device that answers every request at once (`[0]`, no simulator): prints "PTY <path>" and
//     serves that pty until stdin closes. What a client's own cost per call is measured against.
//   tether_python_calls_cpp --port PTY CALLS
//     The N calls against a device already on PTY (the fake device).
#include <chrono>
#include <ctime>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <iostream>
#include <string>
#include <thread>

#include "tether/romi/client.hpp"
#include "tether/romi/decoder.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace {

using namespace tether;

int fake_device() {
  transports::IoThread io;
  const auto pty = transports::PtyStream::open(io.executor());
  std::printf("PTY %s\n", pty->slave_path().c_str());
  std::fflush(stdout);
  std::thread device([pty] {
    LinkCounters counters;
    romi::Decoder<64> decoder(counters);
    std::uint8_t input[256];
    std::uint8_t answer[64];
    const std::uint8_t body[] = {'[', '0', ']'};
    for (;;) {
      boost::system::error_code error;
      const std::size_t got = pty->read_some(boost::asio::buffer(input), error);
      if (error) return;
      for (std::size_t i = 0; i < got; ++i) {
        if (decoder.feed(input[i]) != DecodeStatus::frame || decoder.frame().log) continue;
        const auto size = romi::encode_response(decoder.frame().opcode, ByteView(body, sizeof body),
                                                decoder.frame().id, MutableByteView(answer, sizeof answer));
        if (!size.ok()) continue;
        pty->write(boost::asio::buffer(answer, size.value()), error);
        if (error) return;
      }
    }
  });
  std::string line;
  while (std::getline(std::cin, line)) {
  }
  boost::system::error_code ignored;
  pty->close(ignored);
  device.join();
  return 0;
}

// Prints the rate (wall clock) and the process's CPU time per call (both threads: caller and io), which
// a loaded machine disturbs far less than the rate.
void timed_calls(const std::string& port, long calls) {
  transports::IoThread io;
  transports::SerialOptions serial;  // a pty: no boot wait
  romi::Client client(transports::SerialPortStream::open(io.executor(), port, serial));
  client.call("a");  // warm-up
  const std::clock_t cpu_start = std::clock();
  const auto start = std::chrono::steady_clock::now();
  for (long i = 0; i < calls; ++i) client.call("a");
  const std::chrono::duration<double> elapsed = std::chrono::steady_clock::now() - start;
  const double cpu = static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC;
  std::printf("calls_per_second %.1f cpu_us_per_call %.2f\n", static_cast<double>(calls) / elapsed.count(),
              cpu * 1e6 / static_cast<double>(calls));
}

}  // namespace

int run(int argc, char** argv) {
  if (argc == 2 && std::string(argv[1]) == "--fake-device") return fake_device();
  if (argc == 4 && std::string(argv[1]) == "--port") {
    timed_calls(argv[2], std::strtol(argv[3], nullptr, 10));
    return 0;
  }
  if (argc != 4) {
    std::fprintf(stderr, "usage: %s IMAGE CALLS fast|real_time | --fake-device | --port PTY CALLS\n", argv[0]);
    return 2;
  }
  transports::VirtualUnoOptions options;
  options.firmware = argv[1];
  options.pacing = std::string(argv[3]) == "fast" ? transports::Pacing::fast : transports::Pacing::real_time;
  transports::VirtualUno board(options);
  const std::string port = board.open_pty();
  board.start();
  while (!board.uart().rx_enabled) std::this_thread::sleep_for(std::chrono::milliseconds(1));
  timed_calls(port, std::strtol(argv[2], nullptr, 10));
  return 0;
}

int main(int argc, char** argv) {
  try {
    return run(argc, argv);
  } catch (const std::exception& error) {  // a missing image, a port that does not open, a failed call
    std::fprintf(stderr, "%s: %s\n", argv[0], error.what());
    return 1;
  }
}
