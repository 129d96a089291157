// Capture recorders and recording streams (recording.hpp).
#include "tether/transports/recording.hpp"
#include "tether/transports/serial_port_stream.hpp"

#include <fcntl.h>
#include <unistd.h>

#include <boost/asio/bind_executor.hpp>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <stdexcept>
#include <utility>

#ifndef TETHER_VERSION
#define TETHER_VERSION "unknown"
#endif

namespace tether::transports {

namespace {

std::string os_error(int value) { return std::strerror(value); }

int open_file(const std::filesystem::path& file, bool overwrite) {
  const int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (overwrite ? O_TRUNC : O_EXCL);
  int fd;
  do {
    fd = ::open(file.c_str(), flags, 0644);
  } while (fd < 0 && errno == EINTR);
  return fd;
}

std::uint64_t system_microseconds() {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::system_clock::now().time_since_epoch()).count());
}

}  // namespace

std::filesystem::path ring_file_name(const std::filesystem::path& file, unsigned index) {
  if (index == 0) return file;
  std::filesystem::path name = file.parent_path() / file.stem();
  name += "." + std::to_string(index);
  name += file.extension();
  return name;
}

// --- CaptureRecorder ------------------------------------------------------------------------------------------

std::shared_ptr<CaptureRecorder> CaptureRecorder::open(const RecordOptions& options, boost::system::error_code& error,
                                                       std::string& message) {
  error.clear();
  message.clear();
  const auto invalid = [&](const std::string& what) {
    error = boost::system::errc::make_error_code(boost::system::errc::invalid_argument);
    message = what;
    return nullptr;
  };
  if (options.file.empty()) return invalid("no capture file named");
  const bool rotating = options.max_file_bytes > 0 || options.max_file_duration.count() > 0;
  if (rotating && (options.ring_files < 2 || options.ring_files > 1000)) {
    return invalid(options.file.string() + ": ring files must be 2..1000, not " + std::to_string(options.ring_files));
  }
  if (options.max_file_bytes > 0 && options.max_file_bytes < 4096) {
    return invalid(options.file.string() + ": a file size limit under 4096 bytes leaves no room for packets");
  }
  if (options.queue_bytes == 0) return invalid(options.file.string() + ": the queue must hold at least one byte");
  if (rotating && !options.overwrite) {
    for (unsigned i = 1; i < options.ring_files; ++i) {
      const auto name = ring_file_name(options.file, i);
      std::error_code ignored;
      if (std::filesystem::exists(std::filesystem::symlink_status(name, ignored))) {
        error = boost::system::errc::make_error_code(boost::system::errc::file_exists);
        message = name.string() + ": ring file exists (--force overwrites it)";
        return nullptr;
      }
    }
  }
  const int fd = open_file(options.file, options.overwrite);
  if (fd < 0) {
    const int cause = errno;
    error = boost::system::error_code(cause, boost::system::system_category());
    message = options.file.string() + ": " + os_error(cause) + (cause == EEXIST ? " (--force overwrites it)" : "");
    return nullptr;
  }
  return std::make_shared<CaptureRecorder>(options, fd);
}

std::shared_ptr<CaptureRecorder> CaptureRecorder::open(const RecordOptions& options) {
  boost::system::error_code error;
  std::string message;
  auto recorder = open(options, error, message);
  if (!recorder) throw boost::system::system_error(error, message);
  return recorder;
}

CaptureRecorder::CaptureRecorder(RecordOptions options, int fd) : options_(std::move(options)), fd_(fd) {
  counters_.files = 1;
  counters_.file = options_.file.string();
  writer_ = std::thread([this] { run(); });
}

CaptureRecorder::~CaptureRecorder() { close(); }

std::uint32_t CaptureRecorder::add_interface(const std::string& name, const std::string& description) {
  std::lock_guard lock(mutex_);
  const auto id = static_cast<std::uint32_t>(interfaces_.size());
  interfaces_.emplace_back(name, description);
  Item item;
  item.interface = true;
  item.id = id;
  // Interfaces are never dropped: a packet of an undescribed interface would corrupt the file.
  queued_bytes_ += item.size();
  queue_.push_back(std::move(item));
  wake_.notify_one();
  return id;
}

void CaptureRecorder::record(std::uint32_t interface, CaptureDirection direction, std::uint64_t timestamp_us,
                             std::vector<std::uint8_t> bytes, std::string comment) {
  Item item;
  item.id = interface;
  item.direction = direction;
  item.timestamp_us = timestamp_us;
  item.bytes = std::move(bytes);
  item.comment = std::move(comment);
  std::lock_guard lock(mutex_);
  if (closing_ || counters_.stopped) {
    ++counters_.lost_packets;
    return;
  }
  if (queued_bytes_ + item.size() > options_.queue_bytes) {
    ++counters_.dropped_packets;
    return;
  }
  queued_bytes_ += item.size();
  queue_.push_back(std::move(item));
  wake_.notify_one();
}

void CaptureRecorder::flush() {
  std::unique_lock lock(mutex_);
  drained_.wait(lock, [this] { return (queue_.empty() && in_flight_ == 0) || !writer_.joinable(); });
}

