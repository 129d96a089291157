/// @file recording.hpp
/// Recording what crosses a link into a capture file (pcapng, pcapng.hpp; docs/captures.md):
///   - `CaptureRecorder` owns one capture file (with its ring files when limits are set), one interface per
///     device link, and a background thread that writes it: recording never waits for the disk;
///   - `RecordingStream` wraps a link's `ByteStream`: it timestamps every read and write, cuts the bytes into
///     packets with the codec's framing (capture_framing.hpp) and hands them to the recorder.
///
/// @code
///   transports::RecordOptions options;
///   options.file = "rover.pcapng";
///   auto recorder = transports::CaptureRecorder::open(options);            // throws system_error
///   auto recorded = transports::RecordingStream::wrap(stream, recorder, "arm",
///                                                     "tether codec=romi baud=115200 transport=serial", framing);
/// @endcode
///
/// Bounded and never in the link's way: packets wait in a queue of at most `RecordOptions::queue_bytes`; when
/// the disk is slower than the link the packets that do not fit are dropped and counted (`dropped_packets`).
/// A write error (a full disk) stops the recording and keeps the reason (`RecordCounters::error`); the link
/// goes on. A file that exists is never overwritten unless `overwrite` is set.
///
/// Rotation: with `max_file_bytes` and/or `max_file_duration` set, the recording moves on to the next file of a
/// ring of `ring_files` once a file reaches a limit; each file is a complete capture (section header and every
/// interface). The files are `FILE` and then `STEM.1.EXT`, `STEM.2.EXT`, ... (`rover.pcapng`, `rover.1.pcapng`);
/// after the last the first is written again (the ring's own files only).
#pragma once

#include <boost/system/error_code.hpp>

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <filesystem>
#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "tether/transports/byte_stream.hpp"
#include "tether/transports/capture_framing.hpp"
#include "tether/transports/pcapng.hpp"

namespace tether::transports {

/// Where and how much to record.
struct RecordOptions {
  std::filesystem::path file;  ///< The capture file (the first of a ring).
  bool overwrite = false;      ///< Replace existing files (otherwise opening fails when one exists).
  /// Start the next ring file once a file holds this many bytes (0: no limit).
  std::uint64_t max_file_bytes = 0;
  /// Start the next ring file once a file spans this long (0: no limit).
  std::chrono::milliseconds max_file_duration{0};
  /// Files of the ring when a limit is set (2..1000).
  unsigned ring_files = 2;
  /// Bytes of packets waiting for the writer at most (a slower disk drops what does not fit).
  std::size_t queue_bytes = std::size_t{4} << 20;
};

/// The name of ring file `index` of `file` (0: `file` itself, then `STEM.index.EXT`).
std::filesystem::path ring_file_name(const std::filesystem::path& file, unsigned index);

/// What a recorder did.
struct RecordCounters {
  std::uint64_t packets = 0;          ///< Packets written.
  std::uint64_t bytes = 0;            ///< Bytes written to files (blocks, headers included).
  std::uint64_t dropped_packets = 0;  ///< Packets dropped because the queue was full (a slow disk).
  std::uint64_t lost_packets = 0;     ///< Packets not written because the recording had stopped (an error).
  std::uint64_t files = 0;            ///< Files opened (1 + rotations).
  std::uint64_t write_errors = 0;     ///< Write errors (each stops the recording).
  bool stopped = false;               ///< True once a write error stopped the recording.
  std::string error;                  ///< Why it stopped (`rover.pcapng: No space left on device`), or empty.
  std::string file;                   ///< The file being written.
};

/// One capture file being written; see the file overview. Thread-safe.
class CaptureRecorder {
 public:
  /// Creates the file (and checks the ring's names) and starts the writer. `error` and `message`
  /// (`rover.pcapng: File exists (--force overwrites it)`) on failure, then null.
  static std::shared_ptr<CaptureRecorder> open(const RecordOptions& options, boost::system::error_code& error,
                                               std::string& message);
  /// `open` that throws `boost::system::system_error` (its what() the message).
  static std::shared_ptr<CaptureRecorder> open(const RecordOptions& options);

  /// Writes what is queued and closes the file.
  ~CaptureRecorder();
  CaptureRecorder(const CaptureRecorder&) = delete;
  CaptureRecorder& operator=(const CaptureRecorder&) = delete;

