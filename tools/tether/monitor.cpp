// `tether monitor DEVICE [options]`: decodes and prints everything a device sends, one line per frame or
// message, damaged frames and resynchronisations included, with timestamps.
//
// It reads the device's byte stream with the codec's portable decoder (no client: no session, no Reset,
// no pings), so it is passive: romi and proxy devices get nothing at all (proxy: unless --keepalive); an
// Elcano ring gets what a ring node must send, every message the host does not capture, forwarded.
//
// With --tap it sits between an application and the device instead: it opens the device, makes a new pty
// for the application (printed as `PTY /dev/pts/N`, like `tether sim`), passes every byte both ways
// unchanged and decodes both directions. Two pump threads (one per direction) read with a short deadline,
// decode and print, then write the bytes on; the main thread waits for the end.
//
// Output contract: one line per event on stdout, `<time> <kind> <detail>` (tap: `<time> <direction> <kind>
// <detail>`); with --json one JSON object per line instead. Exit status: 0 when --count or --duration is
// reached or on SIGINT/SIGTERM; 2 for usage errors, a device that cannot be opened, or a link that fails
// (the device went away).
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <thread>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "monitor_decoding.hpp"
#include "tether/transports/io_thread.hpp"
#include "tether/transports/pty_stream.hpp"
#include "tether/transports/serial_port_stream.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::cli {

namespace {

namespace asio = boost::asio;

const CommandText& monitor_command() {
  static const CommandText text(
      "monitor",
      std::string(
          "usage: tether monitor DEVICE [--tap] [--utc] [--json] [--count N] [--duration S] [--keepalive]\n"
          "\n"
          "Decodes and prints everything the device sends, one line per frame or message, with a timestamp\n"
          "(milliseconds since the start, or ISO 8601 UTC with --utc): romi responses and log lines, proxy\n"
          "messages (ArduinoOut of the mode's schema), Elcano messages; and what the decoder dropped (CRC\n"
          "errors, malformed or oversize frames, undecodable payloads) and each resynchronisation:\n"
          "  12.345 frame    e[0,1,2] id 07\n"
          "  13.001 log      motor: ready\n"
          "  20.500 error    -4 crc mismatch (opcode e, id 08)\n"
          "  20.512 resync   skipped bytes to the next frame start\n"
          "\n"
          "Passive: it opens the device's byte stream without a client, so romi and proxy devices receive\n"
          "nothing (a proxy device in primary mode fails safe after 10 s without pings; --keepalive sends it a\n"
          "Ping every second, whose acks then show up). An Elcano ring receives what the protocol requires of\n"
          "the host's node: every message it does not capture (--capture; default none) is forwarded to the\n"
          "next board, paced, exactly as `RingClient` would, and shown as `forwarded`.\n"
          "\n"
          "Watching a live session: the monitor must not read the port an application reads (both would get\n"
          "a share of the bytes). Use --tap: it opens the device, creates a pseudo-terminal for the application\n"
          "and prints `PTY /dev/pts/N` (with --json {\"pty\":\"/dev/pts/N\"}) once ready; point the application\n"
          "at that path. Every byte passes through unchanged, both directions are decoded, and each line says\n"
          "which way it went:\n"
          "  12.345 host->device frame    e id 07\n"
          "  12.351 device->host frame    e[0,1,2] id 07\n"
          "(JSON: \"direction\":\"host->device\"). On an Elcano ring the tap only decodes: the application is\n"
          "the host's node.\n"
          "\n") +
      device_usage() +
      "\n"
      "  --utc          ISO 8601 UTC wall-clock timestamps instead of milliseconds since the start\n"
      "  --json         one JSON object per line: {\"t_ms\":12.345,\"kind\":\"frame\",...} (\"time\" with --utc)\n"
      "  --count N      stop after N frames or messages (log lines included; errors and resyncs not counted)\n"
      "  --duration S   stop after S seconds (decimals allowed)\n"
      "  --keepalive    proxy primary mode: send a Ping every second (the only thing monitor then sends)\n"
      "  --tap          pass an application's session through a new pty and decode both directions\n"
      "  --write FILE   record the session into FILE (pcapng), as --record FILE does (see recording above)\n"
      "\n"
      "Runs until --count, --duration, SIGINT or SIGTERM (exit status 0). Exit status 2: usage errors, a\n"
      "device that cannot be opened, a link that failed (the device went away).\n",
      CommandText::OnUsageError::synopsis);
  return text;
}

struct MonitorArguments {
  DeviceOptions device;
  bool utc = false;
  bool json = false;
  bool keepalive = false;
  bool tap = false;
  std::optional<std::uint32_t> count;
  std::optional<std::uint32_t> duration_ms;
};

std::optional<int> parse_monitor_arguments(int argc, char** argv, MonitorArguments& arguments) {
  const CommandText& text = monitor_command();
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--utc") {
      arguments.utc = true;
    } else if (argument == "--json") {
      arguments.json = true;
    } else if (argument == "--keepalive") {
      arguments.keepalive = true;
    } else if (argument == "--tap") {
      arguments.tap = true;
    } else if (argument == "--write") {
      // The tap's recording: the same as --record FILE.
      if (i + 1 >= argc || *argv[i + 1] == '\0') return text.usage_error("--write needs a capture file");
      arguments.device.record = argv[++i];
    } else if (argument == "--count" || argument == "--duration") {
      if (i + 1 >= argc) return text.usage_error(std::string(argument) + " needs a value");
      const std::string_view value = argv[++i];
      if (argument == "--count") {
        arguments.count = parse_number(value, 1, 0xFFFFFFFFu);
        if (!arguments.count)
          return text.usage_error("--count needs a positive number, got '" + std::string(value) + "'");
      } else {
        arguments.duration_ms = parse_seconds(value, 30.0 * 24 * 3600);
        if (!arguments.duration_ms)
          return text.usage_error("--duration needs seconds, got '" + std::string(value) + "'");
      }
    } else {
      return text.unexpected_argument(argument);
    }
    return std::nullopt;
  };
  return parse_device_arguments(argc, argv, text, arguments.device, own);
}

