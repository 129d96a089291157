// Captures in the devices library: every codec row's capture framing (noise, over-long frames, a partial
// frame at close, frames split across reads), the interface descriptions, and the `record` keys of a
// configuration.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "tether/devices/codecs.hpp"
#include "tether/devices/config.hpp"
#include "tether/devices/rover.hpp"

namespace tether::devices {
namespace {

using transports::FramedPacket;

DeviceConfig device_of(std::string_view codec) {
  DeviceConfig device;
  device.name = "dev";
  const CodecRow* row = find_codec(codec);
  EXPECT_NE(row, nullptr) << codec;
  device.codec = row->codec;
  device.transport = TcpTransport{"localhost", 4001, std::chrono::milliseconds(100)};
  return device;
}

// The packets `codec`'s inbound framer cuts `reads` into, then closed: `[bytes]` for frames,
// `[bytes|comment]` for unframed bytes (non-printable bytes as \xNN).
std::string framed(std::string_view codec, const std::vector<std::string>& reads) {
  const CodecRow* row = find_codec(codec);
  if (row == nullptr || !row->capture_framing) return "no framing";
  const auto framer = row->capture_framing(device_of(codec))(true);
  std::string text;
  const transports::PacketSink sink = [&](FramedPacket packet) {
    text += "[";
    for (const std::uint8_t byte : packet.bytes) {
      if (byte >= 0x20 && byte < 0x7f) {
        text.push_back(static_cast<char>(byte));
      } else {
        static const char* digits = "0123456789abcdef";
        text += std::string("\\x") + digits[byte >> 4] + digits[byte & 0xF];
      }
    }
    if (!packet.frame) text += "|" + packet.comment();
    text += "]";
  };
  for (const auto& read : reads) {
    framer->feed(std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(read.data()), read.size()), sink);
  }
  framer->flush("cut at close", sink);
  return text;
}

TEST(CaptureFraming, Romi) {
  EXPECT_EQ(framed("romi", {"#e:0", "a5c\r\n#!hello:xxxx\r\n"}), "[#e:0a5c\\x0d\\x0a][#!hello:xxxx\\x0d\\x0a]");
  EXPECT_EQ(framed("romi", {"\xff\xfe#e:0a5c\r\n"}), "[\\xff\\xfe|unframed: noise][#e:0a5c\\x0d\\x0a]");
  EXPECT_EQ(framed("romi", {"#e:0a", "#v:1b22\r\n#a"}),
            "[#e:0a|unframed: cut by a new frame][#v:1b22\\x0d\\x0a][#a|unframed: cut at close]");
  const std::string long_frame = "#" + std::string(1100, 'a') + "\r\n";
  const std::string packets = framed("romi", {long_frame, "#e:0a5c\r\n"});
  EXPECT_EQ(packets.find("unframed: too long"), 1 + 1032 + 1u) << packets;  // cut at the bound: 1032 bytes
  EXPECT_NE(packets.find("[#e:0a5c\\x0d\\x0a]"), std::string::npos);
}

TEST(CaptureFraming, Elcano) {
  EXPECT_EQ(framed("elcano", {"D{s 1", "0}{a 5}\n", "S{v 3}\n"}), "[D{s 10}{a 5}\\x0a][S{v 3}\\x0a]");
  EXPECT_EQ(framed("elcano", {"zz\nD{s 1}\n"}), "[zz\\x0a|unframed: noise][D{s 1}\\x0a]");
  EXPECT_EQ(framed("elcano", {"D{s 1}S{v 2}\n", "G{p"}),
            "[D{s 1}|unframed: cut by a new frame][S{v 2}\\x0a][G{p|unframed: cut at close]");
  const std::string packets = framed("elcano", {"D{" + std::string(2000, '1') + "}\nS{v 2}\n"});
  EXPECT_NE(packets.find("unframed: too long"), std::string::npos);
  EXPECT_EQ(packets.substr(packets.size() - 12), "[S{v 2}\\x0a]");
}

TEST(CaptureFraming, ProxyAndRpcFramesAreCobs) {
  for (const char* codec : {"proxy", "proxy-compat", "rpc"}) {
    SCOPED_TRACE(codec);
    const std::string wire("\x00\x03\x01\x02\x00\x02\x05\x00\x04", 9);
    EXPECT_EQ(framed(codec, {wire.substr(0, 2), wire.substr(2)}),
              "[\\x00\\x03\\x01\\x02\\x00][\\x02\\x05\\x00][\\x04|unframed: cut at close]");
    const std::string packets = framed(codec, {std::string(600, '\x01') + std::string(1, '\0') + "\x02\x05" +
                                               std::string(1, '\0')});
    EXPECT_NE(packets.find("unframed: too long"), std::string::npos);
    EXPECT_EQ(packets.substr(packets.size() - 14), "[\\x02\\x05\\x00]");
  }
}

TEST(CaptureDescription, NamesCodecBaudTransportAndTheCodecsWords) {
  DeviceConfig romi = device_of("romi");
  romi.transport = SerialTransport{"/dev/ttyACM0", transports::SerialOptions::arduino_uno()};
  EXPECT_EQ(capture_description(romi), "tether codec=romi baud=115200 transport=serial");
  EXPECT_EQ(capture_description(device_of("proxy")), "tether codec=proxy baud=- transport=tcp crc=on");
  EXPECT_EQ(capture_description(device_of("proxy-compat")), "tether codec=proxy-compat baud=- transport=tcp");
}

TEST(RecordConfig, AFileOrAnObjectOnADeviceAndOnTheRover) {
  ParseOptions where;
  where.base_dir = "/srv/rover";
  const RoverConfig config = parse_config(R"({
    "record": {"file": "rover.pcapng", "max_bytes": 1048576, "max_seconds": 60, "files": 5, "overwrite": true},
    "devices": [
      {"name": "arm", "codec": "romi", "transport": {"tcp": {"host": "pi", "port": 4001}}, "record": "/tmp/arm.pcapng"},
      {"name": "base", "codec": "romi", "transport": {"tcp": {"host": "pi", "port": 4002}}}
    ]})",
                                          where);
  ASSERT_TRUE(config.record);
  EXPECT_EQ(config.record->file, "/srv/rover/rover.pcapng");
  EXPECT_EQ(config.record->max_file_bytes, 1048576u);
  EXPECT_EQ(config.record->max_file_duration, std::chrono::seconds(60));
  EXPECT_EQ(config.record->ring_files, 5u);
  EXPECT_TRUE(config.record->overwrite);
  ASSERT_TRUE(config.devices[0].record);
  EXPECT_EQ(config.devices[0].record->file, "/tmp/arm.pcapng");
  EXPECT_FALSE(config.devices[0].record->overwrite);
  EXPECT_FALSE(config.devices[1].record);
}

TEST(RecordConfig, BadValuesNameTheirKey) {
  const auto error_of = [](const std::string& record) {
    try {
      parse_config(R"({"devices": [{"name": "arm", "codec": "romi", "transport": {"tcp": {"host": "pi", "port": 1}},
                       "record": )" + record + "}]}");
    } catch (const ConfigError& error) {
      return std::string(error.what());
    }
    return std::string("no error");
  };
  EXPECT_EQ(error_of("\"\""), "devices[0].record: expected a non-empty string, got string \"\"");
  EXPECT_EQ(error_of("7"), "devices[0].record: expected a capture file name or an object with \"file\", got number 7");
  EXPECT_EQ(error_of(R"({"file": "a", "max_byte": 5})").rfind("devices[0].record: unknown key \"max_byte\"", 0), 0u);
  EXPECT_EQ(error_of(R"({"file": "a", "files": 1})").rfind("devices[0].record.files: expected an unsigned integer in 2..1000", 0), 0u)
      << error_of(R"({"file": "a", "files": 1})");
  EXPECT_EQ(error_of(R"({"max_bytes": 5000})"), "devices[0].record: missing key \"file\"");
}

}  // namespace
}  // namespace tether::devices
