// What `tether shell` prints for what a device said (see shell_text.hpp).
#include "shell_text.hpp"

#include "cli_support.hpp"
#include "message_text.hpp"

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

ShellLine proxy_event_line(const proxy::Event& event) {
  namespace ev = proxy::events;
  if (const auto* error = std::get_if<ev::DeviceError>(&event)) {
    const bool fatal = error->level == proxy::ErrorLevel::fatal;
    return {std::string("device ") + (fatal ? "FATAL" : "error") + ": " + printable(error->text),
            {{"event", "device_error"}, {"text", error->text}, {"level", fatal ? "fatal" : "warning"}}};
  }
  if (const auto* info = std::get_if<ev::DeviceInfo>(&event)) {
    return {"info: session " + std::to_string(info->session_id) +
                (info->ping_failsafe_triggered ? ", failsafe triggered" : ""),
            {{"event", "info"},
             {"session_id", info->session_id},
             {"ping_failsafe_triggered", info->ping_failsafe_triggered}}};
  }
  if (const auto* failsafe = std::get_if<ev::FailsafeTriggered>(&event)) {
    return {"FAILSAFE triggered (no ping for 10 s)", {{"event", "failsafe"}, {"session_id", failsafe->session_id}}};
  }
  if (const auto* report = std::get_if<ev::PinReport>(&event)) {
    const char* kind = report->kind == proxy::PinKind::servo     ? "servo"
                       : report->kind == proxy::PinKind::digital ? "digital"
                                                                 : "pin";
    return {std::string(kind) + " " + std::to_string(report->pin) + " = " + std::to_string(report->value) +
                (report->failsafe ? " (failsafe)" : ""),
            {{"event", "pin"},
             {"kind", kind},
             {"pin", report->pin},
             {"value", report->value},
             {"failsafe", report->failsafe}}};
  }
  if (const auto* lost = std::get_if<ev::PinLost>(&event)) {
    return {"pin " + std::to_string(lost->pin) + " lost (silent " + std::to_string(lost->silent_ms) + " ms)",
            {{"event", "pin_lost"}, {"pin", lost->pin}, {"silent_ms", lost->silent_ms}}};
  }
  if (const auto* established = std::get_if<ev::SessionEstablished>(&event)) {
    return {"session " + std::to_string(established->session_id) + " established" +
                (established->inits > 0 ? " (" + std::to_string(established->inits) + " inits replayed)" : ""),
            {{"event", "session"},
             {"session_id", established->session_id},
             {"inits", established->inits},
             {"first", established->first}}};
  }
  if (const auto* reset = std::get_if<ev::ResetDetected>(&event)) {
    return {"device reset detected (session " + std::to_string(reset->previous_session_id) + " -> " +
                std::to_string(reset->reported_session_id) + "); recovering",
            {{"event", "reset_detected"},
             {"previous_session_id", reset->previous_session_id},
             {"reported_session_id", reset->reported_session_id}}};
  }
  if (const auto* compat = std::get_if<ev::CompatEvent>(&event)) {
    const std::string name = RocketryProto::EventTypes_Name(compat->type);
    return {"device event " + name + " " + std::to_string(compat->data),
            {{"event", "compat_event"}, {"name", name}, {"data", compat->data}}};
  }
  if (const auto* compat_error = std::get_if<ev::CompatError>(&event)) {
    const std::string name = RocketryProto::ErrorTypes_Name(compat_error->type);
    return {"device error " + name + " " + std::to_string(compat_error->data),
            {{"event", "compat_error"}, {"name", name}, {"data", compat_error->data}}};
  }
  if (const auto* state = std::get_if<ev::CompatState>(&event)) {
    return {"device state " + describe_proxy_message(state->message),
            {{"event", "compat_state"}, {"message", proxy_message_json(state->message)}}};
  }
  if (const auto* undecodable = std::get_if<ev::UndecodableMessage>(&event)) {
    return {std::string(undecodable->malformed ? "undecodable" : "unknown") + " message (" +
                std::to_string(undecodable->payload.size()) + " bytes)",
            {{"event", "undecodable"}, {"malformed", undecodable->malformed}}};
  }
  const auto& failed = std::get<ev::LinkFailed>(event);
  return {"link failed: " + failed.error.message(), {{"event", "link_failed"}, {"message", failed.error.message()}}};
}

ShellLine ring_event_line(const elcano::Event& event, elcano::Generation generation) {
  namespace ev = elcano::events;
  if (const auto* undeliverable = std::get_if<ev::Undeliverable>(&event)) {
    const std::string text = format_elcano(undeliverable->message, generation);
    return {"undeliverable " + text + " (came back round the ring: nobody captured it)",
            {{"event", "undeliverable"}, {"text", text}, {"message", elcano_json(undeliverable->message)}}};
  }
  if (const auto* dropped = std::get_if<ev::InputDropped>(&event)) {
    return {std::string("read error: ") + elcano::describe(dropped->error),
            {{"event", "read_error"}, {"reason", elcano::describe(dropped->error)}}};
  }
  if (const auto* forward = std::get_if<ev::ForwardDropped>(&event)) {
    const std::string text = format_elcano(forward->message, generation);
    return {"forward dropped " + text + " (output queue full)", {{"event", "forward_dropped"}, {"text", text}}};
  }
  if (const auto* overflow = std::get_if<ev::ReceiveOverflow>(&event)) {
    const std::string text = format_elcano(overflow->message, generation);
    return {"receive overflow, dropped " + text, {{"event", "receive_overflow"}, {"text", text}}};
  }
  const auto& failed = std::get<ev::LinkFailed>(event);
  return {"link failed: " + failed.error.message(), {{"event", "link_failed"}, {"message", failed.error.message()}}};
}

ShellLine captured_line(const elcano::Message& message, elcano::Generation generation) {
  const std::string text = format_elcano(message, generation);
  return {"captured " + text, {{"event", "captured"}, {"text", text}, {"message", elcano_json(message)}}};
}

std::string shell_output(std::string_view type, const ShellLine& line, bool json) {
  if (!json) return line.text;
  nlohmann::ordered_json full = {{"type", std::string(type)}};
  for (const auto& [key, value] : line.json.items()) full[key] = value;
  return dump(full);
}

}  // namespace tether::cli