// Prints records, one line each, and counts them towards --count (from any thread).
class RecordPrinter {
 public:
  explicit RecordPrinter(const MonitorArguments& arguments)
      : json_(arguments.json), count_(arguments.count), stamps_(arguments.utc) {}

  /// Prints `record` (with its direction when `direction` is set); true once --count is reached.
  bool print(const MonitorRecord& record, std::optional<Direction> direction = std::nullopt) {
    if (json_) {
      nlohmann::ordered_json object;
      stamps_.add_to(object);
      if (direction) object["direction"] = to_string(*direction);
      const nlohmann::ordered_json fields = record_json(record);
      for (const auto& [key, value] : fields.items()) object[key] = value;
      out().line(dump(object));
    } else {
      out().line(stamps_.text() + " " + (direction ? std::string(to_string(*direction)) + " " : std::string()) +
                 record_text(record));
    }
    return record.counted && count_ && ++counted_ >= *count_;
  }

 private:
  bool json_;
  std::optional<std::uint32_t> count_;
  Timestamps stamps_;
  std::atomic<std::uint32_t> counted_{0};
};

Millis elapsed_ms(std::chrono::steady_clock::time_point start) {
  return static_cast<Millis>(
      std::chrono::duration_cast<std::chrono::milliseconds>(std::chrono::steady_clock::now() - start).count());
}