  /// Adds an interface (a device link): `name` is if_name, `description` if_description. Returns its id.
  std::uint32_t add_interface(const std::string& name, const std::string& description);
  /// Queues one packet (never waits for the disk; dropped and counted when the queue is full).
  void record(std::uint32_t interface, CaptureDirection direction, std::uint64_t timestamp_us,
              std::vector<std::uint8_t> bytes, std::string comment);
  /// Waits until everything queued so far is written (or dropped); for tests and orderly shutdowns.
  void flush();
  /// Writes what is queued, then closes the file and stops the writer. Idempotent; later packets are lost.
  void close();
  /// Closes the recorder, then removes its file if no packet ever reached it (none written, dropped or lost):
  /// the file an open that failed created, so that opening again does not fail on "File exists". A file with
  /// packets is kept (what crossed the link before the failure). True when the file was removed.
  bool discard_if_empty();
  /// A snapshot of the counters.
  RecordCounters counters() const;
  /// The options it was opened with.
  const RecordOptions& options() const { return options_; }

  /// Constructed by `open` (public for std::make_shared).
  CaptureRecorder(RecordOptions options, int fd);

 private:
  struct Item {
    bool interface = false;
    std::uint32_t id = 0;
    CaptureDirection direction = CaptureDirection::unknown;
    std::uint64_t timestamp_us = 0;
    std::vector<std::uint8_t> bytes;
    std::string comment;
    std::size_t size() const { return bytes.size() + comment.size() + 64; }
  };
  void run();
  void write_item(const Item& item);
  bool write_block(const std::vector<std::uint8_t>& block);
  bool rotate();
  void stop_with(const std::string& error);

  const RecordOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  std::condition_variable drained_;
  std::deque<Item> queue_;
  std::size_t queued_bytes_ = 0;
  std::uint64_t in_flight_ = 0;  // items taken by the writer and not yet written
  bool closing_ = false;
  std::vector<std::pair<std::string, std::string>> interfaces_;  // every interface, for each new ring file
  RecordCounters counters_;
  // The writer thread's own (counters_ is updated under mutex_):
  int fd_ = -1;
  unsigned ring_index_ = 0;
  std::uint64_t file_bytes_ = 0;
  std::uint64_t file_packets_ = 0;
  std::uint64_t file_first_us_ = 0;
  std::size_t interfaces_written_ = 0;
  std::thread writer_;
};

/// A link's stream whose reads and writes are recorded; see the file overview. Closing it closes the inner
/// stream, and flushes a partial frame as unframed bytes (`cut at close`).
class RecordingStream final : public ByteStream {
 public:
  /// Microseconds since the Unix epoch (the system clock by default; a fake one in tests).
  using WallClock = std::function<std::uint64_t()>;
  /// Wraps `inner` (owned from then on): adds interface `name`/`description` to `recorder` and records both
  /// directions, cut by `framing` (null: each read and write one `unframed: no framing` packet).
  static std::shared_ptr<RecordingStream> wrap(std::shared_ptr<ByteStream> inner,
                                               std::shared_ptr<CaptureRecorder> recorder, const std::string& name,
                                               const std::string& description, const CaptureFraming& framing,
                                               WallClock clock = {});
  /// The recorder.
  const std::shared_ptr<CaptureRecorder>& recorder() const { return recorder_; }
  /// This link's interface id in the capture.
  std::uint32_t interface() const { return interface_; }
  /// The stream it records (a serial port's, for its link events).
  const std::shared_ptr<ByteStream>& inner() const { return inner_; }
  /// Records a link event: a zero-length packet with comment `link: <text>` (`down`, `up ready after 37 ms (probed)`).
  void record_event(const std::string& text);
  /// `recording to FILE over <inner>`.
  std::string description() const override;
  /// Closes the recorder too when this stream closes (the file is then complete): for a recorder of this
  /// link alone (a client opened with `record=`, `tether monitor --write`).
  void close_recorder_on_close(bool close) { close_recorder_ = close; }

  /// Constructed by `wrap` (public for std::make_shared).
  RecordingStream(std::shared_ptr<ByteStream> inner, std::shared_ptr<CaptureRecorder> recorder,
                  std::uint32_t interface, const CaptureFraming& framing, WallClock clock);

 protected:
  void do_read(asio::mutable_buffer buffer, IoHandler handler) override;
  void do_write(asio::const_buffer buffer, IoHandler handler) override;
  void do_close(error_code& error) override;

 private:
  void record(CaptureFramer& framer, CaptureDirection direction, std::span<const std::uint8_t> bytes,
              std::uint64_t timestamp_us);
  void flush(CaptureFramer& framer, CaptureDirection direction, const std::string& reason);

  std::shared_ptr<ByteStream> inner_;
  std::shared_ptr<CaptureRecorder> recorder_;
  std::uint32_t interface_;
  WallClock clock_;
  std::mutex framers_mutex_;
  std::unique_ptr<CaptureFramer> inbound_;
  std::unique_ptr<CaptureFramer> outbound_;
  std::shared_ptr<std::vector<std::uint8_t>> scratch_;
  std::atomic<bool> close_recorder_{false};
};

}  // namespace tether::transports
