#include "reference_firmware_double.hpp"

#include <cstdio>

#include "tether/core/crc.hpp"
#include "tether/romi/encoder.hpp"
#include "tether/romi/request_parser.hpp"

namespace tether::romi::testing {
namespace {

constexpr std::size_t kReferencePayload = 57;

int hex(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  return -1;
}

}  // namespace

ReferenceFirmwareDouble::ReferenceFirmwareDouble(std::vector<Handler> handlers) : handlers_(std::move(handlers)) {}

int ReferenceFirmwareDouble::executions(char opcode) const {
  const auto it = executions_.find(opcode);
  return it == executions_.end() ? 0 : it->second;
}

std::string ReferenceFirmwareDouble::respond(const std::string& body, char opcode, uint8_t id) {
  uint8_t frame[512];
  const auto size = encode_response(opcode, ByteView::from_chars(body.data(), body.size()), id, frame);
  return std::string(reinterpret_cast<const char*>(frame), size.ok() ? size.value() : 0);
}

// g++ 12 at -O2/-O3 (Release) reports a -Wrestrict overlap inside libstdc++'s operator+ for
// `"[" + std::string + "]"` that cannot happen (GCC bug 105329); silenced for this function only.
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wrestrict"
#endif
std::string ReferenceFirmwareDouble::reply(int16_t code, uint8_t id) {
  // Protocol errors carry the code alone: `#a[-17]:00ac` in the published vectors.
  return respond("[" + std::to_string(code) + "]", last_opcode_, id);
}
#if defined(__GNUC__) && !defined(__clang__) && __GNUC__ == 12
#pragma GCC diagnostic pop
#endif

std::string ReferenceFirmwareDouble::diagnostics(const std::string& detail, int16_t code) const {
  std::string lines;
  for (const std::string& text : {std::string("error"), detail, std::to_string(code), payload_}) {
    lines += "#!" + text + ":xxxx\r\n";
  }
  return lines;
}

void ReferenceFirmwareDouble::error(int16_t code, std::string& out, char offending) {
  // The id parsed so far: both digits when they were valid, else 0.
  uint8_t id = 0;
  if (metadata_.size() >= 2 && hex(metadata_[0]) >= 0 && hex(metadata_[1]) >= 0) {
    id = static_cast<uint8_t>(hex(metadata_[0]) * 16 + hex(metadata_[1]));
  }
  out += diagnostics(std::string(1, offending), code);
  out += reply(code, id);
  state_ = State::wait_start;  // the offending byte is consumed
}

std::string ReferenceFirmwareDouble::feed(std::string_view bytes) {
  std::string out;
  for (const char c : bytes) {
    if (c == '#' && state_ != State::metadata && state_ != State::expect_cr && state_ != State::expect_lf) {
      state_ = State::payload;
      payload_.clear();
      metadata_.clear();
      overflowed_ = false;
      running_crc_.reset();
      running_crc_.update('#');
      continue;
    }
    switch (state_) {
      case State::wait_start:
        break;
      case State::payload:
        // The CRC runs over every byte received, also one that did not fit the buffer (B1's second answer).
        if (c != '\r' && c != '\n') running_crc_.update(static_cast<uint8_t>(c));
        if (c == ':') {
          state_ = State::metadata;
        } else if (c == '\r' || c == '\n') {
          error(-6, out, c);
        } else if (payload_.size() == kReferencePayload) {
          // B1: reported, but parsing goes on, and the frame "completes" later without its last character.
          if (!overflowed_) {
            error(-1, out, c);
            state_ = State::payload;  // unlike other errors, the reference keeps parsing this frame
          }
          overflowed_ = true;
        } else {
          payload_ += c;
        }
        break;
      case State::metadata:
        metadata_ += c;
        if (metadata_.size() <= 2) running_crc_.update(static_cast<uint8_t>(c));
        if (metadata_.size() == 1 && c == 'x') break;
        if (metadata_[0] == 'x') {
          if (c != 'x') error(-7, out, c);
        } else if (metadata_.size() <= 2 ? hex(c) < 0 : false) {
          error(-2, out, c);
        } else if (metadata_.size() > 2 && hex(c) < 0) {
          error(-3, out, c);
        }
        if (state_ == State::metadata && metadata_.size() == 4) state_ = State::expect_cr;
        break;
      case State::expect_cr:
        if (c == '\r') {
          state_ = State::expect_lf;
        } else {
          error(-5, out, c);
        }
        break;
      case State::expect_lf:
        if (c == '\n') {
          complete(out);
          state_ = State::wait_start;
        } else {
          error(-5, out, c);
        }
        break;
    }
  }
  return out;
}

void ReferenceFirmwareDouble::complete(std::string& out) {
  const bool manual = metadata_ == "xxxx";
  uint8_t id = 0;
  if (!manual) {
    id = static_cast<uint8_t>(hex(metadata_[0]) * 16 + hex(metadata_[1]));
    if (running_crc_.value() != hex(metadata_[2]) * 16 + hex(metadata_[3])) {
      char crc[8];
      std::snprintf(crc, sizeof crc, "crc=%02X", running_crc_.value());
      out += diagnostics(crc, -4);
      out += reply(-4, id);
      return;
    }
  }
  if (overflowed_) {  // B1: the second answer, no handler
    out += respond("[0]", payload_.empty() ? '_' : payload_[0], id);
    return;
  }
  Request request;
  const Error parsed = parse_request(ByteView::from_chars(payload_.data(), payload_.size()), request);
  if (parsed != Error::no_error) {
    out += diagnostics(std::string(1, payload_.empty() ? '_' : payload_.back()), static_cast<int16_t>(parsed));
    out += reply(static_cast<int16_t>(parsed), id);
    return;
  }
  last_opcode_ = request.opcode;
  if (!manual && id == last_id_) {
    out += reply(-15, id);
    return;
  }
  last_id_ = manual ? 0 : id;
  const Handler* handler = nullptr;
  for (const auto& h : handlers_) {
    if (h.opcode == request.opcode) handler = &h;
  }
  if (handler == nullptr) return void(out += reply(-16, id));
  if (request.argument_count != handler->arguments) return void(out += reply(-17, id));
  if (handler->requires_string && !request.has_string) return void(out += reply(-18, id));
  if (!handler->requires_string && request.has_string) return void(out += reply(-19, id));
  ++executions_[request.opcode];
  const std::string body = handler->reply(std::vector<int16_t>(request.arguments, request.arguments + request.argument_count),
                                          request.string);
  out += body.empty() ? reply(-20, id) : respond(body, request.opcode, id);
}

}  // namespace tether::romi::testing
