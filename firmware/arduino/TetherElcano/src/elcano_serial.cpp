// ElcanoSerial API on Tether's ring node: see ElcanoSerial.h.
#include "ElcanoSerial.h"

namespace elcano {

namespace {

using tether::elcano::Message;
using tether::elcano::Error;
using tether::elcano::RingEvent;
using tether::elcano::Type;

tether::elcano::RingNodeConfig node_config() {
  tether::elcano::RingNodeConfig config;
  config.generation = tether::elcano::Generation::b;
  config.pacing.baud = baudrate;
  return config;
}

bool to_message(const SerialData& data, Message& message) {
  switch (data.kind) {
    case MsgType::drive: message.type = Type::drive; break;
    case MsgType::sensor: message.type = Type::sensor; break;
    case MsgType::goal: message.type = Type::goal; break;
    case MsgType::seg: message.type = Type::segment; break;
    default: return false;
  }
  message.number = data.number;
  message.speed = data.speed_cmPs;
  message.angle = data.angle_deg;
  message.bearing = data.bearing_deg;
  message.east = data.posE_cm;
  message.north = data.posN_cm;
  message.probability = data.probability;
  return tether::elcano::has_required_fields(message);
}

// `fields` (tether::elcano::field_bits): the fields of `message` that may hold a value; the others are
// unset, so NaN is stored without reading them (a drive carries two of the seven).
void from_message(const Message& message, uint8_t fields, SerialData& data) {
  namespace bits = tether::elcano::field_bits;
  if (fields == (bits::speed | bits::angle)) {  // a drive with its own fields only: the usual capture
    data.kind = MsgType::drive;
    data.number = NaN;
    data.speed_cmPs = message.speed;
    data.angle_deg = message.angle;
    data.bearing_deg = NaN;
    data.posE_cm = NaN;
    data.posN_cm = NaN;
    data.probability = NaN;
    return;
  }
  switch (message.type) {
    case Type::drive: data.kind = MsgType::drive; break;
    case Type::sensor: data.kind = MsgType::sensor; break;
    case Type::goal: data.kind = MsgType::goal; break;
    case Type::segment: data.kind = MsgType::seg; break;
  }
  data.number = message.number;
  data.speed_cmPs = message.speed;
  data.angle_deg = message.angle;
  data.bearing_deg = message.bearing;
  data.posE_cm = message.east;
  data.posN_cm = message.north;
  data.probability = message.probability;
}

ParseStateError from_read_error(Error error) {
  switch (error) {
    case Error::success: return ParseStateError::success;
    case Error::bad_type: return ParseStateError::bad_type;
    case Error::bad_lcurly: return ParseStateError::bad_lcurly;
    case Error::bad_attrib: return ParseStateError::bad_attrib;
    case Error::bad_number: return ParseStateError::bad_number;
    case Error::inval_comb: return ParseStateError::inval_comb;
    case Error::bad_crc: return ParseStateError::bad_crc;
    case Error::too_long: return ParseStateError::too_long;
    case Error::timed_out: return ParseStateError::timed_out;
    case Error::queue_full: return ParseStateError::queue_full;
  }
  return ParseStateError::bad_type;
}

}  // namespace

void SerialData::clear() { *this = SerialData(); }

bool SerialData::verify() const {
  Message message;
  return to_message(*this, message);
}

bool SerialData::write(Print* device) const {
  Message message;
  if (device == nullptr || !to_message(*this, message)) return false;
  uint8_t text[96];
  const tether::Result<size_t> written =
      tether::elcano::encode_message(message, tether::elcano::Generation::b, tether::MutableByteView(text, sizeof text));
  if (!written.ok()) return false;
  return device->write(text, written.value()) == written.value();
}

ParseState::ParseState() : node_(node_config(), millis(), link_counters_, ring_counters_) {}

ParseStateError ParseState::update() {
  const tether::Millis now = millis();
  node_.set_capture(tether::elcano::TypeSet::from_bits(static_cast<uint8_t>(capture)));
  ParseStateError result = ParseStateError::unavailable;
  while (result == ParseStateError::unavailable) {
    // Up to and including the byte that completes something; the rest waits for the next update(): in
    // the core's receive ring (the HardwareSerial path reads it in place), or in received_.
    tether::ByteView run;
    HardwareSerial* const ring = input.ring();
    const bool copied = received_next_ != received_end_ || ring == nullptr;
    if (copied) {
      if (received_next_ == received_end_) {
        // Every byte waiting (up to the chunk) in one go, then the node takes them as a run: a call per
        // byte into the node was most of a forwarded byte's cost.
        const uint8_t count = input.read_run(received_, sizeof received_);
        if (count == 0) break;
        received_next_ = 0;
        received_end_ = count;
      }
      run = tether::ByteView(received_ + received_next_, static_cast<size_t>(received_end_ - received_next_));
    } else {
#if TETHER_ARDUINO_SERIAL_RINGS
      const uint8_t* data;
      const uint8_t count = tether::arduino::rx_run(*ring, data);
      if (count == 0) break;
      run = tether::ByteView(data, count);
#endif
    }
    size_t used = 0;
    const RingEvent::Kind kind = node_.consume(run, now, used);
    if (copied) {
      received_next_ = static_cast<uint8_t>(received_next_ + used);
    } else {
#if TETHER_ARDUINO_SERIAL_RINGS
      tether::arduino::rx_consume(*ring, static_cast<uint8_t>(used));
#endif
    }
    switch (kind) {
      case RingEvent::Kind::none: break;
      case RingEvent::Kind::captured:
        if (dt != nullptr) from_message(node_.message(), node_.message_fields(), *dt);
        result = ParseStateError::success;
        break;
      case RingEvent::Kind::forwarded: result = ParseStateError::passthru; break;
      case RingEvent::Kind::undeliverable: result = ParseStateError::undeliverable; break;
      case RingEvent::Kind::dropped: result = from_read_error(node_.error()); break;
    }
  }
  for (;;) {
    const RingEvent event = node_.poll(now);
    if (event.kind == RingEvent::Kind::none) break;
    if (result == ParseStateError::unavailable && event.kind == RingEvent::Kind::dropped) {
      result = from_read_error(event.error);
    }
  }
  pump(now);
  return result;
}

bool ParseState::write(const SerialData& data) {
  Message message;
  if (!to_message(data, message)) return false;
  const tether::Millis now = millis();
  if (node_.originate(message, now) != tether::Status::ok) return false;
  pump(now);
  return true;
}

void ParseState::pump(tether::Millis now) {
  if (node_.pending_output() == 0 || output == nullptr) return;  // usually nothing is pending
  const int room = output->availableForWrite();
  if (room <= 0) return;
  uint8_t chunk[32];
  const size_t size = static_cast<size_t>(room) < sizeof chunk ? static_cast<size_t>(room) : sizeof chunk;
  const size_t count = node_.take_output(tether::MutableByteView(chunk, size), now);
  if (count != 0) output->write(chunk, count);
}

}  // namespace elcano
