// What `tether monitor` makes of a byte stream: a codec's decoder turning bytes into records (one output line
// each: frames, log lines, messages, errors, resyncs) and their text and JSON forms. Each codec's plugin
// defines its decoder (codecs/<codec>/plugin/src/<codec>_text.*) and its fuzz target runs it on random bytes.
#pragma once

#include <nlohmann/json.hpp>

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "tether/core/counters.hpp"
#include "tether/core/decode_status.hpp"
#include "tether/core/time.hpp"
#include "tether/devices/config.hpp"

namespace tether::cli {

/// Which way the decoded bytes travel. `monitor` sees the device's side only; `monitor --tap` both.
enum class Direction {
  device_to_host,  ///< what the device sends
  host_to_device,  ///< what the application sends (tap only)
};

/// `device->host` or `host->device`.
const char* to_string(Direction direction);

/// One line of output.
struct MonitorRecord {
  std::string kind;             ///< frame, log, message, forwarded, captured, undecodable, error, resync
  std::string detail;           ///< the text after the kind
  nlohmann::ordered_json json;  ///< the JSON fields after "kind"
  bool counted = false;         ///< counts towards --count (errors and resyncs do not)
};

/// `kind     detail`: the kind padded to 8 columns (the text line after the timestamp).
std::string record_text(const MonitorRecord& record);
/// `{"kind": ..., <fields>}` (the JSON line after the timestamp).
nlohmann::ordered_json record_json(const MonitorRecord& record);
/// `resync   skipped bytes to the next frame start`: what a decoder adds when its resync counter moved.
MonitorRecord resync_record();

/// Feeds `byte` to a frame decoder (`feed(byte)` -> DecodeStatus, `error()`) whose counters are `counters`:
/// appends a resync record when its resync counter moved and an `error` record (`describe(error())`) for a
/// frame it refused; true when a frame is complete (`decoder.frame()`).
template <typename Decoder, typename Describe>
bool feed_frame(Decoder& decoder, const LinkCounters& counters, std::uint8_t byte, Describe describe,
                std::vector<MonitorRecord>& records) {
  const std::uint32_t resyncs = counters.resyncs;
  const DecodeStatus status = decoder.feed(byte);
  if (counters.resyncs != resyncs) records.push_back(resync_record());
  if (status == DecodeStatus::error) {
    const char* cause = describe(decoder.error());
    records.push_back({"error", cause, {{"status", cause}}, false});
  }
  return status == DecodeStatus::frame;
}

/// A codec's receiving side, fed with one direction's bytes.
class MonitorDecoder {
 public:
  virtual ~MonitorDecoder() = default;
  /// Decodes `byte`, appending what it produced.
  virtual void feed(std::uint8_t byte, Millis now, std::vector<MonitorRecord>& records) = 0;
  /// Handles deadlines (elcano ring node).
  virtual void poll(Millis, std::vector<MonitorRecord>&) {}
  /// Bytes the protocol requires the host to send now (elcano forwarding, proxy keepalive pings).
  virtual std::string output(Millis) { return {}; }
  /// True while output is waiting for its pacing (what `output` will still return).
  virtual bool output_pending() const { return false; }
  /// When `poll`/`output` next has something to do, in ms from `now` (nothing: no deadline).
  virtual std::optional<Duration> next_wakeup(Millis) { return std::nullopt; }
  /// The decoder's counters.
  virtual LinkCounters counters() const = 0;
};

/// How a decoder takes part in the link.
struct DecoderRole {
  Direction direction = Direction::device_to_host;  ///< whose bytes it decodes (proxy: the schema side)
  /// Elcano: act as the host's ring node (capture, forward what is not captured). False: only decode (a tap
  /// forwards the bytes themselves).
  bool ring_node = true;
  /// Proxy primary mode: produce a Ping every second as output.
  bool keepalive = false;
};

/// The decoder of `config`'s codec (and its options: proxy mode, elcano generation and capture) for `role`:
/// its row's `monitor_decoder` (codec_commands.hpp); null when the codec has none.
std::unique_ptr<MonitorDecoder> make_monitor_decoder(const devices::DeviceConfig& config, const DecoderRole& role,
                                                     Millis now);

}  // namespace tether::cli
