// Captures: the pcapng writer and reader, the delimited framing, the recorder (queue, rotation, write errors,
// no overwrite) and the recording stream on an in-memory link with a fake wall clock.
#include <gtest/gtest.h>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <boost/asio/io_context.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "tether/transports/capture_framing.hpp"
#include "tether/transports/in_memory_stream.hpp"
#include "tether/transports/pcapng.hpp"
#include "tether/transports/recording.hpp"

namespace tether::transports {
namespace {

namespace fs = std::filesystem;

std::vector<std::uint8_t> bytes_of(std::string_view text) { return {text.begin(), text.end()}; }
std::string text_of(const std::vector<std::uint8_t>& bytes) { return {bytes.begin(), bytes.end()}; }

std::string capture_text(std::initializer_list<std::vector<std::uint8_t>> blocks) {
  std::string text;
  for (const auto& block : blocks) text.append(block.begin(), block.end());
  return text;
}

struct ReadResult {
  std::vector<CaptureInterface> interfaces;
  std::vector<CapturePacket> packets;
  boost::system::error_code error;
  std::string message;
};

ReadResult read_text(const std::string& text) {
  std::istringstream input(text);
  CaptureReader reader(input);
  ReadResult result;
  CaptureRecord record;
  while (reader.next(record, result.error, result.message)) {
    if (record.packet) result.packets.push_back(*record.packet);
  }
  result.interfaces = reader.interfaces();
  return result;
}

// A fresh folder per test, removed at the end.
class TempDir {
 public:
  TempDir() {
    char name[] = "/tmp/tether-capture-test-XXXXXX";
    path_ = ::mkdtemp(name);
  }
  ~TempDir() {
    std::error_code ignored;
    fs::remove_all(path_, ignored);
  }
  fs::path operator/(const std::string& name) const { return path_ / name; }

