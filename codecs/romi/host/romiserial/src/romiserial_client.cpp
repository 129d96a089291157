#include "RomiSerialClient.h"

#include <algorithm>
#include <atomic>
#include <cstdint>
#include <stdexcept>

#include "Console.h"
#include "link.hpp"
#include "tether/romi/client.hpp"
#include "tether/romi/errors.hpp"

namespace romiserial {

struct RomiSerialClient::Session {
  std::atomic<bool> debug{false};
  std::atomic<uint8_t> last_id{0};
  tether::romi::Client client;

  Session(std::shared_ptr<tether::transports::ByteStream> stream, const tether::romi::Options& options)
      : client(std::move(stream), options) {}
};

namespace {

nlohmann::json error_response(int code) { return nlohmann::json::array({code, RomiSerialClient::get_error_message(code)}); }

// RomiSerial's response shape: the values on success, `[code, "message"]` on every error.
nlohmann::json reference_shape(const tether::romi::RomiResponse& answer, ILog& log, const std::string& name) {
  const nlohmann::json& values = answer.values;
  if (answer.code == 0) return values;
  if (values.is_array() && values.size() == 2 && values[1].is_string()) return values;
  if (values.is_array() && values.size() == 1) return error_response(answer.code);
  log.warn("RomiSerialClient<%s>: error answer with invalid values: '%s'", name.c_str(), values.dump().c_str());
  return error_response(static_cast<int>(tether::romi::Error::client_invalid_error_response));
}

std::shared_ptr<RSerial> the_one_rserial(const std::shared_ptr<IInputStream>& in,
                                         const std::shared_ptr<IOutputStream>& out) {
  auto serial = std::dynamic_pointer_cast<RSerial>(in);
  if (!serial || dynamic_cast<RSerial*>(out.get()) != serial.get()) {
    throw std::invalid_argument("RomiSerialClient: Tether's client runs on one RSerial given as both in and out");
  }
  return serial;
}

}  // namespace

std::unique_ptr<IRomiSerialClient> RomiSerialClient::create(const std::string& device, const std::string& client_name,
                                                             std::shared_ptr<ILog> log) {
  auto serial = std::make_shared<RSerial>(device, kDefaultBaudRate, kDontReset, log);
  return std::make_unique<RomiSerialClient>(serial, serial, log, any_id(), client_name);
}

uint8_t RomiSerialClient::any_id() { return tether::romi::random_first_id(); }

RomiSerialClient::RomiSerialClient(std::shared_ptr<IInputStream> in, std::shared_ptr<IOutputStream> out,
                                   std::shared_ptr<ILog> log, uint8_t start_id, const std::string& client_name)
    : log_(log ? std::move(log) : std::make_shared<Console>()), client_name_(client_name) {
  const std::shared_ptr<RSerial> serial = the_one_rserial(in, out);
  link_ = serial->link_;
  {
    std::lock_guard lock(link_->mutex);
    if (link_->taken) {
      throw std::invalid_argument("RomiSerialClient: " + link_->device + " is already used by another client");
    }
    link_->taken = true;
  }
  tether::romi::Options options;
  options.last_id = start_id;  // the first request uses start_id + 1, as in RomiSerial
  session_ = std::make_unique<Session>(link_->stream, options);
  session_->last_id = start_id;
  // The handler runs on the client's strand; `log_` and the name live as long as the session (destroyed first).
  session_->client.on_event([log = log_.get(), name = &client_name_](const tether::romi::Event& event) {
    const auto* line = std::get_if<tether::romi::events::Log>(&event);
    if (line == nullptr) return;
    log->debug("RomiSerialClient<%s>: Firmware says: '%.*s'", name->c_str(), static_cast<int>(line->text.size()),
               line->text.data());
  });
}

RomiSerialClient::~RomiSerialClient() { session_.reset(); }

uint8_t RomiSerialClient::id() { return session_->last_id; }

void RomiSerialClient::send(const char* command, nlohmann::json& response) {
  std::string text = command ? command : "";
  std::replace(text.begin(), text.end(), ':', '-');  // as RomiSerial: ':' would end the envelope's payload
  const bool debug = session_->debug;
  if (debug) log_->debug("RomiSerialClient<%s>::send: %s", client_name_.c_str(), text.c_str());
  boost::system::error_code error;
  const tether::romi::RomiResponse answer = session_->client.call(tether::romi::Command(text), error);
  if (answer.attempts > 0) session_->last_id = answer.id;
  response = reference_shape(answer, *log_, client_name_);
  if (debug) log_->debug("RomiSerialClient<%s>::send: %s -> %s", client_name_.c_str(), text.c_str(), response.dump().c_str());
}

void RomiSerialClient::set_debug(bool value) { session_->debug = value; }

const char* RomiSerialClient::get_error_message(int code) {
  if (code < INT16_MIN || code > INT16_MAX) return "unknown error";
  return tether::romi::describe(static_cast<int16_t>(code));
}

}  // namespace romiserial
