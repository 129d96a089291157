#include "tether/transports/intel_hex.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <map>
#include <sstream>

namespace tether::transports {

namespace {

int nibble(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

}  // namespace

std::size_t HexImage::size() const {
  std::size_t total = 0;
  for (const auto& segment : segments) total += segment.bytes.size();
  return total;
}

std::uint32_t HexImage::begin() const { return segments.empty() ? 0 : segments.front().address; }

std::uint32_t HexImage::end() const {
  if (segments.empty()) return 0;
  return segments.back().address + static_cast<std::uint32_t>(segments.back().bytes.size());
}

std::optional<HexImage> parse_intel_hex(std::string_view text, std::string& error, std::size_t limit) {
  std::map<std::uint32_t, std::vector<std::uint8_t>> runs;  // by address; merged below
  std::uint32_t base = 0;
  std::size_t total = 0;
  bool ended = false;
  std::size_t line_number = 0;
  while (!text.empty() && !ended) {
    const std::size_t newline = text.find('\n');
    std::string_view line = text.substr(0, newline);
    text = newline == std::string_view::npos ? std::string_view() : text.substr(newline + 1);
    ++line_number;
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.remove_suffix(1);
    if (line.empty()) continue;
    auto fail = [&](const std::string& what) -> std::optional<HexImage> {
      error = "line " + std::to_string(line_number) + ": " + what;
      return std::nullopt;
    };
    if (line.front() != ':') return fail("a record starts with ':'");
    line.remove_prefix(1);
    if (line.size() < 10 || line.size() % 2 != 0) return fail("truncated record");
    std::vector<std::uint8_t> bytes;
    for (std::size_t i = 0; i < line.size(); i += 2) {
      const int high = nibble(line[i]);
      const int low = nibble(line[i + 1]);
      if (high < 0 || low < 0) return fail("not a hexadecimal digit");
      bytes.push_back(static_cast<std::uint8_t>(high * 16 + low));
    }
    const std::size_t length = bytes[0];
    if (bytes.size() != length + 5) return fail("the length byte says " + std::to_string(length) + " data bytes");
    unsigned sum = 0;
    for (const std::uint8_t byte : bytes) sum += byte;
    if ((sum & 0xFFu) != 0) return fail("bad checksum");
    const std::uint32_t offset = static_cast<std::uint32_t>(bytes[1] << 8 | bytes[2]);
    const std::uint8_t* data = bytes.data() + 4;
    switch (bytes[3]) {
      case 0x00: {
        if (length == 0) break;
        total += length;
        if (total > limit) return fail("more than " + std::to_string(limit) + " bytes of data");
        const std::uint32_t address = base + offset;
        auto& run = runs[address];
        if (!run.empty()) return fail("data written twice at the same address");
        run.assign(data, data + length);
        break;
      }
      case 0x01: ended = true; break;
      case 0x02:
        if (length != 2) return fail("an extended segment address record has 2 data bytes");
        base = static_cast<std::uint32_t>((data[0] << 8 | data[1]) << 4);
        break;
      case 0x04:
        if (length != 2) return fail("an extended linear address record has 2 data bytes");
        base = static_cast<std::uint32_t>(data[0] << 8 | data[1]) << 16;
        break;
      case 0x03:
      case 0x05: break;  // start address: an AVR starts at its reset vector
      default: return fail("unknown record type " + std::to_string(bytes[3]));
    }
  }
  if (!ended) {
    error = "no end record (a truncated file?)";
    return std::nullopt;
  }
  HexImage image;
  for (auto& [address, bytes] : runs) {
    if (!image.segments.empty()) {
      HexImage::Segment& last = image.segments.back();
      const std::uint64_t last_end = std::uint64_t{last.address} + last.bytes.size();
      if (address < last_end) {
        error = "overlapping data records";
        return std::nullopt;
      }
      if (address == last_end) {
        last.bytes.insert(last.bytes.end(), bytes.begin(), bytes.end());
        continue;
      }
    }
    image.segments.push_back({address, std::move(bytes)});
  }
  return image;
}

std::optional<HexImage> read_intel_hex(const std::filesystem::path& path, std::string& error) {
  std::ifstream file(path, std::ios::binary);
  if (!file) {
    error = path.string() + ": " + std::strerror(errno);
    return std::nullopt;
  }
  // An Uno image is under 100 kB of text; anything far larger is not one.
  std::string text;
  text.resize(4 << 20);
  file.read(text.data(), static_cast<std::streamsize>(text.size()));
  text.resize(static_cast<std::size_t>(file.gcount()));
  auto image = parse_intel_hex(text, error);
  if (!image) error = path.string() + ": not valid Intel HEX: " + error;
  return image;
}

std::string to_intel_hex(const HexImage& image) {
  std::string text;
  char line[64];
  auto record = [&](std::uint8_t type, std::uint16_t address, const std::uint8_t* data, std::size_t length) {
    unsigned sum = static_cast<unsigned>(length) + (address >> 8) + (address & 0xFFu) + type;
    int at = std::snprintf(line, sizeof line, ":%02X%04X%02X", static_cast<unsigned>(length), address, type);
    for (std::size_t i = 0; i < length; ++i) {
      at += std::snprintf(line + at, sizeof line - static_cast<std::size_t>(at), "%02X", data[i]);
      sum += data[i];
    }
    std::snprintf(line + at, sizeof line - static_cast<std::size_t>(at), "%02X\n", (0x100u - (sum & 0xFFu)) & 0xFFu);
    text += line;
  };
  std::uint32_t upper = 0;
  for (const auto& segment : image.segments) {
    std::size_t offset = 0;
    while (offset < segment.bytes.size()) {
      const std::uint32_t address = segment.address + static_cast<std::uint32_t>(offset);
      if ((address >> 16) != upper) {
        upper = address >> 16;
        const std::uint8_t high[2] = {static_cast<std::uint8_t>(upper >> 8), static_cast<std::uint8_t>(upper)};
        record(0x04, 0, high, 2);
      }
      // A record stays inside its 64 KiB page.
      const std::size_t length =
          std::min({std::size_t{16}, segment.bytes.size() - offset, std::size_t{0x10000 - (address & 0xFFFFu)}});
      record(0x00, static_cast<std::uint16_t>(address & 0xFFFFu), segment.bytes.data() + offset, length);
      offset += length;
    }
  }
  record(0x01, 0, nullptr, 0);
  return text;
}

}  // namespace tether::transports
