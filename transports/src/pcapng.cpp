// pcapng blocks written and read (pcapng.hpp); the block layouts are the pcapng specification's
// (draft-ietf-opsawg-pcapng): SHB 0x0A0D0D0A, IDB 1, EPB 6, options as code/length/value padded to 4.
#include "tether/transports/pcapng.hpp"

#include <algorithm>
#include <cerrno>
#include <fstream>
#include <limits>

namespace tether::transports {

namespace {

class CaptureCategory final : public boost::system::error_category {
 public:
  const char* name() const noexcept override { return "tether.capture"; }
  std::string message(int value) const override {
    switch (static_cast<CaptureError>(value)) {
      case CaptureError::truncated: return "capture file truncated";
      case CaptureError::corrupt: return "capture file corrupt";
      case CaptureError::wrong_link_type: return "not a Tether capture (another link type)";
      case CaptureError::too_large: return "capture block too large";
      case CaptureError::not_pcapng: return "not a pcapng file";
      case CaptureError::unknown_interface: return "packet of an undescribed interface";
    }
    return "unknown capture error";
  }
};

constexpr std::uint32_t kSectionHeader = 0x0A0D0D0A;
constexpr std::uint32_t kInterfaceDescription = 1;
constexpr std::uint32_t kEnhancedPacket = 6;
constexpr std::uint32_t kByteOrderMagic = 0x1A2B3C4D;
constexpr std::uint32_t kByteOrderSwapped = 0x4D3C2B1A;
constexpr std::uint16_t kOptEnd = 0;
constexpr std::uint16_t kOptComment = 1;
constexpr std::uint16_t kShbUserAppl = 4;
constexpr std::uint16_t kIfName = 2;
constexpr std::uint16_t kIfDescription = 3;
constexpr std::uint16_t kIfTsresol = 9;
constexpr std::uint16_t kEpbFlags = 2;

std::size_t padded(std::size_t size) { return (size + 3) & ~std::size_t{3}; }

// --- writing --------------------------------------------------------------------------------------------------

class BlockWriter {
 public:
  explicit BlockWriter(std::uint32_t type) {
    u32(type);
    u32(0);  // total length, patched by finish()
  }
  void u16(std::uint16_t value) {
    bytes_.push_back(static_cast<std::uint8_t>(value & 0xFF));
    bytes_.push_back(static_cast<std::uint8_t>(value >> 8));
  }
  void u32(std::uint32_t value) {
    for (int shift = 0; shift < 32; shift += 8) bytes_.push_back(static_cast<std::uint8_t>((value >> shift) & 0xFF));
  }
  void raw(std::span<const std::uint8_t> data) {
    bytes_.insert(bytes_.end(), data.begin(), data.end());
    bytes_.resize(padded(bytes_.size()), 0);
  }
  void option(std::uint16_t code, std::span<const std::uint8_t> value) {
    u16(code);
    u16(static_cast<std::uint16_t>(value.size()));
    raw(value);
  }
  void option(std::uint16_t code, std::string_view value) {
    // An option's length is 16 bits: a longer text is cut (names and descriptions are short).
    value = value.substr(0, std::min<std::size_t>(value.size(), 0xFFFC));
    option(code, std::span<const std::uint8_t>(reinterpret_cast<const std::uint8_t*>(value.data()), value.size()));
  }
  std::vector<std::uint8_t> finish() {
    u16(kOptEnd);
    u16(0);
    const std::uint32_t total = static_cast<std::uint32_t>(bytes_.size() + 4);
    u32(total);
    for (int i = 0; i < 4; ++i) bytes_[static_cast<std::size_t>(4 + i)] = static_cast<std::uint8_t>((total >> (8 * i)) & 0xFF);
    return std::move(bytes_);
  }

