/// @file capture_file.hpp
/// Test-only pcapng writer in Tether's capture format (docs/captures.md): one interface per device link
/// (LINKTYPE_USER0, if_name, if_description `tether codec=...`, microseconds), enhanced packets with the
/// direction in epb_flags and an optional comment (`unframed: ...`, `link: ...`). The dissector's tests
/// write their captures through this one helper until `tether --record` writes them; then they read real
/// recordings and this file goes.
#pragma once

#include <cstdint>
#include <fstream>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

namespace tether::wireshark_test {

/// Direction in epb_flags bits 0-1.
enum class Direction : std::uint32_t { inbound = 1, outbound = 2 };

/// A capture built in memory and written at once.
class CaptureFile {
 public:
  CaptureFile() {
    std::string body;
    put32(body, 0x1A2B3C4D);  // byte-order magic
    put16(body, 1);
    put16(body, 0);
    put64(body, 0xFFFFFFFFFFFFFFFFull);  // section length unknown
    option(body, 4, "tether test");      // shb_userappl
    end_options(body);
    block(0x0A0D0D0A, body);
  }

  /// Adds a device link; returns its interface id.
  std::uint32_t add_link(std::string_view name, std::string_view description) {
    std::string body;
    put16(body, 147);  // LINKTYPE_USER0
    put16(body, 0);
    put32(body, 0);  // no snap length limit
    option(body, 2, name);
    option(body, 3, description);
    option(body, 9, std::string_view("\x06", 1));  // microseconds
    end_options(body);
    block(1, body);
    return links_++;
  }

  /// Adds a packet of `link` at `time_us` (microseconds since the epoch).
  void add_packet(std::uint32_t link, std::uint64_t time_us, Direction direction, std::string_view bytes,
                  std::string_view comment = {}) {
    if (link >= links_) throw std::invalid_argument("no such link");
    std::string body;
    put32(body, link);
    put32(body, static_cast<std::uint32_t>(time_us >> 32));
    put32(body, static_cast<std::uint32_t>(time_us & 0xFFFFFFFFu));
    put32(body, static_cast<std::uint32_t>(bytes.size()));
    put32(body, static_cast<std::uint32_t>(bytes.size()));
    body.append(bytes);
    pad(body);
    std::string flags;
    put32(flags, static_cast<std::uint32_t>(direction));
    option(body, 2, flags);
    if (!comment.empty()) option(body, 1, comment);
    end_options(body);
    block(6, body);
  }

  /// Writes the capture to `path`.
  void write(const std::string& path) const {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(data_.data(), static_cast<std::streamsize>(data_.size()));
    if (!out) throw std::runtime_error("cannot write " + path);
  }

 private:
  static void put16(std::string& s, std::uint16_t v) {
    for (int i = 0; i < 2; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
  }
  static void put32(std::string& s, std::uint32_t v) {
    for (int i = 0; i < 4; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
  }
  static void put64(std::string& s, std::uint64_t v) {
    for (int i = 0; i < 8; ++i) s.push_back(static_cast<char>((v >> (8 * i)) & 0xFF));
  }
  static void pad(std::string& s) {
    while (s.size() % 4 != 0) s.push_back('\0');
  }
  static void option(std::string& s, std::uint16_t code, std::string_view value) {
    put16(s, code);
    put16(s, static_cast<std::uint16_t>(value.size()));
    s.append(value);
    pad(s);
  }
  static void end_options(std::string& s) { put32(s, 0); }
  void block(std::uint32_t type, const std::string& body) {
    const auto length = static_cast<std::uint32_t>(body.size() + 12);
    put32(data_, type);
    put32(data_, length);
    data_.append(body);
    put32(data_, length);
  }

  std::string data_;
  std::uint32_t links_ = 0;
};

}  // namespace tether::wireshark_test