 private:
  fs::path path_;
};

// --- pcapng ---------------------------------------------------------------------------------------------------

TEST(Pcapng, WhatIsWrittenIsReadBack) {
  const auto data = bytes_of("#e:0a5c\r\n");
  const std::string text = capture_text({
      pcapng::section_header("tether 0.2.0"),
      pcapng::interface_description("arm", "tether codec=romi baud=115200 transport=serial"),
      pcapng::interface_description("/dev/ttyACM0", "tether codec=proxy baud=- transport=tcp crc=on"),
      pcapng::enhanced_packet(0, 1700000000123456, CaptureDirection::outbound, data, ""),
      pcapng::enhanced_packet(1, 1700000000123999, CaptureDirection::inbound, bytes_of("xy"), "unframed: noise"),
      pcapng::enhanced_packet(0, 1700000000200000, CaptureDirection::unknown, {}, "link: down"),
  });
  std::istringstream input(text);
  CaptureReader reader(input);
  CaptureRecord record;
  boost::system::error_code error;
  std::string message;
  ASSERT_TRUE(reader.next(record, error, message)) << message;
  ASSERT_TRUE(record.interface);
  EXPECT_EQ(*record.interface, 0u);
  EXPECT_EQ(reader.application(), "tether 0.2.0");
  const ReadResult all = read_text(text);
  ASSERT_FALSE(all.error) << all.message;
  ASSERT_EQ(all.interfaces.size(), 2u);
  EXPECT_EQ(all.interfaces[0].name, "arm");
  EXPECT_EQ(all.interfaces[0].word("codec"), "romi");
  EXPECT_EQ(all.interfaces[1].word("baud"), "-");
  EXPECT_EQ(all.interfaces[1].word("crc"), "on");
  ASSERT_EQ(all.packets.size(), 3u);
  EXPECT_EQ(all.packets[0].interface, 0u);
  EXPECT_EQ(all.packets[0].timestamp_us, 1700000000123456u);
  EXPECT_EQ(all.packets[0].direction, CaptureDirection::outbound);
  EXPECT_EQ(all.packets[0].data, data);
  EXPECT_TRUE(all.packets[0].comment.empty());
  EXPECT_EQ(all.packets[1].direction, CaptureDirection::inbound);
  EXPECT_TRUE(all.packets[1].unframed());
  EXPECT_EQ(all.packets[1].comment, "unframed: noise");
  EXPECT_TRUE(all.packets[2].link_event());
  EXPECT_EQ(all.packets[2].direction, CaptureDirection::unknown);
  EXPECT_TRUE(all.packets[2].data.empty());
}

TEST(Pcapng, WordValuesArePercentEncoded) {
  EXPECT_EQ(capture_word_value("my arm.proto"), "my%20arm.proto");
  EXPECT_EQ(capture_word_value("100%"), "100%25");
  EXPECT_EQ(capture_word_value(""), "-");
  CaptureInterface interface;
  interface.description = "tether codec=rpc schema=my%20arm.proto package=arm";
  EXPECT_EQ(interface.word("schema"), "my arm.proto");
  EXPECT_EQ(interface.word("package"), "arm");
  EXPECT_EQ(interface.word("generation"), "");
}

// A big-endian section, as a big-endian machine writes it: every field of every block swapped.
std::vector<std::uint8_t> be32(std::uint32_t value) {
  return {static_cast<std::uint8_t>(value >> 24), static_cast<std::uint8_t>(value >> 16),
          static_cast<std::uint8_t>(value >> 8), static_cast<std::uint8_t>(value)};
}
std::vector<std::uint8_t> be16(std::uint16_t value) {
  return {static_cast<std::uint8_t>(value >> 8), static_cast<std::uint8_t>(value)};
}
void append(std::vector<std::uint8_t>& to, const std::vector<std::uint8_t>& bytes) {
  to.insert(to.end(), bytes.begin(), bytes.end());
}

TEST(Pcapng, BigEndianSectionsAreRead) {
  std::vector<std::uint8_t> file;
  // SHB: type, length 28, magic, 1.0, section length -1, no options, length.
  append(file, be32(0x0A0D0D0A));
  append(file, be32(28));
  append(file, be32(0x1A2B3C4D));
  append(file, be16(1));
  append(file, be16(0));
  append(file, be32(0xFFFFFFFF));
  append(file, be32(0xFFFFFFFF));
  append(file, be32(28));
  // IDB: link type 147, if_name "arm" (padded), if_tsresol 3 (milliseconds), end.
  append(file, be32(1));
  append(file, be32(40));
  append(file, be16(147));
  append(file, be16(0));
  append(file, be32(0));
  append(file, be16(2));
  append(file, be16(3));
  append(file, {'a', 'r', 'm', 0});
  append(file, be16(9));
  append(file, be16(1));
  append(file, {3, 0, 0, 0});
  append(file, be16(0));
  append(file, be16(0));
  append(file, be32(40));
  // EPB: interface 0, timestamp 1234 ms, 2 bytes, epb_flags inbound.
  append(file, be32(6));
  append(file, be32(44));
  append(file, be32(0));
  append(file, be32(0));
  append(file, be32(1234));
  append(file, be32(2));
  append(file, be32(2));
  append(file, {'o', 'k', 0, 0});
  append(file, be16(2));
  append(file, be16(4));
  append(file, be32(1));  // the options end with the block: no opt_endofopt
  append(file, be32(44));
  const ReadResult result = read_text(std::string(file.begin(), file.end()));
  ASSERT_FALSE(result.error) << result.message;
  ASSERT_EQ(result.interfaces.size(), 1u);
  EXPECT_EQ(result.interfaces[0].name, "arm");
  ASSERT_EQ(result.packets.size(), 1u);
  EXPECT_EQ(result.packets[0].timestamp_us, 1234000u);
  EXPECT_EQ(text_of(result.packets[0].data), "ok");
  EXPECT_EQ(result.packets[0].direction, CaptureDirection::inbound);
}

TEST(Pcapng, UnknownBlocksAreSkipped) {
  std::vector<std::uint8_t> unknown = {0x05, 0, 0, 0, 16, 0, 0, 0, 1, 2, 3, 4, 16, 0, 0, 0};  // an ISB-like block
  const std::string text = capture_text({pcapng::section_header("x"), pcapng::interface_description("a", "tether"),
                                         unknown,
                                         pcapng::enhanced_packet(0, 1, CaptureDirection::inbound, bytes_of("z"), "")});
  const ReadResult result = read_text(text);
  ASSERT_FALSE(result.error) << result.message;
  EXPECT_EQ(result.packets.size(), 1u);
}

TEST(Pcapng, ATruncatedFileIsAnErrorNamingTheOffset) {
  const std::string whole = capture_text({pcapng::section_header("x"), pcapng::interface_description("a", "tether"),
                                          pcapng::enhanced_packet(0, 1, CaptureDirection::inbound, bytes_of("abc"), "")});
  const std::size_t packet_at = whole.size() - pcapng::enhanced_packet(0, 1, CaptureDirection::inbound,
                                                                       bytes_of("abc"), "").size();
  for (std::size_t cut = packet_at + 1; cut < whole.size(); ++cut) {
    const ReadResult result = read_text(whole.substr(0, cut));
    EXPECT_EQ(result.error, CaptureError::truncated) << cut;
    EXPECT_EQ(result.message.rfind("offset " + std::to_string(packet_at) + ": ", 0), 0u) << result.message;
  }
  EXPECT_EQ(read_text("").error, CaptureError::not_pcapng);
  EXPECT_EQ(read_text("hello world, not a capture").error, CaptureError::not_pcapng);
}

TEST(Pcapng, CorruptLengthsAreErrors) {
  std::string text = capture_text({pcapng::section_header("x"), pcapng::interface_description("a", "tether")});
  std::string bad_trailer = text;
  bad_trailer[bad_trailer.size() - 4] = 0x7C;  // the IDB's trailing length
  const ReadResult trailer = read_text(bad_trailer);
  EXPECT_EQ(trailer.error, CaptureError::corrupt);
  EXPECT_NE(trailer.message.find("trailing length"), std::string::npos) << trailer.message;

  std::string odd = text;
  const std::size_t idb = pcapng::section_header("x").size();
  odd[idb + 4] = 13;  // not a multiple of 4
  EXPECT_EQ(read_text(odd).error, CaptureError::corrupt);

  std::string huge = text;
  huge[idb + 7] = 0x40;  // 1 GiB
  const ReadResult large = read_text(huge);
  EXPECT_EQ(large.error, CaptureError::too_large);
  EXPECT_EQ(large.message.rfind("offset " + std::to_string(idb + 4), 0), 0u) << large.message;
}

TEST(Pcapng, AnotherLinkTypeIsAClearError) {
  std::vector<std::uint8_t> idb = pcapng::interface_description("eth0", "");
  idb[8] = 1;  // LINKTYPE_ETHERNET
  idb[9] = 0;
  const ReadResult result = read_text(capture_text({pcapng::section_header("dumpcap"), idb}));
  EXPECT_EQ(result.error, CaptureError::wrong_link_type);
  EXPECT_NE(result.message.find("link type 1, not Tether's 147"), std::string::npos) << result.message;
}

TEST(Pcapng, APacketOfAnUndescribedInterfaceIsAnError) {
  const ReadResult result = read_text(capture_text(
      {pcapng::section_header("x"), pcapng::enhanced_packet(3, 1, CaptureDirection::inbound, bytes_of("z"), "")}));
  EXPECT_EQ(result.error, CaptureError::unknown_interface);
}

// --- framing --------------------------------------------------------------------------------------------------

std::vector<FramedPacket> frame_all(CaptureFramer& framer, const std::vector<std::string>& reads,
                                    const char* close_reason = nullptr) {
  std::vector<FramedPacket> packets;
  const PacketSink sink = [&](FramedPacket packet) { packets.push_back(std::move(packet)); };
  for (const auto& read : reads) framer.feed(bytes_of(read), sink);
  if (close_reason) framer.flush(close_reason, sink);
  return packets;
}

std::string show(const std::vector<FramedPacket>& packets) {
  std::string text;
  for (const auto& packet : packets) {
    text += "[" + text_of(packet.bytes) + (packet.frame ? "" : "|" + packet.comment()) + "]";
  }
  return text;
}

DelimitedFraming lines(std::string start, bool restart, std::size_t max) {
  DelimitedFraming framing;
  framing.start = std::move(start);
  framing.end = '\n';
  framing.restart_on_start = restart;
  framing.max_frame = max;
  return framing;
}

TEST(CaptureFraming, FramesSplitAcrossReadsAreOnePacketEach) {
  DelimitedFramer framer(lines("#", true, 64));
  EXPECT_EQ(show(frame_all(framer, {"#e:0", "a5c\r", "\n#!hi:xxxx\r\n#v"}, "cut at close")),
            "[#e:0a5c\r\n][#!hi:xxxx\r\n][#v|unframed: cut at close]");
}

TEST(CaptureFraming, NoiseBeforeAStartByteIsOneUnframedRun) {
  DelimitedFramer framer(lines("#", true, 64));
  EXPECT_EQ(show(frame_all(framer, {"xx", "y#a\n", "z"}, "cut at close")),
            "[xxy|unframed: noise][#a\n][z|unframed: noise]");
}

TEST(CaptureFraming, AStartByteInsideAFrameCutsIt) {
  DelimitedFramer framer(lines("#", true, 64));
  EXPECT_EQ(show(frame_all(framer, {"#ab#cd\n"})), "[#ab|unframed: cut by a new frame][#cd\n]");
}

TEST(CaptureFraming, AnOverLongFrameIsUnframedUpToTheNextEnd) {
  DelimitedFramer framer(lines("#", true, 4));
  EXPECT_EQ(show(frame_all(framer, {"#abcdef\n#a\n"})), "[#abc|unframed: too long][def\n|unframed: too long][#a\n]");
  DelimitedFramer restart(lines("#", true, 4));
  EXPECT_EQ(show(frame_all(restart, {"#abcd#e\n"})), "[#abc|unframed: too long][d|unframed: too long][#e\n]");
}

TEST(CaptureFraming, CobsFramesKeepTheirLeadingDelimiter) {
  DelimitedFraming cobs;
  cobs.end = 0;
  cobs.leading_end_bytes = true;
  cobs.max_frame = 8;
  DelimitedFramer framer(cobs);
  const std::string wire("\x00\x03\x01\x02\x00\x02\x05\x00\x00\x00", 10);
  const auto packets = frame_all(framer, {wire.substr(0, 3), wire.substr(3)}, "cut at close");
  ASSERT_EQ(packets.size(), 3u);
  EXPECT_EQ(text_of(packets[0].bytes), wire.substr(0, 5));
  EXPECT_TRUE(packets[0].frame);
  EXPECT_EQ(text_of(packets[1].bytes), wire.substr(5, 3));
  EXPECT_EQ(text_of(packets[2].bytes), wire.substr(8, 2));
  EXPECT_EQ(packets[2].comment(), "unframed: cut at close");
}

TEST(CaptureFraming, UnframedRunsAreBounded) {
  DelimitedFramer framer(lines("#", true, 4));
  EXPECT_EQ(show(frame_all(framer, {"0123456789"}, "cut at close")),
            "[0123|unframed: noise][4567|unframed: noise][89|unframed: noise]");
}

// --- recorder -------------------------------------------------------------------------------------------------

Capture read_back(const fs::path& file) {
  boost::system::error_code error;
  std::string message;
  auto capture = read_capture(file.string(), error, message);
  EXPECT_FALSE(error) << message;
  return capture ? *capture : Capture();
}

TEST(CaptureRecorder, WritesInterfacesAndPacketsInOrder) {
  TempDir dir;
  RecordOptions options;
  options.file = dir / "rover.pcapng";
  auto recorder = CaptureRecorder::open(options);
  const auto arm = recorder->add_interface("arm", "tether codec=romi baud=115200 transport=serial");
  recorder->record(arm, CaptureDirection::outbound, 10, bytes_of("#e:0a5c\r\n"), "");
  const auto ring = recorder->add_interface("ring", "tether codec=elcano baud=- transport=virtual_ring generation=D");
  recorder->record(ring, CaptureDirection::inbound, 20, bytes_of("D{s 1}\n"), "");
  recorder->close();
  const RecordCounters counters = recorder->counters();
  EXPECT_EQ(counters.packets, 2u);
  EXPECT_EQ(counters.dropped_packets, 0u);
  const Capture capture = read_back(options.file);
  EXPECT_EQ(capture.application.rfind("tether ", 0), 0u);
  ASSERT_EQ(capture.interfaces.size(), 2u);
  EXPECT_EQ(capture.interfaces[1].word("generation"), "D");
  ASSERT_EQ(capture.packets.size(), 2u);
  EXPECT_EQ(capture.packets[1].interface, 1u);
  EXPECT_EQ(text_of(capture.packets[1].data), "D{s 1}\n");
}

TEST(CaptureRecorder, AnExistingFileIsNotOverwrittenUnlessAsked) {
  TempDir dir;
  const fs::path file = dir / "old.pcapng";
  std::ofstream(file) << "precious";
  RecordOptions options;
  options.file = file;
  boost::system::error_code error;
  std::string message;
  EXPECT_FALSE(CaptureRecorder::open(options, error, message));
  EXPECT_EQ(message, file.string() + ": File exists (--force overwrites it)");
  std::ifstream kept(file);
  std::string text;
  kept >> text;
  EXPECT_EQ(text, "precious");
  options.overwrite = true;
  auto recorder = CaptureRecorder::open(options, error, message);
  ASSERT_TRUE(recorder) << message;
  recorder->close();
  EXPECT_FALSE(read_back(file).application.empty());

  // A ring file that exists is refused before anything is written.
  const fs::path ring = dir / "ring.pcapng";
  std::ofstream(dir / "ring.2.pcapng") << "precious";
  RecordOptions rotating;
  rotating.file = ring;
  rotating.max_file_bytes = 4096;
  rotating.ring_files = 3;
  EXPECT_FALSE(CaptureRecorder::open(rotating, error, message));
  EXPECT_EQ(message, (dir / "ring.2.pcapng").string() + ": ring file exists (--force overwrites it)");
  EXPECT_FALSE(fs::exists(ring));
}

TEST(CaptureRecorder, RotatesThroughItsRingFiles) {
  TempDir dir;
  RecordOptions options;
  options.file = dir / "long.pcapng";
  options.max_file_bytes = 4096;
  options.ring_files = 3;
  auto recorder = CaptureRecorder::open(options);
  const auto link = recorder->add_interface("arm", "tether codec=romi baud=- transport=virtual");
  const std::vector<std::uint8_t> frame(1000, 'x');
  for (int i = 0; i < 14; ++i) recorder->record(link, CaptureDirection::inbound, 1000u * static_cast<unsigned>(i), frame, "");
  recorder->close();
  const RecordCounters counters = recorder->counters();
  EXPECT_EQ(counters.packets, 14u);
  EXPECT_GE(counters.files, 4u);  // wrapped around the ring
  for (unsigned i = 0; i < 3; ++i) {
    const fs::path name = ring_file_name(options.file, i);
    ASSERT_TRUE(fs::exists(name)) << name;
    EXPECT_LE(fs::file_size(name), 4096u) << name;
    const Capture capture = read_back(name);
    ASSERT_EQ(capture.interfaces.size(), 1u) << name;  // each file complete on its own
    EXPECT_EQ(capture.interfaces[0].name, "arm");
    EXPECT_FALSE(capture.packets.empty());
  }
  EXPECT_EQ(ring_file_name(options.file, 2), dir / "long.2.pcapng");
}

TEST(CaptureRecorder, RotatesByDuration) {
  TempDir dir;
  RecordOptions options;
  options.file = dir / "timed.pcapng";
  options.max_file_duration = std::chrono::milliseconds(1000);
  auto recorder = CaptureRecorder::open(options);
  const auto link = recorder->add_interface("arm", "tether");
  for (std::uint64_t second = 0; second < 3; ++second) {
    recorder->record(link, CaptureDirection::inbound, second * 1000000, bytes_of("a\n"), "");
    recorder->record(link, CaptureDirection::inbound, second * 1000000 + 999000, bytes_of("b\n"), "");
  }
  recorder->close();
  EXPECT_EQ(recorder->counters().files, 3u);
  const Capture last = read_back(options.file);  // the third file went back to the first name
  ASSERT_EQ(last.packets.size(), 2u);
  EXPECT_EQ(last.packets[0].timestamp_us, 2000000u);
}

TEST(CaptureRecorder, AWriteErrorStopsTheRecordingAndSaysWhy) {
  RecordOptions options;
  options.file = "/dev/full";
  options.overwrite = true;
  auto recorder = CaptureRecorder::open(options);
  const auto link = recorder->add_interface("arm", "tether");
  for (int i = 0; i < 5; ++i) recorder->record(link, CaptureDirection::inbound, 1, bytes_of("a\n"), "");
  recorder->flush();
  recorder->record(link, CaptureDirection::inbound, 2, bytes_of("b\n"), "");
  recorder->close();
  const RecordCounters counters = recorder->counters();
  EXPECT_TRUE(counters.stopped);
  EXPECT_EQ(counters.write_errors, 1u);
  EXPECT_EQ(counters.error, "/dev/full: No space left on device");
  EXPECT_EQ(counters.packets, 0u);
  EXPECT_EQ(counters.lost_packets, 6u);
}

// A pipe nobody reads is a disk that does not keep up: the queue fills, packets are dropped and counted, and
// recording never waits.
TEST(CaptureRecorder, ASlowDiskDropsPacketsAndCountsThem) {
  TempDir dir;
  const fs::path fifo = dir / "slow.pcapng";
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  RecordOptions options;
  options.file = fifo;
  options.overwrite = true;
  options.queue_bytes = 64 * 1024;
  // O_WRONLY on a fifo waits for a reader: hold one open (read nothing) while the recorder opens.
  const int reader = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
  ASSERT_GE(reader, 0);
  auto recorder = CaptureRecorder::open(options);
  const auto link = recorder->add_interface("arm", "tether");
  const std::vector<std::uint8_t> frame(1000, 'x');
  const auto start = std::chrono::steady_clock::now();
  for (int i = 0; i < 1000; ++i) recorder->record(link, CaptureDirection::inbound, 1, frame, "");
  const auto took = std::chrono::steady_clock::now() - start;
  const RecordCounters counters = recorder->counters();
  // 1 MB offered; the pipe takes 64 KB and the queue 64 KB: most is dropped.
  EXPECT_GT(counters.dropped_packets, 500u);
  EXPECT_LT(took, std::chrono::seconds(5));  // never blocked on the pipe (a bound far above what it takes)
  // Drain the pipe so the writer can finish.
  std::thread drain([reader] {
    char buffer[65536];
    for (;;) {
      const ssize_t got = ::read(reader, buffer, sizeof buffer);
      if (got == 0) break;
      if (got < 0 && errno == EAGAIN) {
        std::this_thread::sleep_for(std::chrono::milliseconds(1));
        continue;
      }
      if (got < 0) break;
    }
  });
  recorder->close();
  drain.join();
  ::close(reader);
  const RecordCounters after = recorder->counters();
  EXPECT_EQ(after.packets + after.dropped_packets, 1000u);
}

// --- recording stream -----------------------------------------------------------------------------------------

TEST(RecordingStream, RecordsBothDirectionsFramedWithTheWallClock) {
  TempDir dir;
  RecordOptions options;
  options.file = dir / "link.pcapng";
  auto recorder = CaptureRecorder::open(options);
  asio::io_context io;
  auto [host, device] = InMemoryStream::make_pair(io.get_executor());
  std::uint64_t now = 1000;
  const CaptureFraming framing = [](bool) {
    return std::make_unique<DelimitedFramer>(lines("#", true, 64));
  };
  auto recorded = RecordingStream::wrap(host, recorder, "arm", "tether codec=romi baud=- transport=virtual", framing,
                                        [&now] { return now; });
  const std::string request = "#e:0a5c\r\n";
  const std::string answer = "junk#e:0a5c\r\n#!par";
  std::vector<std::uint8_t> got(64);
  std::size_t received = 0;
  asio::async_write(*recorded, asio::buffer(request), [&](error_code error, std::size_t) {
    ASSERT_FALSE(error);
    now = 2000;
    asio::async_write(*device, asio::buffer(answer), [](error_code, std::size_t) {});
    asio::async_read(*recorded, asio::buffer(got, answer.size()), [&](error_code read_error, std::size_t size) {
      EXPECT_FALSE(read_error);
      received = size;
      now = 3000;
      recorded->close();
    });
  });
  io.run();
  EXPECT_EQ(received, answer.size());
  recorder->close();
  const Capture capture = read_back(options.file);
  ASSERT_EQ(capture.interfaces.size(), 1u);
  EXPECT_EQ(capture.interfaces[0].name, "arm");
  ASSERT_EQ(capture.packets.size(), 4u);
  EXPECT_EQ(text_of(capture.packets[0].data), request);
  EXPECT_EQ(capture.packets[0].direction, CaptureDirection::outbound);
  EXPECT_EQ(capture.packets[0].timestamp_us, 1000u);
  EXPECT_EQ(text_of(capture.packets[1].data), "junk");
  EXPECT_EQ(capture.packets[1].comment, "unframed: noise");
  EXPECT_EQ(capture.packets[1].direction, CaptureDirection::inbound);
  EXPECT_EQ(text_of(capture.packets[2].data), "#e:0a5c\r\n");
  EXPECT_EQ(capture.packets[2].timestamp_us, 2000u);
  EXPECT_EQ(text_of(capture.packets[3].data), "#!par");
  EXPECT_EQ(capture.packets[3].comment, "unframed: cut at close");
  EXPECT_EQ(capture.packets[3].timestamp_us, 3000u);
}

// Reads from an in-memory host end; holds each write until `release_write()`, as a busy serial port does.
class HeldWriteStream final : public ByteStream {
 public:
  explicit HeldWriteStream(std::shared_ptr<ByteStream> inner) : ByteStream(inner->get_executor()), inner_(std::move(inner)) {}
  std::string description() const override { return "held writes"; }
  void release_write() {
    asio::post(strand(), [this, handler = std::move(write_), size = write_size_]() mutable { handler(error_code(), size); });
  }
  bool write_held() const { return static_cast<bool>(write_); }