 private:
  std::vector<std::uint8_t> bytes_;
};

// --- reading --------------------------------------------------------------------------------------------------

// A block's body (after type and length), read in the section's byte order.
class BlockReader {
 public:
  BlockReader(std::span<const std::uint8_t> bytes, bool big_endian) : bytes_(bytes), big_endian_(big_endian) {}
  bool has(std::size_t size) const { return bytes_.size() - at_ >= size; }
  std::size_t at() const { return at_; }
  std::uint16_t u16() {
    const std::uint8_t a = bytes_[at_], b = bytes_[at_ + 1];
    at_ += 2;
    return big_endian_ ? static_cast<std::uint16_t>(a << 8 | b) : static_cast<std::uint16_t>(b << 8 | a);
  }
  std::uint32_t u32() {
    std::uint32_t value = 0;
    for (std::size_t i = 0; i < 4; ++i) {
      const std::uint32_t byte = bytes_[at_ + i];
      value |= big_endian_ ? byte << (8 * (3 - i)) : byte << (8 * i);
    }
    at_ += 4;
    return value;
  }
  std::span<const std::uint8_t> take(std::size_t size) {
    const auto part = bytes_.subspan(at_, size);
    at_ = std::min(bytes_.size(), at_ + padded(size));
    return part;
  }

 private:
  std::span<const std::uint8_t> bytes_;
  bool big_endian_;
  std::size_t at_ = 0;
};

std::string as_text(std::span<const std::uint8_t> bytes) {
  return std::string(reinterpret_cast<const char*>(bytes.data()), bytes.size());
}

// Walks the options from the reader's position; calls `each(code, value)`. False when they run past the
// block (then `bad` says where).
template <typename Each>
bool read_options(BlockReader& reader, Each each, std::size_t& bad) {
  while (reader.has(4)) {
    bad = reader.at();
    const std::uint16_t code = reader.u16();
    const std::uint16_t length = reader.u16();
    if (code == kOptEnd) return true;
    if (!reader.has(padded(length)) && !reader.has(length)) return false;
    each(code, reader.take(length));
  }
  return true;  // options may end with the block, without opt_endofopt
}

int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::string percent_decode(std::string_view text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '%' && i + 2 < text.size()) {
      const int high = hex_digit(text[i + 1]), low = hex_digit(text[i + 2]);
      if (high >= 0 && low >= 0) {
        out.push_back(static_cast<char>(high * 16 + low));
        i += 2;
        continue;
      }
    }
    out.push_back(text[i]);
  }
  return out;
}

std::string hex32(std::uint32_t value) {
  static const char* digits = "0123456789abcdef";
  std::string text = "0x";
  for (int shift = 28; shift >= 0; shift -= 4) text.push_back(digits[(value >> shift) & 0xF]);
  return text;
}

// Timestamp units per second of an if_tsresol value, 0 when it is beyond 64 bits.
std::uint64_t units_per_second(std::uint8_t tsresol) {
  const unsigned exponent = tsresol & 0x7F;
  if (tsresol & 0x80) return exponent < 64 ? std::uint64_t{1} << exponent : 0;
  std::uint64_t units = 1;
  for (unsigned i = 0; i < exponent; ++i) {
    if (units > std::numeric_limits<std::uint64_t>::max() / 10) return 0;
    units *= 10;
  }
  return units;
}

std::uint64_t to_microseconds(std::uint64_t stamp, std::uint8_t tsresol) {
  const std::uint64_t units = units_per_second(tsresol);
  if (units == 0) return 0;
  if (units == 1000000) return stamp;
  const std::uint64_t seconds = stamp / units;
  const std::uint64_t rest = stamp % units;
  // rest < units: scale without overflow through long double's 64-bit mantissa.
  const auto fraction = static_cast<std::uint64_t>(static_cast<long double>(rest) * 1e6L / static_cast<long double>(units));
  if (seconds > std::numeric_limits<std::uint64_t>::max() / 1000000) return std::numeric_limits<std::uint64_t>::max();
  return seconds * 1000000 + fraction;
}

}  // namespace

const boost::system::error_category& capture_category() {
  static const CaptureCategory category;
  return category;
}

boost::system::error_code make_error_code(CaptureError error) {
  return {static_cast<int>(error), capture_category()};
}

std::string_view to_string(CaptureDirection direction) {
  switch (direction) {
    case CaptureDirection::inbound: return "inbound";
    case CaptureDirection::outbound: return "outbound";
    case CaptureDirection::unknown: break;
  }
  return "unknown";
}

std::vector<std::pair<std::string, std::string>> CaptureInterface::words() const {
  std::vector<std::pair<std::string, std::string>> result;
  std::string_view rest = description;
  bool first = true;
  while (!rest.empty()) {
    const std::size_t space = rest.find(' ');
    const std::string_view word = rest.substr(0, space);
    rest = space == std::string_view::npos ? std::string_view() : rest.substr(space + 1);
    if (word.empty()) continue;
    if (first) {
      first = false;
      if (word == "tether") continue;
    }
    const std::size_t equals = word.find('=');
    if (equals == std::string_view::npos) {
      result.emplace_back(percent_decode(word), std::string());
    } else {
      result.emplace_back(percent_decode(word.substr(0, equals)), percent_decode(word.substr(equals + 1)));
    }
  }
  return result;
}

