/// @file ElcanoSerial.h
/// The ElcanoSerial API that ring sketches use today, on Tether's ring node (codecs/elcano, docs/elcano.md):
/// a sketch written for ElcanoSerial builds with this header; its node then also drops its own messages
/// when they come back round (nobody captured them), drops a message stalled half-way (250 ms) instead of
/// waiting for ever, and paces what it writes so the next Uno's 64-byte receive buffer never overflows.
///
///     elcano::ParseState ps;
///     elcano::SerialData dt;
///     void setup() {
///       Serial.begin(elcano::baudrate);
///       ps.dt = &dt; ps.input = &Serial; ps.output = &Serial;   // an Uno: one UART, RX from the previous
///       ps.capture = elcano::MsgType::drive;                     // node, TX to the next
///       dt.clear();
///     }
///     void loop() { if (ps.update() == elcano::ParseStateError::success) { /* use dt */ } }
///
/// Wire: generation B (`D{s 50}{a 25}\n`). What changes from the reference: `ps.write(data)` originates a
/// message through the node (paced, recognised when it comes back) where the reference sketch wrote
/// `data.write(&Serial)` (which still works: it writes at once, unpaced and untracked); `update()` never
/// blocks and returns one outcome per call (`unavailable` when no byte completed anything), plus Tether's
/// outcomes below; `input` is any `Stream`, `output` any `Print` that reports `availableForWrite()`
/// (HardwareSerial does).
#pragma once

#include <Arduino.h>
#include <TetherCore.h>  // first: the Arduino builder finds the TetherCore library by this name

#include "TetherArduinoStream.h"
#include "TetherSetArduinoMacrosAside.h"  // Arduino.h's bit, min, max, ... would rewrite Tether's names
#include "tether/core/counters.hpp"
#include "tether/elcano/ring_node.hpp"
#include "TetherRestoreArduinoMacros.h"

namespace elcano {

/// Ring line speed (Tether's default; the reference's first rings ran at 9600, `Serial.begin` any rate).
const uint32_t baudrate = 115200;
/// The reference's "no value" of a field (int32 0x7FFFFFFF): not written, not required.
const int32_t NaN = 0x7FFFFFFF;

/// Message types, as capture bits (combine with `|`).
enum class MsgType : uint8_t { none = 0, drive = 1, sensor = 2, goal = 4, seg = 8 };
/// Both sets of types.
inline MsgType operator|(MsgType a, MsgType b) {
  return static_cast<MsgType>(static_cast<uint8_t>(a) | static_cast<uint8_t>(b));
}

/// Outcome of `ParseState::update()`: the reference's names first, then Tether's.
enum class ParseStateError : int8_t {
  success = 0,    ///< A captured message is in `*dt`.
  inval_comb,     ///< A message lacked a field its type requires (dropped).
  bad_number,     ///< Malformed number (dropped).
  bad_attrib,     ///< Unknown attribute letter (dropped).
  bad_lcurly,     ///< `{` expected (dropped).
  bad_type,       ///< Not a message header (skipped).
  unavailable,    ///< Nothing completed: no byte, or a message still arriving.
  passthru,       ///< A message of another type went on to the next node.
  undeliverable,  ///< Tether: one of this node's messages came back (nobody captured it); dropped.
  too_long,       ///< Tether: longer than a message can be (dropped).
  timed_out,      ///< Tether: a message stalled half-way for 250 ms (dropped).
  queue_full,     ///< Tether: no room to forward (the next node is not reading); dropped.
  bad_crc,        ///< Tether: generation D checksum mismatch (not used in generation B).
};

/// One message's fields (the reference's names). Unset fields hold `NaN`.
struct SerialData {
  MsgType kind = MsgType::none;  ///< drive, sensor, goal or seg.
  int32_t number = NaN;          ///< `n` (goal, segment).
  int32_t speed_cmPs = NaN;      ///< `s` (drive, sensor, segment).
  int32_t angle_deg = NaN;       ///< `a` (drive, sensor).
  int32_t bearing_deg = NaN;     ///< `b` (sensor, goal, segment).
  int32_t posE_cm = NaN;         ///< `p` east (sensor, goal, segment).
  int32_t posN_cm = NaN;         ///< `p` north.
  int32_t probability = NaN;     ///< `r` (goal, optional).

