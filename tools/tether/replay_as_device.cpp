// `tether replay FILE --device D --as-device [--link PATH] [--loop]`: plays the recorded device of one link
// of a capture on a pseudo-terminal, so host code can be run offline against a field session.
//
// The recording is cut into steps at the host's requests (as the codec's rules classify them,
// transports/capture_replay.hpp): step 0 is what the device sent before the first request, step k the k-th
// recorded request and every device frame recorded after it up to the next request. When the live host's
// frame (cut by the codec's capture framing) matches the next step's request, that step's frames go out,
// each at the live request's time plus its recorded delay after the recorded request, rewritten for the
// live host (ids, CRCs); whatever an earlier step still had pending goes out first, so the order is always
// the recorded one. A live request that does not match is one line on stderr (what was expected, what
// came) and gets the codec's answer to an unknown request; a keepalive gets the codec's answer at once.
//
// Output contract (as `tether sim`'s): exactly one line `PTY <slave path>` on stdout once the pty is open
// (`{"pty":...,"device":...}` with --json); mismatches on stderr. Ends 0 after the last step was played, the
// host has read it all (or left it unread for 2 s: it closed the port), and 500 ms passed without a frame
// either way; or on SIGINT/SIGTERM. With --loop the recording starts again as soon as its last frame went
// out, until a signal.
#include "replay_as_device.hpp"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <deque>
#include <filesystem>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "cli_support.hpp"
#include "tether/devices/codecs.hpp"
#include "tether/transports/capture_replay.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/pcapng.hpp"
#include "tether/transports/pty_stream.hpp"

namespace tether::cli {

namespace {

using Clock = std::chrono::steady_clock;
using Bytes = std::vector<std::uint8_t>;

// How long the link has to be quiet after the last step before the replay ends.
constexpr std::chrono::milliseconds kGrace{500};
// How long bytes may stay unread before they count as left behind by a host that closed the port.
constexpr std::chrono::milliseconds kGone{2000};

struct RecordedFrame {
  Bytes bytes;
  std::uint64_t delay_us = 0;  // after the step's request (step 0: after the capture's first packet)
  bool frame = true;           // false: unframed bytes, played as recorded
};

struct Step {
  Bytes request;      // empty for step 0
  std::string key;    // the request's key
  std::uint64_t at_us = 0;
  std::vector<RecordedFrame> frames;
};

std::string in_quotes(const std::string& key) { return "'" + printable(key) + "'"; }

std::span<const std::uint8_t> view(const Bytes& bytes) { return {bytes.data(), bytes.size()}; }

}  // namespace

int replay_as_device(const transports::Capture& capture, std::uint32_t interface, const devices::DeviceConfig& device,
                     const AsDeviceOptions& options) {
  const auto fail = [](const std::string& message) {
    std::fprintf(stderr, "tether replay: %s\n", message.c_str());
    return 2;
  };
  const devices::CodecRow& row = devices::codec_row(device.codec);
  if (!row.capture_replay) {
    return fail(options.file + ": codec " + std::string(row.name) + "'s devices cannot be played (--as-device)");
  }
  const std::unique_ptr<transports::CaptureReplayer> rules = row.capture_replay(device);
  const transports::CaptureFraming framing =
      row.capture_framing
          ? row.capture_framing(device)
          : transports::CaptureFraming([](bool) { return std::make_unique<transports::ChunkFramer>(); });

  // The steps, from the link's packets in file order.
  std::vector<Step> steps(1);
  const std::uint64_t first = capture.packets.empty() ? 0 : capture.packets.front().timestamp_us;
  steps[0].at_us = first;
  for (const transports::CapturePacket& packet : capture.packets) {
    if (packet.interface != interface || packet.link_event()) continue;
    if (packet.direction == transports::CaptureDirection::outbound) {
      if (packet.unframed()) continue;
      transports::ReplayRequest request = rules->classify(view(packet.data));
      if (request.kind != transports::ReplayRequest::Kind::request) continue;
      Step step;
      step.request = packet.data;
      step.key = std::move(request.key);
      step.at_us = packet.timestamp_us;
      steps.push_back(std::move(step));
    } else if (packet.direction == transports::CaptureDirection::inbound) {
      Step& step = steps.back();
      const std::uint64_t delay = packet.timestamp_us >= step.at_us ? packet.timestamp_us - step.at_us : 0;
      step.frames.push_back(RecordedFrame{packet.data, delay, !packet.unframed()});
    }
  }

  transports::IoThread io;
  boost::system::error_code error;
  const auto pty = transports::PtyStream::open(io.executor(), error);
  if (!pty) return fail("cannot open a pseudo-terminal: " + error.message());
  const std::string path = pty->slave_path();
  // A descriptor of our own on the slave, never read: how many bytes the host has not read yet (FIONREAD),
  // so the replay never ends (closing the pty) before the host has the last answer.
  const int watch = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_CLOEXEC);
  if (watch < 0) return fail("cannot open " + path + ": " + std::strerror(errno));
  struct Cleanup {
    int fd;
    const AsDeviceOptions& options;
    const std::string& path;
    ~Cleanup() {
      ::close(fd);
      if (options.link) remove_link(*options.link, path);
    }
  };
  std::string message;
  if (options.link && make_link(*options.link, path, message)) {
    ::close(watch);
    return fail(message);
  }
  const Cleanup cleanup{watch, options, path};
  // Before the pty is announced: a stop signal sent once the path is out ends the replay cleanly.
  const std::atomic<bool>& stop = catch_stop_signals();
  if (options.json) {
    std::printf("%s\n", dump(nlohmann::ordered_json{{"pty", path}, {"device", device.name}}).c_str());
  } else {
    std::printf("PTY %s\n", path.c_str());
  }
  std::fflush(stdout);

