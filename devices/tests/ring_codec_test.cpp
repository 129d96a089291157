// A codec a program registers that runs on virtual rings: its row, not the devices library, says what a ring
// board's settings object means and which image a board runs by default. Its own program: registering a codec
// changes the table every other configuration test sees.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <string>
#include <variant>
#include <vector>

#include "tether/devices/codecs.hpp"
#include "tether/devices/config.hpp"

namespace tether::devices {
namespace {

// The options of the test codecs: a byte every board's settings start with.
struct MarkOptions {
  std::uint8_t mark = 0xA5;
};

CodecOptions parse_mark(const OptionsContext& context) {
  MarkOptions options;
  if (const auto object = context.object()) {
    if (auto v = object->optional("mark")) options.mark = static_cast<std::uint8_t>(read_unsigned(*v, 0, 255));
  }
  return options;
}

DeviceClient no_client(std::shared_ptr<transports::ByteStream>, const DeviceConfig&,
                       std::shared_ptr<client::LinkClock>) {
  return {};
}

// "ring-mark": boards run `mark-node` unless named; `{"fill": N}` is the device's mark, the board's index and
// N; `{"size": N}` asks for N bytes (to see the library bound what a row returns).
Codec ring_mark_codec() {
  static const Codec codec = [] {
    CodecRow row;
    row.name = "ring-mark";
    row.option_keys = {"mark"};
    row.virtual_boards = VirtualBoards::ring;
    row.parse_options = parse_mark;
    row.open = no_client;
    row.ring_board_image = "mark-node";
    row.ring_board_settings = [](const RingBoardContext& board) {
      const JsonObject settings(board.settings);
      settings.allow_only({"fill", "size"});
      if (auto size = settings.optional("size")) return std::vector<std::uint8_t>(read_unsigned(*size), 0);
      const auto fill = static_cast<std::uint8_t>(read_unsigned(settings.required("fill"), 0, 255));
      return std::vector<std::uint8_t>{board.options->get<MarkOptions>().mark, static_cast<std::uint8_t>(board.index),
                                       fill};
    };
    return register_codec(row);
  }();
  return codec;
}

// "ring-plain": a ring codec without board settings or a default image.
Codec ring_plain_codec() {
  static const Codec codec = [] {
    CodecRow row;
    row.name = "ring-plain";
    row.virtual_boards = VirtualBoards::ring;
    row.parse_options = [](const OptionsContext&) -> CodecOptions { return MarkOptions{}; };
    row.open = no_client;
    return register_codec(row);
  }();
  return codec;
}

std::string ring_device(const std::string& codec, const std::string& boards, const std::string& options = "") {
  return R"({"devices": [{"name": "r", "codec": ")" + codec + R"(", "transport": {"virtual_ring": {"boards": )" +
         boards + "}}" + (options.empty() ? "" : R"(, "options": )" + options) + "}]}";
}

ParseOptions firmware_dir() {
  ParseOptions options;
  options.firmware_dir = "/opt/fw";
  return options;
}

std::string error_of(const std::string& text) {
  try {
    parse_config(text, firmware_dir());
  } catch (const ConfigError& error) {
    return error.what();
  }
  ADD_FAILURE() << "parsed: " << text;
  return {};
}

TEST(DevicesRingCodec, TheRowReadsBoardSettingsWithTheDevicesOptions) {
  ring_mark_codec();
  const RoverConfig config = parse_config(
      ring_device("ring-mark", R"([{"eeprom": {"fill": 7}}, {"firmware": "/x/other.elf", "eeprom": [1, 2]},
                                   {"eeprom": {"fill": 9}}])",
                  R"({"mark": 66})"),
      firmware_dir());
  const auto& ring = std::get<VirtualRingTransport>(config.devices[0].transport);
  ASSERT_EQ(ring.boards.size(), 3u);
  EXPECT_EQ(ring.boards[0].firmware, std::filesystem::path("/opt/fw/mark-node.elf"));
  EXPECT_EQ(ring.boards[0].eeprom, (std::vector<std::uint8_t>{66, 0, 7}));
  EXPECT_EQ(ring.boards[1].firmware, std::filesystem::path("/x/other.elf"));
  EXPECT_EQ(ring.boards[1].eeprom, (std::vector<std::uint8_t>{1, 2}));
  EXPECT_EQ(ring.boards[2].eeprom, (std::vector<std::uint8_t>{66, 2, 9}));
}

TEST(DevicesRingCodec, BoardSettingsErrorsAreAtTheirKeys) {
  ring_mark_codec();
  EXPECT_EQ(error_of(ring_device("ring-mark", R"([{}, {"eeprom": {"fil": 1}}])")),
            R"(devices[0].transport.virtual_ring.boards[1].eeprom: unknown key "fil" (did you mean "fill"?))");
  EXPECT_EQ(error_of(ring_device("ring-mark", R"([{"eeprom": {"fill": 256}}])")),
            "devices[0].transport.virtual_ring.boards[0].eeprom.fill: expected an unsigned integer in 0..255, got 256");
  EXPECT_EQ(error_of(ring_device("ring-mark", R"([{"eeprom": {"size": 1025}}])")),
            "devices[0].transport.virtual_ring.boards[0].eeprom: the settings make 1025 bytes of EEPROM (at most 1024)");
  const RoverConfig full = parse_config(ring_device("ring-mark", R"([{"eeprom": {"size": 1024}}])"), firmware_dir());
  EXPECT_EQ(std::get<VirtualRingTransport>(full.devices[0].transport).boards[0].eeprom.size(), 1024u);
}

TEST(DevicesRingCodec, ARowWithoutBoardSettingsTakesBytesAndNamedImagesOnly) {
  ring_plain_codec();
  EXPECT_EQ(error_of(ring_device("ring-plain", R"([{"firmware": "plain", "eeprom": {"fill": 1}}])")),
            "devices[0].transport.virtual_ring.boards[0].eeprom: expected an array of bytes, got object");
  EXPECT_EQ(error_of(ring_device("ring-plain", R"([{"eeprom": [1]}])")),
            R"(devices[0].transport.virtual_ring.boards[0]: missing key "firmware")");
  const RoverConfig config = parse_config(ring_device("ring-plain", R"([{"firmware": "plain", "eeprom": [3]}])"),
                                          firmware_dir());
  const auto& ring = std::get<VirtualRingTransport>(config.devices[0].transport);
  EXPECT_EQ(ring.boards[0].firmware, std::filesystem::path("/opt/fw/plain.elf"));
  EXPECT_EQ(ring.boards[0].eeprom, (std::vector<std::uint8_t>{3}));
}

}  // namespace
}  // namespace tether::devices
