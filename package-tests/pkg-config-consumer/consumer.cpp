// pkg-config-consumer FIRMWARE_DIR: a program built with `pkg-config --cflags --libs tether-romi
// tether-proxy tether-elcano tether-virtual-uno` and nothing else. On virtual Unos: calls romi-test's `e`
// (answers [0,1,2]) and sets a servo on the proxy image (acked); writes and reads back an Elcano drive
// message. Prints one line per check; exit status 0 when all passed.
// A service includes asio for its own timers and sockets, and usually first: it must compile so.
#include <boost/asio.hpp>

#include <cstdint>
#include <filesystem>
#include <iostream>
#include <string>

#include <tether/elcano/decoder.hpp>
#include <tether/elcano/encoder.hpp>
#include <tether/elcano/message.hpp>
#include <tether/proxy/client.hpp>
#include <tether/romi/client.hpp>
#include <tether/transports/io_thread.hpp>
#include <tether/transports/virtual_uno_stream.hpp>

namespace {

tether::transports::VirtualUnoOptions board(const std::filesystem::path& image) {
  tether::transports::VirtualUnoOptions options;
  options.firmware = image;
  return options;
}

bool elcano_round_trip() {
  const tether::elcano::Message drive = tether::elcano::Message::drive(50, 25);
  std::uint8_t wire[64];
  const auto written = tether::elcano::encode_message(drive, tether::elcano::Generation::d,
                                                     tether::MutableByteView(wire, sizeof wire));
  if (!written.ok()) return false;
  tether::LinkCounters counters;
  tether::elcano::Decoder<> decoder(tether::elcano::Generation::d, counters);
  for (std::size_t i = 0; i < written.value(); ++i) {
    if (decoder.feed(wire[i]) == tether::DecodeStatus::frame) {
      const tether::elcano::Message& message = decoder.frame();
      std::cout << "elcano: " << std::string(reinterpret_cast<const char*>(wire), written.value() - 1)
                << " read back as " << tether::elcano::to_string(message.type) << " speed " << message.speed
                << " angle " << message.angle << "\n";
      return message.type == tether::elcano::Type::drive && message.speed == 50 && message.angle == 25;
    }
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: pkg-config-consumer FIRMWARE_DIR\n";
    return 2;
  }
  const std::filesystem::path images = argv[1];
  tether::transports::IoThread io;

  tether::romi::Client romi(tether::transports::VirtualUnoStream::open(io.executor(), board(images / "romi-test.elf")));
  const tether::romi::RomiResponse answer = romi.call("e");
  std::cout << "romi: e -> " << answer.values.dump() << "\n";

  tether::proxy::Client proxy(tether::transports::VirtualUnoStream::open(io.executor(), board(images / "proxy.elf")));
  proxy.servo(9).init(90);
  const tether::proxy::SendResult sent = proxy.servo(9).set(120);
  std::cout << "proxy: servo 9 to 120, " << (sent.acked ? "acked" : "not acked") << "\n";

  const bool elcano = elcano_round_trip();
  return answer.values.dump() == "[0,1,2]" && sent.acked && elcano ? 0 : 1;
}