  struct Pending {
    Clock::time_point due;
    const RecordedFrame* frame;
  };
  std::deque<Pending> pending;
  const auto schedule = [&](const Step& step, Clock::time_point from) {
    for (const RecordedFrame& frame : step.frames) {
      pending.push_back({from + std::chrono::microseconds(frame.delay_us), &frame});
    }
  };
  bool write_failed = false;
  Clock::time_point last_activity = Clock::now();  // the last frame from the host or to it
  const auto send = [&](const Bytes& bytes) {
    if (bytes.empty() || write_failed) return;
    last_activity = Clock::now();
    boost::system::error_code write_error;
    write_to_device(*pty, boost::asio::buffer(bytes), write_error);
    if (write_error) {
      write_failed = true;
      fail("writing to " + path + ": " + write_error.message());
    }
  };
  const auto play = [&](const RecordedFrame& frame) {
    if (!frame.frame) return send(frame.bytes);
    if (const std::optional<Bytes> rewritten = rules->rewrite(view(frame.bytes))) send(*rewritten);
  };

  int last_unread = 0;  // what the host had not read yet at the last look, and since when
  Clock::time_point unread_since = Clock::now();
  std::size_t next = 1;  // the step whose request comes next
  std::size_t requests = 0;
  schedule(steps[0], Clock::now());
  const std::unique_ptr<transports::CaptureFramer> framer = framing(false);
  std::array<std::uint8_t, 1024> buffer{};
  bool host_failed = false;
  while (!stop && !write_failed) {
    Clock::time_point now = Clock::now();
    while (!pending.empty() && pending.front().due <= now) {
      play(*pending.front().frame);
      pending.pop_front();
    }
    if (next == steps.size() && pending.empty()) {
      if (options.loop) {
        // At once, not after a grace: a host that runs its session again right away finds the first request
        // expected.
        next = 1;
        schedule(steps[0], now);
        continue;
      }
      int unread = 0;
      if (::ioctl(watch, FIONREAD, &unread) != 0) unread = 0;
      if (unread != last_unread) {
        last_unread = unread;
        unread_since = now;
      }
      // The grace also covers bytes still on their way into the slave's queue (FIONREAD does not count them).
      // Bytes that stay unread for kGone were left behind by a host that closed the port (an ack after the
      // reply it waited for): nobody will read them.
      if (now - last_activity >= kGrace && (unread == 0 || now - unread_since >= kGone)) break;
    }
    auto wait = std::chrono::milliseconds(100);
    if (!pending.empty()) {
      wait = std::min(wait, std::chrono::ceil<std::chrono::milliseconds>(pending.front().due - now));
    }
    boost::system::error_code read_error;
    const std::size_t size = pty->read_some(boost::asio::buffer(buffer), wait, read_error);
    if (read_error && read_error != transports::TransportError::timed_out) {
      if (stop) break;
      host_failed = true;
      fail("reading " + path + ": " + read_error.message());
      break;
    }
    if (size == 0) continue;
    now = Clock::now();
    framer->feed(std::span<const std::uint8_t>(buffer.data(), size), [&](transports::FramedPacket packet) {
      if (!packet.frame) return;
      last_activity = now;
      const transports::ReplayRequest request = rules->classify(view(packet.bytes));
      if (request.kind == transports::ReplayRequest::Kind::request) {
        ++requests;
        if (next < steps.size() && request.key == steps[next].key) {
          rules->matched(view(steps[next].request), view(packet.bytes));
          // What the previous steps still hold came before this request's answers in the recording.
          while (!pending.empty()) {
            play(*pending.front().frame);
            pending.pop_front();
          }
          schedule(steps[next], now);
          ++next;
          return;
        }
        const std::string expected =
            next < steps.size()
                ? in_quotes(steps[next].key) + " (recorded request " + std::to_string(next) + " of " +
                      std::to_string(steps.size() - 1) + ", at " +
                      std::to_string((steps[next].at_us - first) / 1000) + " ms)"
                : "nothing (the recording has no more requests)";
        std::fprintf(stderr, "tether replay: request %zu does not match the recording: expected %s, got %s\n",
                     requests, expected.c_str(), in_quotes(request.key).c_str());
      }
      for (const Bytes& answer : rules->answer(view(packet.bytes))) send(answer);
    });
  }
  if (host_failed || write_failed) return 2;
  if (stop && !options.loop && next < steps.size()) {
    std::fprintf(stderr, "tether replay: stopped before the end of the recording: %zu of %zu requests played\n",
                 next - 1, steps.size() - 1);
  }
  return 0;
}

}  // namespace tether::cli
