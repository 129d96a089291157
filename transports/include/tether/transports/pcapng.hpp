/// @file pcapng.hpp
/// Tether's capture files: pcapng (the format Wireshark and tshark read) with one interface per device link,
/// LinkType 147 (LINKTYPE_USER0), timestamps in microseconds and the direction in each packet's flags.
/// The layout of a Tether capture (interface options, comments of unframed bytes and link events):
/// docs/captures.md.
///
/// The writer is a set of functions that return whole blocks as bytes (little-endian), so the one that
/// writes them (`CaptureRecorder`, recording.hpp) decides where they go. The reader takes either byte order,
/// skips block types it does not know, and reports a truncated or corrupt file, an interface of another link
/// type, or a block over `kMaxBlockBytes` as a `CaptureError` whose message names the file offset:
///
/// @code
///   transports::CaptureReader reader(file_stream);
///   transports::CaptureRecord record;
///   while (reader.next(record, error, message)) {
///     if (record.packet) use(reader.interfaces()[record.packet->interface], *record.packet);
///   }
///   if (error) fail(message);   // "offset 1024: block of type 0x00000006 truncated (needs 72 bytes, 20 left)"
/// @endcode
#pragma once

#include <boost/system/error_code.hpp>

#include <cstddef>
#include <cstdint>
#include <istream>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

namespace tether::transports {

/// What a capture file can be wrong with.
enum class CaptureError {
  truncated = 1,    ///< The file ends inside a block.
  corrupt,          ///< A block's lengths, magic or options are inconsistent.
  wrong_link_type,  ///< An interface is not Tether's (LinkType 147).
  too_large,        ///< A block is larger than `kMaxBlockBytes`.
  not_pcapng,       ///< The file does not start with a pcapng Section Header Block.
  unknown_interface,  ///< A packet names an interface the section has not described.
};

/// The "tether.capture" category.
const boost::system::error_category& capture_category();
/// Makes an error_code of the capture category.
boost::system::error_code make_error_code(CaptureError error);

/// The link type of every Tether interface: LINKTYPE_USER0.
inline constexpr std::uint16_t kTetherLinkType = 147;
/// Largest block the reader accepts (and the writer produces): a packet is one frame, at most a few KB.
inline constexpr std::uint32_t kMaxBlockBytes = 1u << 20;

/// Which way bytes went, as pcapng's epb_flags bits 0-1 say.
enum class CaptureDirection : std::uint8_t {
  unknown = 0,   ///< Not said (a link event).
  inbound = 1,   ///< Device to host (read by the host).
  outbound = 2,  ///< Host to device (written by the host).
};

/// `inbound`/`outbound`/`unknown`.
std::string_view to_string(CaptureDirection direction);

/// One interface of a capture: a device link.
struct CaptureInterface {
  std::uint16_t link_type = kTetherLinkType;  ///< Always 147 in what the reader returns.
  std::string name;                           ///< if_name: the device's name.
  std::string description;                    ///< if_description: `tether codec=romi baud=115200 ...`.
  /// The `key=value` words of `description` after its leading `tether` (percent-decoded values).
  std::vector<std::pair<std::string, std::string>> words() const;
  /// The value of word `key` (`codec`), or empty.
  std::string word(std::string_view key) const;
};

/// One packet of a capture.
struct CapturePacket {
  std::uint32_t interface = 0;        ///< Index into the section's interfaces.
  std::uint64_t timestamp_us = 0;     ///< Microseconds since the Unix epoch.
  CaptureDirection direction = CaptureDirection::unknown;
  std::vector<std::uint8_t> data;     ///< The bytes as they crossed the wire.
  std::string comment;                ///< opt_comment: empty, `unframed...` or `link: ...`.
  /// True when the comment marks bytes that formed no frame (`unframed` or `unframed: <reason>`).
  bool unframed() const;
  /// True for a link event (`link: down`).
  bool link_event() const;
};

/// Percent-encodes what may not appear in a value of an if_description word: space, `%` and control bytes.
std::string capture_word_value(std::string_view value);

/// The pcapng writer: each function returns one whole block, little-endian, padded as the format asks.
namespace pcapng {
/// Section Header Block with shb_userappl = `application` (`tether 0.2.0`).
std::vector<std::uint8_t> section_header(std::string_view application);
/// Interface Description Block: LinkType 147, SnapLen 0, if_name, if_description, if_tsresol = 6.
std::vector<std::uint8_t> interface_description(std::string_view name, std::string_view description);
/// Enhanced Packet Block: interface `interface`, `timestamp_us`, the direction in epb_flags (none when
/// unknown), `data`, and opt_comment when `comment` is not empty. `data` over `kMaxBlockBytes` minus the
/// block's overhead is cut there (the writer never makes a block the reader refuses).
std::vector<std::uint8_t> enhanced_packet(std::uint32_t interface, std::uint64_t timestamp_us,
                                          CaptureDirection direction, std::span<const std::uint8_t> data,
                                          std::string_view comment);
/// Largest packet data an Enhanced Packet Block carries.
inline constexpr std::size_t kMaxPacketData = kMaxBlockBytes - 4096;
}  // namespace pcapng

/// What `CaptureReader::next` returns: a new interface, or a packet.
struct CaptureRecord {
  /// Set when the block was an Interface Description Block: its index (the interface is in `interfaces()`).
  std::optional<std::uint32_t> interface;
  /// Set when the block was a packet.
  std::optional<CapturePacket> packet;
};

/// Reads a pcapng capture block by block; bounded (one block at a time, at most `kMaxBlockBytes`).
class CaptureReader {
 public:
  /// Reads from `input` (a file opened in binary mode, a string stream), which must outlive the reader.
  explicit CaptureReader(std::istream& input);