std::string CaptureInterface::word(std::string_view key) const {
  for (auto& [key_of, value] : words()) {
    if (key_of == key) return value;
  }
  return {};
}

bool CapturePacket::unframed() const {
  return comment == "unframed" || comment.starts_with("unframed:");
}

bool CapturePacket::link_event() const { return comment.starts_with("link: "); }

std::string capture_word_value(std::string_view value) {
  static const char* digits = "0123456789ABCDEF";
  std::string out;
  for (const char c : value) {
    const auto byte = static_cast<unsigned char>(c);
    if (byte <= 0x20 || byte == 0x7F || c == '%') {
      out.push_back('%');
      out.push_back(digits[byte >> 4]);
      out.push_back(digits[byte & 0xF]);
    } else {
      out.push_back(c);
    }
  }
  return out.empty() ? "-" : out;
}

namespace pcapng {

std::vector<std::uint8_t> section_header(std::string_view application) {
  BlockWriter block(kSectionHeader);
  block.u32(kByteOrderMagic);
  block.u16(1);  // major
  block.u16(0);  // minor
  block.u32(0xFFFFFFFF);  // section length: not given (-1)
  block.u32(0xFFFFFFFF);
  block.option(kShbUserAppl, application);
  return block.finish();
}

std::vector<std::uint8_t> interface_description(std::string_view name, std::string_view description) {
  BlockWriter block(kInterfaceDescription);
  block.u16(kTetherLinkType);
  block.u16(0);
  block.u32(0);  // SnapLen: no limit
  block.option(kIfName, name);
  block.option(kIfDescription, description);
  const std::uint8_t microseconds = 6;
  block.option(kIfTsresol, std::span<const std::uint8_t>(&microseconds, 1));
  return block.finish();
}

std::vector<std::uint8_t> enhanced_packet(std::uint32_t interface, std::uint64_t timestamp_us,
                                          CaptureDirection direction, std::span<const std::uint8_t> data,
                                          std::string_view comment) {
  data = data.first(std::min(data.size(), kMaxPacketData));
  BlockWriter block(kEnhancedPacket);
  block.u32(interface);
  block.u32(static_cast<std::uint32_t>(timestamp_us >> 32));
  block.u32(static_cast<std::uint32_t>(timestamp_us & 0xFFFFFFFF));
  block.u32(static_cast<std::uint32_t>(data.size()));
  block.u32(static_cast<std::uint32_t>(data.size()));
  block.raw(data);
  if (!comment.empty()) block.option(kOptComment, comment);
  if (direction != CaptureDirection::unknown) {
    const std::uint32_t flags = static_cast<std::uint32_t>(direction);
    const std::uint8_t value[4] = {static_cast<std::uint8_t>(flags), 0, 0, 0};
    block.option(kEpbFlags, std::span<const std::uint8_t>(value, 4));
  }
  return block.finish();
}

}  // namespace pcapng

CaptureReader::CaptureReader(std::istream& input) : input_(input) {}

bool CaptureReader::fail(CaptureError error, std::uint64_t at, const std::string& what,
                         boost::system::error_code& code, std::string& message) {
  code = make_error_code(error);
  message = "offset " + std::to_string(at) + ": " + what;
  return false;
}