void CaptureRecorder::close() {
  {
    std::lock_guard lock(mutex_);
    closing_ = true;
    wake_.notify_one();
  }
  if (writer_.joinable() && writer_.get_id() != std::this_thread::get_id()) writer_.join();
  std::lock_guard lock(mutex_);
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  drained_.notify_all();
}

bool CaptureRecorder::discard_if_empty() {
  close();
  std::lock_guard lock(mutex_);
  if (counters_.packets != 0 || counters_.dropped_packets != 0 || counters_.lost_packets != 0 || counters_.files != 1) {
    return false;
  }
  std::error_code ignored;
  return std::filesystem::remove(options_.file, ignored);
}

RecordCounters CaptureRecorder::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

void CaptureRecorder::run() {
  // The section header at once: a recording without packets is still a capture.
  write_block(pcapng::section_header("tether " TETHER_VERSION));
  std::unique_lock lock(mutex_);
  for (;;) {
    wake_.wait(lock, [this] { return closing_ || !queue_.empty(); });
    if (queue_.empty() && closing_) break;
    std::deque<Item> batch;
    batch.swap(queue_);
    queued_bytes_ = 0;
    in_flight_ = batch.size();
    lock.unlock();
    for (const Item& item : batch) write_item(item);
    lock.lock();
    in_flight_ = 0;
    drained_.notify_all();
  }
}

void CaptureRecorder::stop_with(const std::string& error) {
  std::lock_guard lock(mutex_);
  ++counters_.write_errors;
  counters_.stopped = true;
  counters_.error = error;
}

bool CaptureRecorder::write_block(const std::vector<std::uint8_t>& block) {
  std::size_t done = 0;
  while (done < block.size()) {
    const ssize_t wrote = ::write(fd_, block.data() + done, block.size() - done);
    if (wrote < 0 && errno == EINTR) continue;
    if (wrote <= 0) {
      const int cause = wrote < 0 ? errno : EIO;
      std::string file;
      {
        std::lock_guard lock(mutex_);
        file = counters_.file;
      }
      stop_with(file + ": " + os_error(cause));
      ::close(fd_);
      fd_ = -1;
      return false;
    }
    done += static_cast<std::size_t>(wrote);
  }
  file_bytes_ += block.size();
  std::lock_guard lock(mutex_);
  counters_.bytes += block.size();
  return true;
}

bool CaptureRecorder::rotate() {
  ::close(fd_);
  fd_ = -1;
  ring_index_ = (ring_index_ + 1) % options_.ring_files;
  const auto name = ring_file_name(options_.file, ring_index_);
  // The ring's own files are rewritten; a file that was there before the recording was checked at open.
  fd_ = open_file(name, true);
  if (fd_ < 0) {
    stop_with(name.string() + ": " + os_error(errno));
    return false;
  }
  file_bytes_ = 0;
  file_packets_ = 0;
  std::vector<std::pair<std::string, std::string>> interfaces;
  {
    std::lock_guard lock(mutex_);
    ++counters_.files;
    counters_.file = name.string();
    interfaces.assign(interfaces_.begin(),
                      interfaces_.begin() + static_cast<std::ptrdiff_t>(interfaces_written_));
  }
  if (!write_block(pcapng::section_header("tether " TETHER_VERSION))) return false;
  for (const auto& [name_of, description] : interfaces) {
    if (!write_block(pcapng::interface_description(name_of, description))) return false;
  }
  return true;
}

void CaptureRecorder::write_item(const Item& item) {
  bool stopped;
  {
    std::lock_guard lock(mutex_);
    stopped = counters_.stopped;
    if (stopped && !item.interface) ++counters_.lost_packets;
  }
  if (stopped) return;
  if (file_bytes_ == 0 && !write_block(pcapng::section_header("tether " TETHER_VERSION))) return;
  if (item.interface) {
    std::pair<std::string, std::string> interface;
    {
      std::lock_guard lock(mutex_);
      interface = interfaces_[item.id];
    }
    if (write_block(pcapng::interface_description(interface.first, interface.second))) ++interfaces_written_;
    return;
  }
  auto block = pcapng::enhanced_packet(item.id, item.timestamp_us, item.direction, item.bytes, item.comment);
  if (file_packets_ > 0) {
    const bool full = options_.max_file_bytes > 0 && file_bytes_ + block.size() > options_.max_file_bytes;
    const bool old = options_.max_file_duration.count() > 0 &&
                     item.timestamp_us >= file_first_us_ &&
                     item.timestamp_us - file_first_us_ >=
                         static_cast<std::uint64_t>(options_.max_file_duration.count()) * 1000;
    if ((full || old) && !rotate()) return;
  }
  if (file_packets_ == 0) file_first_us_ = item.timestamp_us;
  if (!write_block(block)) {
    std::lock_guard lock(mutex_);
    ++counters_.lost_packets;
    return;
  }
  ++file_packets_;
  std::lock_guard lock(mutex_);
  ++counters_.packets;
}