  /// Every field unset, kind none.
  void clear();
  /// True when `kind` is a type and every field it requires is set.
  bool verify() const;
  /// Writes the message to `device` at once (the reference's way; unpaced, not tracked by a node).
  /// False when it does not verify.
  bool write(Print* device) const;
};

/// Where a node reads from: set it to any `Stream` (`ps.input = &mySerial;`). The core's hardware ports
/// (`ps.input = &Serial;`) are read through their own functions, inlined (TetherArduinoStream.h): one
/// available() per run and a few cycles a byte, where a `Stream` costs a call to its read() a byte.
class InputPort {
 public:
  InputPort() = default;
  InputPort(const InputPort&) = delete;
  InputPort& operator=(const InputPort&) = delete;
  /// Reads `stream` from now on (one of the core's hardware ports as a `Stream*`: the fast path below).
  InputPort& operator=(Stream* stream) {
    stream_ = stream;
    hardware_ = tether::arduino::core_serial(stream);
    return *this;
  }
  /// Reads the core's hardware port `serial` from now on (the fast path).
  InputPort& operator=(HardwareSerial* serial) {
    stream_ = serial;
    hardware_ = serial;
    return *this;
  }
  /// Reads nothing.
  InputPort& operator=(decltype(nullptr)) { return *this = static_cast<Stream*>(nullptr); }
  /// The stream read (null: none).
  operator Stream*() const { return stream_; }
  Stream* operator->() const { return stream_; }
  /// Takes up to `capacity` waiting bytes into `bytes`; returns how many (0 without a stream).
  uint8_t read_run(uint8_t* bytes, uint8_t capacity) const {
    return stream_ == nullptr ? 0 : tether::arduino::read_run(hardware_, *stream_, bytes, capacity);
  }
  /// The core's HardwareSerial when its receive ring can be read in place (TetherArduinoStream.h), else null.
  HardwareSerial* ring() const { return TETHER_ARDUINO_SERIAL_RINGS ? hardware_ : nullptr; }

 private:
  Stream* stream_ = nullptr;
  HardwareSerial* hardware_ = nullptr;  // stream_ when it is the core's HardwareSerial
};

/// A ring node: reads `input`, hands captured messages to `*dt`, forwards the rest to `output`.
class ParseState {
 public:
  ParseState();
  ParseState(const ParseState&) = delete;
  ParseState& operator=(const ParseState&) = delete;

  SerialData* dt = nullptr;         ///< Where a captured message goes.
  InputPort input;                  ///< Bytes from the previous node (any `Stream`; `&Serial` is the fast path).
  Print* output = nullptr;          ///< Bytes to the next node.
  MsgType capture = MsgType::none;  ///< Types this node consumes (others are forwarded).

  /// Call from loop(): reads what `input` has until something completes, handles timers, writes paced
  /// output. Never blocks. Bytes are read up to 16 at a time (one available() each time) and handed to the node as a run; those
  /// after a completed message are kept for the next call.
  ParseStateError update();
  /// Originates `data` into the ring (paced; dropped by this node if it comes back). False when it does
  /// not verify or the output queue has no room now (call `update()` and try again).
  bool write(const SerialData& data);

  /// The node's counters: captured, forwarded, originated, undeliverable, ...
  const tether::elcano::RingCounters& counters() const { return ring_counters_; }
  /// Read errors and timeouts of the input.
  const tether::LinkCounters& link_counters() const { return link_counters_; }

 private:
  void pump(tether::Millis now);

  tether::LinkCounters link_counters_;
  tether::elcano::RingCounters ring_counters_;
  tether::elcano::RingNode<96, 256, 4> node_;
  // Bytes read from `input` that the node has not taken yet (it stops at each completed message, and
  // update() reports one event at a time): received_[received_next_, received_end_).
  uint8_t received_[16];
  uint8_t received_next_ = 0;
  uint8_t received_end_ = 0;
};

}  // namespace elcano