bool CaptureReader::next(CaptureRecord& record, boost::system::error_code& error, std::string& message) {
  error.clear();
  message.clear();
  record = CaptureRecord();
  for (;;) {
    const std::uint64_t start = offset_;
    std::uint8_t header[8];
    input_.read(reinterpret_cast<char*>(header), 8);
    const auto got = static_cast<std::size_t>(input_.gcount());
    if (got == 0) {
      if (!in_section_) return fail(CaptureError::not_pcapng, start, "empty file, not a pcapng capture", error, message);
      return false;  // the end
    }
    if (got < 8) {
      return fail(CaptureError::truncated, start,
                  "block header truncated (" + std::to_string(got) + " of 8 bytes)", error, message);
    }
    const std::uint32_t type_le = static_cast<std::uint32_t>(header[0]) | static_cast<std::uint32_t>(header[1]) << 8 |
                                  static_cast<std::uint32_t>(header[2]) << 16 | static_cast<std::uint32_t>(header[3]) << 24;
    if (type_le == kSectionHeader) {
      // The byte order is the section's: read the magic first.
      std::uint8_t magic[4];
      input_.read(reinterpret_cast<char*>(magic), 4);
      if (input_.gcount() < 4) return fail(CaptureError::truncated, start, "section header truncated", error, message);
      const std::uint32_t magic_le = static_cast<std::uint32_t>(magic[0]) | static_cast<std::uint32_t>(magic[1]) << 8 |
                                     static_cast<std::uint32_t>(magic[2]) << 16 | static_cast<std::uint32_t>(magic[3]) << 24;
      if (magic_le == kByteOrderMagic) {
        big_endian_ = false;
      } else if (magic_le == kByteOrderSwapped) {
        big_endian_ = true;
      } else {
        return fail(CaptureError::corrupt, start + 8, "bad byte-order magic " + hex32(magic_le), error, message);
      }
      in_section_ = true;
      ++sections_;
      interfaces_.clear();
      tsresol_.clear();
      application_.clear();
    } else if (!in_section_) {
      return fail(CaptureError::not_pcapng, start, "not a pcapng file (first block type " + hex32(type_le) + ")",
                  error, message);
    }
    BlockReader head(std::span<const std::uint8_t>(header, 8), big_endian_);
    const std::uint32_t type = head.u32();
    const std::uint32_t length = head.u32();
    if (length < 12 || length % 4 != 0) {
      return fail(CaptureError::corrupt, start + 4,
                  "block of type " + hex32(type) + " has length " + std::to_string(length) +
                      " (at least 12, a multiple of 4)",
                  error, message);
    }
    if (length > kMaxBlockBytes) {
      return fail(CaptureError::too_large, start + 4,
                  "block of type " + hex32(type) + " has length " + std::to_string(length) + " (at most " +
                      std::to_string(kMaxBlockBytes) + ")",
                  error, message);
    }
    block_.resize(length - 8);
    std::size_t body_at = 0;
    if (type == kSectionHeader) {
      // Put the magic back in front of the body.
      const std::uint32_t magic = big_endian_ ? kByteOrderSwapped : kByteOrderMagic;
      for (int i = 0; i < 4; ++i) block_[static_cast<std::size_t>(i)] = static_cast<std::uint8_t>((magic >> (8 * i)) & 0xFF);
      body_at = 4;
    }
    input_.read(reinterpret_cast<char*>(block_.data() + body_at), static_cast<std::streamsize>(block_.size() - body_at));
    const auto read = static_cast<std::size_t>(input_.gcount());
    if (read < block_.size() - body_at) {
      return fail(CaptureError::truncated, start,
                  "block of type " + hex32(type) + " truncated (needs " + std::to_string(length) + " bytes, " +
                      std::to_string(8 + body_at + read) + " left)",
                  error, message);
    }
    offset_ = start + length;
    BlockReader trailer(std::span<const std::uint8_t>(block_).last(4), big_endian_);
    const std::uint32_t trailing = trailer.u32();
    if (trailing != length) {
      return fail(CaptureError::corrupt, start + length - 4,
                  "block of type " + hex32(type) + ": trailing length " + std::to_string(trailing) +
                      " differs from its leading length " + std::to_string(length),
                  error, message);
    }
    BlockReader body(std::span<const std::uint8_t>(block_).first(block_.size() - 4), big_endian_);
    std::size_t bad = 0;
    if (type == kSectionHeader) {
      if (!body.has(16)) return fail(CaptureError::corrupt, start, "section header too short", error, message);
      body.u32();  // magic
      const std::uint16_t major = body.u16();
      body.u16();
      body.u32();
      body.u32();
      if (major != 1) {
        return fail(CaptureError::corrupt, start + 12, "pcapng major version " + std::to_string(major) + " (expected 1)",
                    error, message);
      }
      if (!read_options(body, [&](std::uint16_t code, std::span<const std::uint8_t> value) {
            if (code == kShbUserAppl) application_ = as_text(value);
          }, bad)) {
        return fail(CaptureError::corrupt, start + 8 + bad, "section header option runs past the block", error, message);
      }
      continue;
    }
    if (type == kInterfaceDescription) {
      if (!body.has(8)) return fail(CaptureError::corrupt, start, "interface description too short", error, message);
      CaptureInterface interface;
      interface.link_type = body.u16();
      body.u16();
      body.u32();
      if (interface.link_type != kTetherLinkType) {
        return fail(CaptureError::wrong_link_type, start + 8,
                    "interface " + std::to_string(interfaces_.size()) + " has link type " +
                        std::to_string(interface.link_type) + ", not Tether's 147 (LINKTYPE_USER0)",
                    error, message);
      }
      std::uint8_t tsresol = 6;
      if (!read_options(body, [&](std::uint16_t code, std::span<const std::uint8_t> value) {
            if (code == kIfName) interface.name = as_text(value);
            if (code == kIfDescription) interface.description = as_text(value);
            if (code == kIfTsresol && value.size() == 1) tsresol = value[0];
          }, bad)) {
        return fail(CaptureError::corrupt, start + 8 + bad, "interface option runs past the block", error, message);
      }
      if (units_per_second(tsresol) == 0) {
        return fail(CaptureError::corrupt, start, "interface " + std::to_string(interfaces_.size()) +
                    ": unusable if_tsresol " + std::to_string(tsresol), error, message);
      }
      interfaces_.push_back(std::move(interface));
      tsresol_.push_back(tsresol);
      record.interface = static_cast<std::uint32_t>(interfaces_.size() - 1);
      return true;
    }
    if (type == kEnhancedPacket) {
      if (!body.has(20)) return fail(CaptureError::corrupt, start, "packet block too short", error, message);
      CapturePacket packet;
      packet.interface = body.u32();
      const std::uint64_t high = body.u32();
      const std::uint64_t low = body.u32();
      const std::uint32_t captured = body.u32();
      body.u32();  // original length
      if (packet.interface >= interfaces_.size()) {
        return fail(CaptureError::unknown_interface, start + 8,
                    "packet of interface " + std::to_string(packet.interface) + ", but the section describes " +
                        std::to_string(interfaces_.size()),
                    error, message);
      }
      if (!body.has(padded(captured)) && !body.has(captured)) {
        return fail(CaptureError::corrupt, start + 20,
                    "packet data of " + std::to_string(captured) + " bytes runs past the block", error, message);
      }
      const auto data = body.take(captured);
      packet.data.assign(data.begin(), data.end());
      packet.timestamp_us = to_microseconds(high << 32 | low, tsresol_[packet.interface]);
      if (!read_options(body, [&](std::uint16_t code, std::span<const std::uint8_t> value) {
            if (code == kOptComment) packet.comment = as_text(value);
            if (code == kEpbFlags && value.size() == 4) {
              BlockReader flags(value, big_endian_);
              packet.direction = static_cast<CaptureDirection>(flags.u32() & 0x3);
            }
          }, bad)) {
        return fail(CaptureError::corrupt, start + 8 + bad, "packet option runs past the block", error, message);
      }
      if (packet.direction != CaptureDirection::inbound && packet.direction != CaptureDirection::outbound) {
        packet.direction = CaptureDirection::unknown;
      }
      record.packet = std::move(packet);
      return true;
    }
    // Any other block (statistics, name resolution, simple packets of another tool): skipped.
  }
}

std::optional<Capture> read_capture(const std::string& file, boost::system::error_code& error, std::string& message) {
  std::ifstream input(file, std::ios::binary);
  if (!input) {
    error = boost::system::error_code(errno, boost::system::generic_category());
    message = file + ": " + error.message();
    return std::nullopt;
  }
  CaptureReader reader(input);
  Capture capture;
  std::size_t section_base = 0;
  std::uint64_t section = 0;
  CaptureRecord record;
  while (reader.next(record, error, message)) {
    if (reader.sections() != section) {
      section = reader.sections();
      section_base = capture.interfaces.size();
    }
    if (record.interface) capture.interfaces.push_back(reader.interfaces()[*record.interface]);
    if (record.packet) {
      record.packet->interface += static_cast<std::uint32_t>(section_base);
      capture.packets.push_back(std::move(*record.packet));
    }
    capture.application = reader.application();
  }
  capture.application = reader.application();
  if (error) {
    message = file + ": " + message;
    return std::nullopt;
  }
  return capture;
}

}  // namespace tether::transports