// --- RecordingStream ------------------------------------------------------------------------------------------

std::shared_ptr<RecordingStream> RecordingStream::wrap(std::shared_ptr<ByteStream> inner,
                                                       std::shared_ptr<CaptureRecorder> recorder,
                                                       const std::string& name, const std::string& description,
                                                       const CaptureFraming& framing, WallClock clock) {
  if (!inner || !recorder) throw std::invalid_argument("RecordingStream::wrap: null stream or recorder");
  const std::uint32_t interface = recorder->add_interface(name, description);
  return std::make_shared<RecordingStream>(std::move(inner), std::move(recorder), interface, framing, std::move(clock));
}

RecordingStream::RecordingStream(std::shared_ptr<ByteStream> inner, std::shared_ptr<CaptureRecorder> recorder,
                                 std::uint32_t interface, const CaptureFraming& framing, WallClock clock)
    : ByteStream(inner->get_executor()),
      inner_(std::move(inner)),
      recorder_(std::move(recorder)),
      interface_(interface),
      clock_(clock ? std::move(clock) : WallClock(system_microseconds)),
      inbound_(framing ? framing(true) : nullptr),
      outbound_(framing ? framing(false) : nullptr),
      scratch_(std::make_shared<std::vector<std::uint8_t>>(4096)) {
  if (!inbound_) inbound_ = std::make_unique<ChunkFramer>();
  if (!outbound_) outbound_ = std::make_unique<ChunkFramer>();
}

std::string RecordingStream::description() const {
  return "recording to " + recorder_->options().file.string() + " over " + inner_->description();
}

void RecordingStream::record_event(const std::string& text) {
  recorder_->record(interface_, CaptureDirection::unknown, clock_(), {}, "link: " + text);
}

void RecordingStream::record(CaptureFramer& framer, CaptureDirection direction, std::span<const std::uint8_t> bytes,
                             std::uint64_t timestamp_us) {
  std::lock_guard lock(framers_mutex_);
  framer.feed(bytes, [&](FramedPacket packet) {
    recorder_->record(interface_, direction, timestamp_us, std::move(packet.bytes), packet.comment());
  });
}

void RecordingStream::flush(CaptureFramer& framer, CaptureDirection direction, const std::string& reason) {
  const std::uint64_t now = clock_();
  std::lock_guard lock(framers_mutex_);
  framer.flush(reason, [&](FramedPacket packet) {
    recorder_->record(interface_, direction, now, std::move(packet.bytes), packet.comment());
  });
}

void RecordingStream::do_read(asio::mutable_buffer buffer, IoHandler handler) {
  // Into a buffer of our own that the pending read keeps alive: the inner stream may outlive this one (a
  // serial port the rover also holds).
  auto scratch = scratch_;
  const std::size_t size = std::min(buffer.size(), scratch->size());
  inner_->async_read_some(
      asio::buffer(scratch->data(), size),
      asio::bind_executor(strand(), [this, weak = weak_from_this(), scratch, buffer,
                                     handler = std::move(handler)](error_code error, std::size_t got) mutable {
        const auto self = weak.lock();
        if (!self) return;
        if (!error) {
          std::copy_n(scratch->data(), got, static_cast<std::uint8_t*>(buffer.data()));
          record(*inbound_, CaptureDirection::inbound, std::span<const std::uint8_t>(scratch->data(), got), clock_());
        } else if (error == TransportError::disconnected) {
          flush(*inbound_, CaptureDirection::inbound, "cut at outage");
          record_event("down");
        } else if (error == TransportError::reconnected) {
          // A supervised serial port says how long the board took to be ready again.
          const auto port = std::dynamic_pointer_cast<SerialPortStream>(inner_);
          if (port) {
            const BootReport boot = port->link_counters().last_boot;
            record_event("up ready after " + std::to_string(boot.ready_after.count()) + " ms (" +
                         std::string(to_string(boot.outcome)) + ")");
          } else {
            record_event("up");
          }
        } else {
          flush(*inbound_, CaptureDirection::inbound, "cut at close");
        }
        handler(error, error ? 0 : got);
      }));
}

void RecordingStream::do_write(asio::const_buffer buffer, IoHandler handler) {
  inner_->async_write_some(
      buffer, asio::bind_executor(strand(), [this, self = shared_from_this(), buffer,
                                             handler = std::move(handler)](error_code error, std::size_t wrote) mutable {
        // Stamped when the link took the bytes, as reads are when they complete: a read that completed while
        // this write was pending is recorded first, so the file's times never go backwards.
        if (wrote > 0) {
          record(*outbound_, CaptureDirection::outbound,
                 std::span<const std::uint8_t>(static_cast<const std::uint8_t*>(buffer.data()), wrote), clock_());
        }
        handler(error, wrote);
      }));
}

void RecordingStream::do_close(error_code& error) {
  flush(*inbound_, CaptureDirection::inbound, "cut at close");
  flush(*outbound_, CaptureDirection::outbound, "cut at close");
  inner_->close(error);
  if (close_recorder_) recorder_->close();
}

}  // namespace tether::transports