// --tap: the application's pty on one side, the device on the other.
int run_tap(const MonitorArguments& arguments, const DeviceTarget& target, transports::ByteStream& device,
            transports::IoThread& io) {
  boost::system::error_code error;
  const auto application = transports::PtyStream::open(io.executor(), error);
  if (!application) return monitor_command().fail("cannot open a pseudo-terminal: " + error.message());
  if (arguments.json) {
    out().line(dump({{"pty", application->slave_path()}, {"device", target.label}}));
  } else {
    out().line("PTY " + application->slave_path());
  }

  const std::atomic<bool>& stop = catch_stop_signals();
  // Ctrl-C also ends a pump blocked writing to a side that does not read.
  const StopAction close_on_stop([&device, &application] {
    device.close();
    application->close();
  });
  const auto start = std::chrono::steady_clock::now();
  const auto run_end = arguments.duration_ms ? start + std::chrono::milliseconds(*arguments.duration_ms)
                                             : std::chrono::steady_clock::time_point::max();
  // A stdout nobody reads must not outlast --duration (a stop signal ends the wait anyway).
  out().set_give_up([run_end] { return std::chrono::steady_clock::now() >= run_end; });
  RecordPrinter printer(arguments);
  std::mutex mutex;
  std::condition_variable finished;
  bool done = false;
  int status = 0;
  auto finish = [&](int exit_status) {
    const std::lock_guard lock(mutex);
    if (!done) status = exit_status;
    done = true;
    finished.notify_all();
  };
  auto is_done = [&] {
    const std::lock_guard lock(mutex);
    return done;
  };
  // Moves bytes from `from` to `to`, then decodes them as `direction`.
  auto pump = [&](transports::ByteStream& from, transports::ByteStream& to, Direction direction) {
    DecoderRole role;
    role.direction = direction;
    role.ring_node = false;
    const auto decoder = make_monitor_decoder(target.config, role, elapsed_ms(start));
    std::array<std::uint8_t, 1024> buffer{};
    std::vector<MonitorRecord> records;
    while (!is_done() && !stop) {
      boost::system::error_code read_error;
      const std::size_t size = from.read_some(asio::buffer(buffer), std::chrono::milliseconds(100), read_error);
      if (read_error == transports::TransportError::disconnected ||
          read_error == transports::TransportError::reconnected) {
        continue;  // a supervised port's outage, reported by its link handler
      }
      if (read_error && read_error != transports::TransportError::timed_out) {
        if (stop || is_done()) return;  // closed by Ctrl-C or by the other pump's end
        std::fprintf(stderr, "tether monitor: the link to %s failed: %s\n",
                     direction == Direction::device_to_host ? "the device" : "the application",
                     read_error.message().c_str());
        finish(2);
        return;
      }
      if (size == 0) continue;
      // Printed before passed on: the other side cannot answer a frame before its line is out, so the lines
      // of the two pumps come in the order things happened.
      const Millis now = elapsed_ms(start);
      for (std::size_t i = 0; i < size; ++i) decoder->feed(buffer[i], now, records);
      for (const MonitorRecord& record : records) {
        if (printer.print(record, direction)) finish(0);
      }
      records.clear();
      boost::system::error_code write_error;
      write_to_device(to, asio::buffer(buffer.data(), size), write_error, run_end);
      if (direction == Direction::host_to_device && (write_error == transports::TransportError::disconnected ||
                                                     write_error == transports::TransportError::reconnected)) {
        // The device's supervised port is away: what the application sends meanwhile is lost, as on a wire
        // to an unplugged board, and the tap stays up for when the port is back.
        std::fprintf(stderr, "tether monitor: %zu bytes from the application dropped: the device's port is away\n",
                     size);
        continue;
      }
      if (write_error) {
        if (stop || is_done() || std::chrono::steady_clock::now() >= run_end) {  // stopped, or --duration is up
          finish(0);
          return;
        }
        std::fprintf(stderr, "tether monitor: the link to %s failed: %s\n",
                     direction == Direction::device_to_host ? "the application" : "the device",
                     write_error.message().c_str());
        finish(2);
        return;
      }
    }
  };
  std::thread to_host([&] { pump(device, *application, Direction::device_to_host); });
  std::thread to_device([&] { pump(*application, device, Direction::host_to_device); });
  {
    std::unique_lock lock(mutex);
    const auto deadline = run_end;
    // Woken by the pumps; the 100 ms steps notice a stop signal (a handler cannot notify).
    while (!done && !stop && std::chrono::steady_clock::now() < deadline) {
      const std::chrono::steady_clock::duration left = deadline - std::chrono::steady_clock::now();
      finished.wait_for(lock, std::min<std::chrono::steady_clock::duration>(std::chrono::milliseconds(100), left));
    }
    done = true;
  }
  to_host.join();
  to_device.join();
  application->close();
  device.close();
  return status;
}

}  // namespace

