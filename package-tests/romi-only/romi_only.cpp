// romi-only: one romi::Client call to a device played on the other end of an in-memory stream, answered
// with the codec's own response writer. Prints the answer; exit status 0 when it is `[0,7]`.
#include <array>
#include <cstdint>
#include <cstdio>
#include <string>
#include <thread>

#include <tether/romi/client.hpp>
#include <tether/romi/encoder.hpp>
#include <tether/transports/in_memory_stream.hpp>
#include <tether/transports/io_thread.hpp>

namespace {

// Reads one request frame (`#e:07xx\r\n`) and answers `[0,7]` with its opcode and id.
void answer_one_request(tether::transports::InMemoryStream& device) {
  std::string frame;
  std::array<char, 64> chunk{};
  while (frame.find("\r\n") == std::string::npos) {
    boost::system::error_code error;
    const std::size_t n = device.read_some(boost::asio::buffer(chunk), error);
    if (error) return;
    frame.append(chunk.data(), n);
  }
  const std::size_t colon = frame.find(':');
  if (frame.size() < 2 || frame[0] != '#' || colon == std::string::npos) return;
  const auto id = static_cast<std::uint8_t>(std::stoul(frame.substr(colon + 1, 2), nullptr, 16));
  std::array<std::uint8_t, 64> out{};
  const auto written = tether::romi::encode_response(frame[1], tether::ByteView::from_literal("[0,7]"), id,
                                                     tether::MutableByteView(out.data(), out.size()));
  if (!written.ok()) return;
  boost::system::error_code error;
  device.write(boost::asio::buffer(out.data(), written.value()), error);
}

}  // namespace

int main() {
  tether::transports::IoThread io;
  auto [host, device] = tether::transports::InMemoryStream::make_pair(io.executor());
  std::thread board([device = device] { answer_one_request(*device); });
  int status = 1;
  {
    tether::romi::Client client(host);
    boost::system::error_code error;
    const tether::romi::RomiResponse answer = client.call("e", error);
    const std::string values = answer.values.dump();
    std::printf("romi-only: %s%s%s\n", values.c_str(), error ? " " : "", error ? error.message().c_str() : "");
    if (!error && answer.code == 0 && values == "[0,7]") status = 0;
    client.close();
  }
  device->close();
  board.join();
  return status;
}
