/// @file capture_replay.hpp
/// How a recorded device is played back to a live host (`tether replay FILE --as-device`, docs/captures.md):
/// a codec's rules for which recorded request a live host frame is, and how the recorded answers are
/// rewritten for the live host (its ids, the CRCs over them). Sans-I/O: whole frames in (as the codec's
/// capture framing cuts them, capture_framing.hpp), whole frames out; the player that reads the capture,
/// keeps the order and the recorded delays is the command's.
///
/// A codec supplies its rules through its row of the codec table (`CodecRow::capture_replay`,
/// devices/codecs.hpp); one replayer per played link, used from one thread.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

namespace tether::transports {

/// What a host-to-device frame is to the played device.
struct ReplayRequest {
  /// How the player treats it.
  enum class Kind {
    request,    ///< A request: matched against the next recorded one by `key`.
    keepalive,  ///< Answered at once by `CaptureReplayer::answer` whenever it comes (a proxy ping), never matched.
    other,      ///< Nothing to match (a damaged frame): a recorded one is skipped, a live one gets `answer`.
  };
  Kind kind = Kind::other;
  /// What a live request must equal to be the recorded one: the frame without the fields the replay
  /// rewrites (ids, CRCs), printable (the player quotes it when a request does not match: `a[1]`).
  std::string key;
};

/// One played device's rules (see the file overview).
class CaptureReplayer {
 public:
  virtual ~CaptureReplayer() = default;
  /// What `frame` (host to device, recorded or live) is.
  virtual ReplayRequest classify(std::span<const std::uint8_t> frame) = 0;
  /// The live frame `live` matched the recorded request `recorded`: answers recorded for `recorded` go to
  /// `live` from now on (its id).
  virtual void matched(std::span<const std::uint8_t> recorded, std::span<const std::uint8_t> live) = 0;
  /// A recorded device-to-host frame as the live host expects it (ids of the live requests, CRCs
  /// recomputed); unchanged when nothing in it refers to a request (a log line), or when it is damaged (the
  /// damage is played too). Nothing: it answers a request the live host did not send (a recorded keepalive,
  /// whose live counterpart got its own answer).
  virtual std::optional<std::vector<std::uint8_t>> rewrite(std::span<const std::uint8_t> recorded) = 0;
  /// What the device answers to a live keepalive, or to a live frame that matched no recorded request (what
  /// the codec's device answers to an unknown or damaged request; none where it answers nothing).
  virtual std::vector<std::vector<std::uint8_t>> answer(std::span<const std::uint8_t> live) = 0;
};

}  // namespace tether::transports