 protected:
  void do_read(asio::mutable_buffer buffer, IoHandler handler) override {
    inner_->async_read_some(buffer, asio::bind_executor(strand(), [handler = std::move(handler)](
                                                                      error_code error, std::size_t got) mutable {
                              handler(error, got);
                            }));
  }
  void do_write(asio::const_buffer buffer, IoHandler handler) override {
    write_ = std::move(handler);
    write_size_ = buffer.size();
  }
  void do_close(error_code& error) override { inner_->close(error); }

 private:
  std::shared_ptr<ByteStream> inner_;
  IoHandler write_;
  std::size_t write_size_ = 0;
};

TEST(RecordingStream, PacketsAreInTimeOrderWhenAWriteCompletesAfterARead) {
  TempDir dir;
  RecordOptions options;
  options.file = dir / "order.pcapng";
  auto recorder = CaptureRecorder::open(options);
  asio::io_context io;
  auto [host, device] = InMemoryStream::make_pair(io.get_executor());
  auto held = std::make_shared<HeldWriteStream>(host);
  std::uint64_t now = 1000;
  const CaptureFraming framing = [](bool) { return std::make_unique<DelimitedFramer>(lines("#", true, 64)); };
  auto recorded = RecordingStream::wrap(held, recorder, "arm", "tether codec=romi baud=- transport=virtual", framing,
                                        [&now] { return now; });
  const std::string request = "#e:0a5c\r\n";
  const std::string log = "#!booted:0000\r\n";
  bool written = false;
  asio::async_write(*recorded, asio::buffer(request), [&](error_code error, std::size_t) {
    EXPECT_FALSE(error);
    written = true;
  });
  io.poll();
  ASSERT_TRUE(held->write_held());
  now = 2000;  // the device's line arrives while the request is still being written
  std::vector<std::uint8_t> got(log.size());
  bool read = false;
  asio::async_write(*device, asio::buffer(log), [](error_code, std::size_t) {});
  asio::async_read(*recorded, asio::buffer(got), [&](error_code error, std::size_t) {
    EXPECT_FALSE(error);
    read = true;
  });
  while (!read && io.run_one() > 0) {
  }
  ASSERT_TRUE(read);
  now = 3000;
  held->release_write();
  while (!written && io.run_one() > 0) {
  }
  ASSERT_TRUE(written);
  recorded->close();
  recorder->close();
  const Capture capture = read_back(options.file);
  ASSERT_EQ(capture.packets.size(), 2u);
  EXPECT_EQ(text_of(capture.packets[0].data), log);
  EXPECT_EQ(text_of(capture.packets[1].data), request);
  EXPECT_EQ(capture.packets[0].timestamp_us, 2000u);
  EXPECT_EQ(capture.packets[1].timestamp_us, 3000u);  // when the link took it, after the read: never backwards
}

TEST(CaptureRecorder, DiscardIfEmptyRemovesOnlyAFileWithoutPackets) {
  TempDir dir;
  RecordOptions options;
  options.file = dir / "failed-open.pcapng";
  auto empty = CaptureRecorder::open(options);
  empty->add_interface("arm", "tether codec=romi baud=- transport=virtual");
  EXPECT_TRUE(empty->discard_if_empty());
  EXPECT_FALSE(fs::exists(options.file));
  EXPECT_TRUE(CaptureRecorder::open(options) != nullptr);  // opening again finds nothing in the way

  options.file = dir / "kept.pcapng";
  auto used = CaptureRecorder::open(options);
  const std::uint32_t arm = used->add_interface("arm", "tether codec=romi baud=- transport=virtual");
  used->record(arm, CaptureDirection::outbound, 1000, bytes_of("#e:0a5c\r\n"), "");
  EXPECT_FALSE(used->discard_if_empty());
  EXPECT_EQ(read_back(options.file).packets.size(), 1u);
}

}  // namespace
}  // namespace tether::transports
