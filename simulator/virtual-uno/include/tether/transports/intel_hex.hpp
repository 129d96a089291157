/// @file intel_hex.hpp
/// Intel HEX, the file format of AVR images and bootloaders (avr-objcopy -O ihex, Debian's optiboot):
/// read into address-ordered segments, written back. Record types 00 (data), 01 (end), 02/04 (extended
/// segment / linear address) and 03/05 (start address, ignored: an AVR starts at its reset vector) are
/// understood; checksums are verified. (libsimavr's reader rejects type 03, which Debian's optiboot has,
/// and merges the segments around a gap.)
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace tether::transports {

/// Bytes at addresses, as contiguous runs.
struct HexImage {
  /// One contiguous run of bytes.
  struct Segment {
    std::uint32_t address = 0;        ///< Address of the first byte.
    std::vector<std::uint8_t> bytes;  ///< Contents.
  };
  std::vector<Segment> segments;      ///< Sorted by address, never overlapping, adjacent runs merged.
  /// Bytes in all segments.
  std::size_t size() const;
  /// First address and one past the last (0, 0 when empty).
  std::uint32_t begin() const;
  std::uint32_t end() const;
};

/// Parses Intel HEX text. nullopt with `error` ("line N: ...") on a malformed record, a bad checksum,
/// overlapping data, a missing end record or more than `limit` bytes of data.
std::optional<HexImage> parse_intel_hex(std::string_view text, std::string& error, std::size_t limit = 1 << 20);

/// Reads and parses a file; `error` names the file.
std::optional<HexImage> read_intel_hex(const std::filesystem::path& path, std::string& error);

/// Intel HEX text: 16-byte data records, extended linear address records where an address needs them,
/// the end record.
std::string to_intel_hex(const HexImage& image);

}  // namespace tether::transports