  /// The next interface or packet: true with `record` set; false at the end of the file (`error` clear) or
  /// on an error (`error` set, `message` saying what and at which file offset). Section headers and blocks of
  /// other types are taken in passing; a new section starts a new list of interfaces.
  bool next(CaptureRecord& record, boost::system::error_code& error, std::string& message);

  /// The interfaces of the current section, in file order.
  const std::vector<CaptureInterface>& interfaces() const { return interfaces_; }
  /// The section header's shb_userappl (`tether 0.2.0`), or empty.
  const std::string& application() const { return application_; }
  /// Offset of the next block in the file.
  std::uint64_t offset() const { return offset_; }
  /// Section headers read so far.
  std::uint64_t sections() const { return sections_; }

 private:
  bool fail(CaptureError error, std::uint64_t at, const std::string& what, boost::system::error_code& code,
            std::string& message);
  std::istream& input_;
  std::uint64_t offset_ = 0;
  bool big_endian_ = false;
  bool in_section_ = false;
  std::uint64_t sections_ = 0;
  std::vector<CaptureInterface> interfaces_;
  std::vector<std::uint8_t> tsresol_;  // per interface
  std::string application_;
  std::vector<std::uint8_t> block_;
};

/// A whole capture in memory: its interfaces and packets. For tests and `tether replay` (a ring file of a
/// recording is bounded by its size limit).
struct Capture {
  std::string application;                    ///< shb_userappl of the last section.
  std::vector<CaptureInterface> interfaces;   ///< Every interface (of every section, renumbered in order).
  std::vector<CapturePacket> packets;         ///< Every packet, `interface` an index into `interfaces`.
};
/// Reads `file` into a `Capture`; on failure `error` and `message` (`FILE: offset N: ...`).
std::optional<Capture> read_capture(const std::string& file, boost::system::error_code& error, std::string& message);

}  // namespace tether::transports

template <>
struct boost::system::is_error_code_enum<tether::transports::CaptureError> : std::true_type {};
