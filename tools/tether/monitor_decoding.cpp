// What `tether monitor` makes of a byte stream (see monitor_decoding.hpp).
#include "monitor_decoding.hpp"


namespace tether::cli {

const char* to_string(Direction direction) {
  return direction == Direction::device_to_host ? "device->host" : "host->device";
}

std::string record_text(const MonitorRecord& record) {
  std::string line = record.kind;
  line.append(record.kind.size() < 8 ? 8 - record.kind.size() : 0, ' ');
  return line + " " + record.detail;
}

nlohmann::ordered_json record_json(const MonitorRecord& record) {
  nlohmann::ordered_json object = {{"kind", record.kind}};
  for (const auto& [key, value] : record.json.items()) object[key] = value;
  return object;
}
MonitorRecord resync_record() {
  return {"resync", "skipped bytes to the next frame start", nlohmann::ordered_json::object(), false};
}

}  // namespace tether::cli