int run_monitor(int argc, char** argv) {
  MonitorArguments arguments;
  if (const auto status = parse_monitor_arguments(argc, argv, arguments)) return *status;
  std::string error;
  const auto target = resolve_device(arguments.device, default_codec(), error);
  if (!target) return monitor_command().usage_error(error);
  const CodecCommands& commands = *codec_commands(target->config.codec);
  if (!commands.monitor_decoder) {
    return monitor_command().usage_error(target->label + ": the monitor cannot decode " +
                                      std::string(devices::to_string(target->config.codec)));
  }
  if (arguments.keepalive && !commands.monitor_keepalive) {
    return monitor_command().usage_error("--keepalive applies to the proxy codec (primary mode) only");
  }
  if (arguments.keepalive && arguments.tap) {
    return monitor_command().usage_error("--keepalive and --tap exclude each other (the application pings)");
  }

  transports::IoThread io;
  Progress progress("monitor");
  auto stream = open_stream(*target, io.executor(), progress, error);
  if (!stream) return monitor_command().fail(target->label + ": " + error);
  // However the monitor ends, the capture file is complete, and a recording that lost packets says so.
  const auto recording = std::dynamic_pointer_cast<transports::RecordingStream>(stream);
  const EndRecording end_recording(recording, "monitor");
  if (const auto port = std::dynamic_pointer_cast<transports::SerialPortStream>(recording ? recording->inner() : stream);
      port && port->options().reconnect.enabled) {
    port->add_link_handler([](const transports::LinkEvent& event) {
      if (event.kind == transports::LinkEvent::Kind::up) {
        std::fprintf(stderr, "tether monitor: link up after %lld ms (%s)\n",
                     static_cast<long long>(event.down_for.count()), event.path.c_str());
      } else {
        std::fprintf(stderr, "tether monitor: link %s: %s\n", transports::to_string(event.kind), event.reason.c_str());
      }
    });
  }
  if (arguments.tap) return run_tap(arguments, *target, *stream, io);

  const std::atomic<bool>& stop = catch_stop_signals();
  // Ctrl-C also ends a write blocked on a device that does not read.
  const StopAction close_on_stop([&stream] { stream->close(); });

  const auto start = std::chrono::steady_clock::now();
  const auto run_end = arguments.duration_ms ? start + std::chrono::milliseconds(*arguments.duration_ms)
                                             : std::chrono::steady_clock::time_point::max();
  // A stdout nobody reads must not outlast --duration (a stop signal ends the wait anyway).
  out().set_give_up([run_end] { return std::chrono::steady_clock::now() >= run_end; });
  auto now_ms = [&] { return elapsed_ms(start); };
  DecoderRole role;
  role.keepalive = arguments.keepalive;
  const std::unique_ptr<MonitorDecoder> decoder = make_monitor_decoder(target->config, role, now_ms());

  RecordPrinter printer(arguments);
  int status = 0;
  std::array<std::uint8_t, 1024> buffer{};
  std::vector<MonitorRecord> records;

  bool done = false;
  while (!done && !stop) {
    const Millis now = now_ms();
    // Whatever the protocol requires us to send (elcano forwarding, keepalive pings).
    decoder->poll(now, records);
    for (std::string bytes = decoder->output(now); !bytes.empty(); bytes = decoder->output(now_ms())) {
      boost::system::error_code write_error;
      write_to_device(*stream, asio::buffer(bytes), write_error, run_end);
      if (write_error) {
        done = true;
        if (stop || std::chrono::steady_clock::now() >= run_end) break;  // stopped, or --duration is up
        std::fprintf(stderr, "tether monitor: the link failed: %s%s\n", write_error.message().c_str(),
                     write_error == transports::TransportError::timed_out ? " (the device does not read)" : "");
        status = 2;
        break;
      }
    }
    // Wait for bytes at most until the next deadline (and 100 ms, to notice a stop signal).
    Duration wait = 100;
    if (const auto wakeup = decoder->next_wakeup(now)) wait = std::min<Duration>(wait, std::max<Duration>(*wakeup, 1));
    if (arguments.duration_ms) {
      const auto elapsed = std::chrono::steady_clock::now() - start;
      const auto left = std::chrono::milliseconds(*arguments.duration_ms) -
                        std::chrono::duration_cast<std::chrono::milliseconds>(elapsed);
      if (left.count() <= 0) break;
      wait = std::min<Duration>(wait, static_cast<Duration>(left.count()));
    }
    std::size_t size = 0;
    if (!done) {
      boost::system::error_code read_error;
      size = stream->read_some(asio::buffer(buffer), std::chrono::milliseconds(wait), read_error);
      if (read_error == transports::TransportError::disconnected ||
          read_error == transports::TransportError::reconnected) {
        // A supervised port's outage (its link handler below says why and for how long): read on.
        read_error.clear();
      }
      if (read_error && read_error != transports::TransportError::timed_out) {
        if (stop) break;  // closed by Ctrl-C
        std::fprintf(stderr, "tether monitor: the link failed: %s\n", read_error.message().c_str());
        status = 2;
        done = true;
      }
    }
    const Millis fed_at = now_ms();
    for (std::size_t i = 0; i < size; ++i) decoder->feed(buffer[i], fed_at, records);
    for (const MonitorRecord& record : records) {
      if (printer.print(record)) {
        done = true;
        break;
      }
    }
    records.clear();
  }
  // Messages already accepted for forwarding still leave (paced), so stopping does not cut the ring.
  const auto flush_limit = std::chrono::steady_clock::now() + std::chrono::seconds(1);
  while (status == 0 && !stop && decoder->output_pending() && std::chrono::steady_clock::now() < flush_limit) {
    const std::string bytes = decoder->output(now_ms());
    boost::system::error_code write_error;
    if (!bytes.empty()) write_to_device(*stream, asio::buffer(bytes), write_error, flush_limit);
    if (write_error) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  stream->close();
  return status;
}

}  // namespace tether::cli
