// Primary-mode proxy device: see tether/proxy/device/proxy_device.hpp for the wire behaviour.
#include "tether/proxy/device/proxy_device.hpp"

#include <stddef.h>
#include <string.h>

#include <pb_decode.h>

#include "tether/core/crc.hpp"
#include "tether/core/execution_witness.hpp"
#include "tether/proxy/device/text.hpp"
#include "tether_proxy.pb.h"

namespace tether {
namespace proxy {
namespace device {

static_assert(tether_proxy_ArduinoOut_size <= kMaxOutPayload, "an ArduinoOut must fit the send buffer");
static_assert(tether_proxy_ArduinoIn_size <= ProxyDevice::kMaxPayload, "an ArduinoIn must fit the decoder");

namespace {

// The texts of Error messages, in flash on the AVR.
const char kDecodeError[] TETHER_IN_FLASH = "decode error";
const char kUnknownMessage[] TETHER_IN_FLASH = "unknown message";
const char kPingFailsafe[] TETHER_IN_FLASH = "ping failsafe";
const char kServoOnPin[] TETHER_IN_FLASH = "servo on pin ";
const char kD9D10Only[] TETHER_IN_FLASH = ": D9/D10 only";
const char kPin[] TETHER_IN_FLASH = "pin ";
const char kPosition[] TETHER_IN_FLASH = ": position ";
const char kMinus[] TETHER_IN_FLASH = "-";
const char kNotIn0180[] TETHER_IN_FLASH = " not in 0..180";
const char kDoesNotExist[] TETHER_IN_FLASH = " does not exist";
const char kIsTheUart[] TETHER_IN_FLASH = " is the UART";
const char kNotInitialised[] TETHER_IN_FLASH = " not initialised";
const char kIsNotAServo[] TETHER_IN_FLASH = " is not a servo";
const char kIsNotDigital[] TETHER_IN_FLASH = " is not digital";

// The drop report, "dropped: crc N cobs N long N stall N": each label with the counter it shows, walked
// by one loop (four text + number calls cost ~150 B more flash).
struct DropField {
  char label[14];
  uint8_t counter;  // offset of the uint32_t counter in LinkCounters
};
const DropField kDropFields[] TETHER_IN_FLASH = {
    {"dropped: crc ", offsetof(LinkCounters, crc_errors)},
    {" cobs ", offsetof(LinkCounters, framing_errors)},
    {" long ", offsetof(LinkCounters, oversize_frames)},
    {" stall ", offsetof(LinkCounters, partial_timeouts)},
};
constexpr uint8_t kDropFieldCount = sizeof(kDropFields) / sizeof(kDropFields[0]);

uint32_t drop_count(const LinkCounters& link, uint8_t field) {
  uint32_t count;
  memcpy(&count, reinterpret_cast<const uint8_t*>(&link) + read_flash_byte(&kDropFields[field].counter),
         sizeof(count));
  return count;
}

// What a refused pin message's Error says after the pin number.
const char* refusal_text(PinResult result, bool servo) {
  switch (result) {
    case PinResult::no_such_pin:
      return kDoesNotExist;
    case PinResult::uart_pin:
      return kIsTheUart;
    case PinResult::not_servo_pin:
      return kD9D10Only;
    case PinResult::not_initialised:
      return kNotInitialised;
    case PinResult::out_of_range:
      return kPosition;
    default:  // wrong_kind
      return servo ? kIsNotAServo : kIsNotDigital;
  }
}

tether_proxy_ArduinoOut out_message(pb_size_t which) {
  tether_proxy_ArduinoOut out = tether_proxy_ArduinoOut_init_zero;
  out.which_data = which;
  return out;
}

// An Error{WARNING} message whose text the caller builds.
struct ErrorOut {
  ErrorOut() : message(out_message(tether_proxy_ArduinoOut_error_tag)),
               text(message.data.error.text, sizeof(message.data.error.text)) {
    message.data.error.level = tether_proxy_Error_Level_WARNING;
  }
  tether_proxy_ArduinoOut message;
  TextBuilder text;
};

}  // namespace

void ProxyDevice::begin(uint32_t session_id, Millis now) {
  session_id_ = session_id;
  watchdog_.start(now);
  next_info_.arm(now, kInfoPeriodMs);
  send_word(tether_proxy_ArduinoOut_resetEvent_tag, session_id, false);
}

void ProxyDevice::handle_byte(uint8_t byte, Millis now) {
  // The decoder's per-byte path (handle_bytes takes runs): the two are tested against each other.
  const bool was_in_frame = decoder_.in_frame();
  const DecodeStatus status = decoder_.feed(byte);
  track_frame(was_in_frame, now);
  if (status == DecodeStatus::frame) handle_payload(decoder_.frame(), decoder_.checksum(), now);
}

size_t ProxyDevice::handle_bytes(const uint8_t* data, size_t size, Millis now) {
  const ByteView bytes(data, size);
  // One feed stops at the first frame or error, so the frame state changes at most once in it: started,
  // or ended (a frame both started and ended inside the run leaves the deadline as it was: disarmed).
  const bool was_in_frame = decoder_.in_frame();
  const FeedResult fed = decoder_.feed(bytes);
  track_frame(was_in_frame, now);
  if (fed.status == DecodeStatus::frame) handle_payload(decoder_.frame(), decoder_.checksum(), now);
  return fed.consumed;
}

void ProxyDevice::track_frame(bool was_in_frame, Millis now) {
  const bool in_frame = decoder_.in_frame();
  if (!was_in_frame && in_frame) {
    partial_.on_frame_start(now);
  } else if (was_in_frame && !in_frame) {
    partial_.on_frame_end();
  }
}

void ProxyDevice::poll(Millis now) {
  if (partial_.poll(now)) {
    // Drop the stalled frame; the decoder takes the next byte as a frame's first (code) byte, so a host
    // that sends no leading 0x00 loses only the stalled frame, not the next one too.
    decoder_.restart();
  }
  watchdog_.poll(now);  // before ArduinoInfo: an info due in the same poll shows the flag
  if (next_info_.expired(now)) {
    send_word(tether_proxy_ArduinoOut_info_tag, session_id_, watchdog_.triggered());
    report_drops();
    next_info_.arm(next_info_.at(), kInfoPeriodMs);
    if (next_info_.expired(now)) next_info_.arm(now, kInfoPeriodMs);  // fell behind: no burst
  }
}

// Out of line and unspecialised: it reaches the device through `this` (2-byte Y+q accesses) instead of
// the image's absolute addresses of its static device (4-byte lds/sts) once inlined into main (-18 B).
__attribute__((noinline, noclone)) void ProxyDevice::handle_payload(ByteView payload, uint16_t fingerprint, Millis now) {
  tether_proxy_ArduinoIn in = tether_proxy_ArduinoIn_init_zero;
  pb_istream_t stream = pb_istream_from_buffer(payload.data(), payload.size());
  if (!pb_decode(&stream, tether_proxy_ArduinoIn_fields, &in)) {
    add_one(counters_.decode_errors);
    send_error(FlashText{kDecodeError});
    return;
  }
  const uint32_t id = in.messageId;
  if (executed_.check(id, fingerprint).duplicate) {
    send_word(tether_proxy_ArduinoOut_ack_tag, id, false);  // a re-send: ack again, execute nothing
    return;
  }
  add_one(counters_.executed);
  const uint32_t refused_before = counters_.refused;
  bool restart = false;
  switch (in.which_data) {
    case tether_proxy_ArduinoIn_ping_tag:
      watchdog_.on_heartbeat(now);
      break;
    case tether_proxy_ArduinoIn_servoInit_tag: {
      const tether_proxy_ServoInit& init = in.data.servoInit;
      report_pin_result(outputs_->init_servo(init.pin, init.safePosition), init.pin, true, init.safePosition);
      break;
    }
    case tether_proxy_ArduinoIn_servoControl_tag: {
      const tether_proxy_ServoControl& control = in.data.servoControl;
      const PinResult result = outputs_->control_servo(control.pin, control.position);
      // Witness key: pin, position (tether/core/execution_witness.hpp; read back by `tether demo`).
      if (result == PinResult::ok) {
        witness_executed(witness_key(static_cast<uint16_t>(control.pin), static_cast<uint16_t>(control.position)));
      }
      report_pin_result(result, control.pin, true, control.position);
      break;
    }
    case tether_proxy_ArduinoIn_digitalInit_tag: {
      const tether_proxy_DigitalInit& init = in.data.digitalInit;
      report_pin_result(outputs_->init_digital(init.pin, init.safeState), init.pin, false, 0);
      break;
    }
    case tether_proxy_ArduinoIn_digitalControl_tag: {
      const tether_proxy_DigitalControl& control = in.data.digitalControl;
      report_pin_result(outputs_->control_digital(control.pin, control.state), control.pin, false, 0);
      break;
    }
    case tether_proxy_ArduinoIn_reset_tag:
      restart = true;
      break;
    case tether_proxy_ArduinoIn_pingFailsafeReset_tag:
      watchdog_.clear_triggered();
      break;
    default:
      add_one(counters_.refused);
      send_error(FlashText{kUnknownMessage});
      break;
  }
  const bool refused = counters_.refused != refused_before;
  // Only what took effect is remembered: a re-send of a refused message is looked at again (it may run now
  // that its pin was initialised), and its ack still says whether it ran.
  if (!refused) executed_.remember(id, fingerprint, ByteView());
  send_word(tether_proxy_ArduinoOut_ack_tag, id, refused);
  if (restart && restart_ != nullptr) restart_(restart_context_);  // on the AVR: flush, reset, no return
}

void ProxyDevice::on_failsafe(void* self, Millis) {
  ProxyDevice& device = *static_cast<ProxyDevice*>(self);
  device.outputs_->drive_safe();
  device.send_error(FlashText{kPingFailsafe});
  for (uint8_t pin = 0; pin < kPinCount; ++pin) {
    if (device.outputs_->initialised(pin)) device.send_pin_state(pin, true);
  }
}

bool ProxyDevice::send(const void* out_message, bool leading_delimiter) {
  if (send_message(sink_, Integrity::crc16, leading_delimiter, tether_proxy_ArduinoOut_fields, out_message)) {
    return true;
  }
  add_one(counters_.send_failures);
  return false;
}

// Ack{messageId, refused}, ArduinoInfo{sessionId, pingFailsafeTriggered} and ResetEvent{sessionId}: one
// function for the three (each with its own zeroed ArduinoOut and send call: proxy.elf +50 B); a
// ResetEvent goes after a 0x00 (proxy_device.hpp, rule 1). Out of line: LTO inlined the ack into main.
__attribute__((noinline)) void ProxyDevice::send_word(pb_size_t which, uint32_t word, bool flag) {
  tether_proxy_ArduinoOut out = out_message(which);
  if (which == tether_proxy_ArduinoOut_ack_tag) {
    out.data.ack.messageId = word;
    out.data.ack.refused = flag;
  } else if (which == tether_proxy_ArduinoOut_info_tag) {
    out.data.info.sessionId = word;
    out.data.info.pingFailsafeTriggered = flag;
  } else {
    out.data.resetEvent.sessionId = word;
  }
  send(&out, which == tether_proxy_ArduinoOut_resetEvent_tag);
}

void ProxyDevice::send_error(FlashText text) {
  ErrorOut error;
  error.text.text(text);
  send(&error.message);
}

void ProxyDevice::send_pin_state(uint8_t pin, bool failsafe) {
  tether_proxy_ArduinoOut out = out_message(tether_proxy_ArduinoOut_pinState_tag);
  out.data.pinState.pin = pin;
  out.data.pinState.value = outputs_->value(pin);
  out.data.pinState.failsafe = failsafe;
  send(&out);
}

void ProxyDevice::report_pin_result(PinResult result, uint32_t pin, bool servo, int32_t value) {
  if (result == PinResult::ok) {
    send_pin_state(static_cast<uint8_t>(pin), false);
    return;
  }
  add_one(counters_.refused);
  ErrorOut error;
  // "<servo on pin|pin> N<why>", then for a position out of range "P not in 0..180".
  error.text.text(FlashText{result == PinResult::not_servo_pin ? kServoOnPin : kPin})
      .number(pin)
      .text(FlashText{refusal_text(result, servo)});
  if (result == PinResult::out_of_range) {
    if (value < 0) error.text.text(FlashText{kMinus});
    error.text.number(value < 0 ? 0u - static_cast<uint32_t>(value) : static_cast<uint32_t>(value))
        .text(FlashText{kNotIn0180});
  }
  send(&error.message);
}

__attribute__((noinline)) void ProxyDevice::report_drops() {
  const LinkCounters& link = counters_.link;
  uint32_t drops = 0;
  for (uint8_t field = 0; field < kDropFieldCount; ++field) drops += drop_count(link, field);
  if (drops == reported_drops_) return;
  reported_drops_ = drops;
  ErrorOut error;
  for (uint8_t field = 0; field < kDropFieldCount; ++field) {
    error.text.text(FlashText{kDropFields[field].label}).number(drop_count(link, field));
  }
  send(&error.message);
}

}  // namespace device
}  // namespace proxy
}  // namespace tether
