// What the `tether` command prints for the Romi codec (see romi_text.hpp).
#include "romi_text.hpp"

#include <cstdio>
#include <string>

#include "cli_support.hpp"
#include "tether/romi/decoder.hpp"

namespace tether::cli {

ShellLine romi_log_line(std::string_view text) {
  return {"log: " + printable(text), {{"event", "log"}, {"text", std::string(text)}}};
}

ShellLine romi_answer_line(std::string_view command, const romi::RomiResponse& response) {
  nlohmann::ordered_json object = {{"command", std::string(command)},
                                   {"code", response.code},
                                   {"values", response.values},
                                   {"answered", response.answered},
                                   {"message", response.message},
                                   {"id", response.id},
                                   {"attempts", response.attempts}};
  std::string text = response.answered ? dump(response.values) : std::string();
  if (response.code != 0) {
    text += std::string(text.empty() ? "" : "  ") + "error " + std::to_string(response.code) + ": " + printable(response.message);
  }
  return {text, object};
}

namespace {

// Requests (host->device) and responses (device->host) share the envelope, so one decoder serves both.
class RomiDecoder final : public MonitorDecoder {
 public:
  void feed(std::uint8_t byte, Millis, std::vector<MonitorRecord>& records) override {
    const std::uint32_t resyncs = counters_.resyncs;
    const DecodeStatus status = decoder_.feed(byte);
    if (counters_.resyncs != resyncs) records.push_back(resync_record());
    if (status == DecodeStatus::more) return;
    const romi::Frame& event = decoder_.frame();
    const std::string payload(reinterpret_cast<const char*>(event.payload.data()), event.payload.size());
    char id[4];
    std::snprintf(id, sizeof id, "%02x", event.id);
    if (status == DecodeStatus::frame && event.log) {
      records.push_back({"log", printable(payload), {{"text", payload}}, true});
    } else if (status == DecodeStatus::frame) {
      nlohmann::ordered_json json = {
          {"opcode", std::string(1, event.opcode)},
          {"id", event.manual ? nlohmann::ordered_json() : nlohmann::ordered_json(event.id)},
          {"manual", event.manual},
          {"payload", payload}};
      // An empty payload (`#:xxxx`, which the reference firmware sends) has no values after an opcode.
      if (payload.size() > 1) {
        const auto values = nlohmann::ordered_json::parse(payload.begin() + 1, payload.end(), nullptr, false);
        if (!values.is_discarded()) json["values"] = values;
      }
      const std::string shown = payload.empty() ? std::string("(empty)") : printable(payload);
      records.push_back({"frame", shown + (event.manual ? " (manual)" : " id " + std::string(id)), json, true});
    } else {
      const auto code = static_cast<std::int16_t>(decoder_.error());
      std::string detail = std::to_string(code) + " " + romi::describe(code);
      nlohmann::ordered_json json = {{"code", code}, {"message", romi::describe(code)}};
      if (event.opcode != '_') {
        detail += " (opcode " + std::string(1, event.opcode);
        json["opcode"] = std::string(1, event.opcode);
        if (event.has_id) {
          detail += ", id " + std::string(id);
          json["id"] = event.id;
        }
        detail += ")";
      }
      records.push_back({"error", detail, json, false});
    }
  }
  LinkCounters counters() const override { return counters_; }

 private:
  LinkCounters counters_;
  romi::Decoder<1030> decoder_{counters_};  // responses and log lines up to 1024 bytes, like the client
};

}  // namespace

std::unique_ptr<MonitorDecoder> make_romi_monitor_decoder(const devices::DeviceConfig&, const DecoderRole&, Millis) {
  return std::make_unique<RomiDecoder>();
}

}  // namespace tether::cli
