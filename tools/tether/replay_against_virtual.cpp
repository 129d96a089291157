// `tether replay FILE [--device D] --against-virtual IMAGE`: a firmware checked against a recording. The
// capture's host->device bytes of link D go to a virtual Uno running IMAGE, each at its recorded offset from the
// link's first host->device packet, counted on the board's clock from the moment its firmware enabled its UART
// receiver (the board runs on this thread through `run_for`: deterministic, faster than real time when it can).
// Both the recorded and the new device->host bytes are cut into packets by the codec's capture framing,
// decoded by its monitor decoder, and the two sequences aligned (Myers' diff of their comparison keys).
//
// Output contract: one line per difference (`<time> changed|recorded-only|new-only <record>`, a changed frame's
// new version on the next line as `<time>   now <record>`), times in ms since the capture's first packet as
// `tether replay` prints them (a new frame's: where it fell on the recorded timeline); then one `ignored:` line
// per codec rule that left frames out or compared them in part, and the summary line `same: N frames the same,
// 0 differ` or `different: N frames the same, M differ (...)`. With --json one object per difference, per rule
// and a summary object. Exit status 0 same, 1 differences, 2 errors.
#include "replay_against_virtual.hpp"

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <system_error>
#include <unordered_map>
#include <utility>
#include <variant>
#include <vector>

#include "codec_commands.hpp"
#include "device_options.hpp"
#include "monitor_decoding.hpp"
#include "tether/devices/codecs.hpp"
#include "tether/transports/capture_framing.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::cli {

namespace {

namespace fs = std::filesystem;
using transports::CaptureDirection;

// Longest the firmware may take to enable its UART receiver, in board time.
constexpr auto kBootLimit = std::chrono::seconds(10);
// Alignments needing more edits than this give up (memory grows with its square) and pair the rest in order.
constexpr std::size_t kMaxEdits = 2000;

// One packet of a device->host sequence: a frame or a run of unframed bytes, with what it decoded to and how
// it is compared.
struct Item {
  std::int64_t time_us = 0;  // since the capture's first packet
  std::vector<std::uint8_t> bytes;
  bool frame = true;
  std::string reason;  // unframed: why
  std::vector<MonitorRecord> decoded;
  ReplayFrameView view;
};

// Cuts one device->host byte stream into items as a recording does, decoding each as `tether replay` does.
class Sequence {
 public:
  Sequence(const devices::DeviceConfig& device, const devices::CodecRow& row, const CodecCommands& commands)
      : commands_(commands) {
    framer_ = row.capture_framing ? row.capture_framing(device)(true) : nullptr;
    if (!framer_) framer_ = std::make_unique<transports::ChunkFramer>();
    DecoderRole role;
    role.direction = Direction::device_to_host;
    role.ring_node = false;
    decoder_ = make_monitor_decoder(device, role, 0);
  }

  void feed(std::int64_t time_us, std::span<const std::uint8_t> bytes) {
    time_us_ = time_us;
    framer_->feed(bytes, [this](transports::FramedPacket packet) { take(std::move(packet)); });
  }
  // What is pending at the end is a frame the end of the recording (or of the run) cut, not an answer: it is
  // counted, not compared.
  void close() {
    framer_->flush("cut at close", [this](transports::FramedPacket packet) {
      take(std::move(packet));
      items_.back().view = {true, {}, "cut at close: a partial frame where the recording or the run ended"};
    });
  }
  std::vector<Item>& items() { return items_; }

 private:
  void take(transports::FramedPacket packet) {
    Item item;
    item.time_us = time_us_;
    item.frame = packet.frame;
    item.reason = std::move(packet.reason);
    item.bytes = std::move(packet.bytes);
    if (decoder_) {
      const Millis now = static_cast<Millis>(time_us_ > 0 ? time_us_ / 1000 : 0);
      for (const std::uint8_t byte : item.bytes) decoder_->feed(byte, now, item.decoded);
    }
    if (item.frame && commands_.replay_frame_view) item.view = commands_.replay_frame_view(item.bytes, item.decoded);
    items_.push_back(std::move(item));
  }

  const CodecCommands& commands_;
  std::unique_ptr<transports::CaptureFramer> framer_;
  std::unique_ptr<MonitorDecoder> decoder_;
  std::int64_t time_us_ = 0;
  std::vector<Item> items_;
};

// What an item is compared by.
std::string key_of(const Item& item) {
  if (!item.view.key.empty()) return "k" + item.view.key;
  return (item.frame ? "f" : "u" + item.reason + ":") + std::string(item.bytes.begin(), item.bytes.end());
}

// The item as `tether replay` prints it.
std::vector<MonitorRecord> records_of(const Item& item) {
  if (!item.frame) {
    const std::string text(item.bytes.begin(), item.bytes.end());
    return {{"unframed", item.reason + " (" + std::to_string(item.bytes.size()) + " bytes) " + printable(text),
             {{"reason", item.reason}, {"bytes", text}},
             false}};
  }
  if (!item.decoded.empty()) return item.decoded;
  const std::string text(item.bytes.begin(), item.bytes.end());
  return {{"frame", printable(text), {{"bytes", text}}, false}};
}

std::string item_text(const Item& item) {
  std::string text;
  for (const MonitorRecord& record : records_of(item)) text += (text.empty() ? "" : " | ") + record_text(record);
  return text;
}

nlohmann::ordered_json item_json(const Item& item) {
  nlohmann::ordered_json object;
  object["t_ms"] = static_cast<double>(item.time_us) / 1000.0;
  const std::vector<MonitorRecord> records = records_of(item);
  if (records.size() == 1) {
    const nlohmann::ordered_json fields = record_json(records[0]);
    for (const auto& [key, value] : fields.items()) object[key] = value;
  } else {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const MonitorRecord& record : records) list.push_back(record_json(record));
    object["records"] = list;
  }
  return object;
}

std::string time_text(std::int64_t time_us) {
  char stamp[32];
  std::snprintf(stamp, sizeof stamp, "%.3f", static_cast<double>(time_us) / 1000.0);
  return stamp;
}

enum class Edit { same, recorded_only, new_only };

// Myers' O((N+M)D) shortest edit script of `a` into `b`, or nothing when it needs more than `max_edits`.
std::optional<std::vector<Edit>> shortest_edit(const std::vector<int>& a, const std::vector<int>& b,
                                               std::size_t max_edits) {
  const long n = static_cast<long>(a.size());
  const long m = static_cast<long>(b.size());
  const long limit = std::min<long>(n + m, static_cast<long>(max_edits));
  const long offset = limit + 1;
  std::vector<long> v(static_cast<std::size_t>(2 * offset + 1), 0);
  std::vector<std::vector<long>> trace;  // v[-d-1 .. d+1] before step d
  const auto at = [&](std::vector<long>& values, long k) -> long& { return values[static_cast<std::size_t>(k + offset)]; };
  long found = -1;
  for (long d = 0; d <= limit && found < 0; ++d) {
    trace.emplace_back(v.begin() + (offset - d - 1), v.begin() + (offset + d + 2));
    for (long k = -d; k <= d; k += 2) {
      long x = k == -d || (k != d && at(v, k - 1) < at(v, k + 1)) ? at(v, k + 1) : at(v, k - 1) + 1;
      long y = x - k;
      while (x < n && y < m && a[static_cast<std::size_t>(x)] == b[static_cast<std::size_t>(y)]) ++x, ++y;
      at(v, k) = x;
      if (x >= n && y >= m) {
        found = d;
        break;
      }
    }
  }
  if (found < 0) return std::nullopt;
  std::vector<Edit> edits;
  long x = n;
  long y = m;
  for (long d = found; d > 0; --d) {
    const std::vector<long>& before = trace[static_cast<std::size_t>(d)];
    const auto old = [&](long k) { return before[static_cast<std::size_t>(k + d + 1)]; };
    const long k = x - y;
    const bool down = k == -d || (k != d && old(k - 1) < old(k + 1));
    const long previous_k = down ? k + 1 : k - 1;
    const long previous_x = old(previous_k);
    const long previous_y = previous_x - previous_k;
    const long middle_x = down ? previous_x : previous_x + 1;
    while (x > middle_x) {
      edits.push_back(Edit::same);
      --x, --y;
    }
    edits.push_back(down ? Edit::new_only : Edit::recorded_only);
    x = previous_x;
    y = previous_y;
  }
  while (x > 0) {
    edits.push_back(Edit::same);
    --x, --y;
  }
  std::reverse(edits.begin(), edits.end());
  return edits;
}

// Aligns the two key sequences: common head and tail, Myers' diff in between (or, past kMaxEdits, the rest
// paired in order). Sets `gave_up` then.
std::vector<Edit> align(const std::vector<int>& a, const std::vector<int>& b, bool& gave_up) {
  std::size_t head = 0;
  while (head < a.size() && head < b.size() && a[head] == b[head]) ++head;
  std::size_t tail = 0;
  while (tail < a.size() - head && tail < b.size() - head && a[a.size() - 1 - tail] == b[b.size() - 1 - tail]) ++tail;
  const std::vector<int> middle_a(a.begin() + static_cast<long>(head), a.end() - static_cast<long>(tail));
  const std::vector<int> middle_b(b.begin() + static_cast<long>(head), b.end() - static_cast<long>(tail));
  std::vector<Edit> edits(head, Edit::same);
  if (middle_a.empty() || middle_b.empty()) {  // one side only: no search needed, however long
    edits.insert(edits.end(), middle_a.size(), Edit::recorded_only);
    edits.insert(edits.end(), middle_b.size(), Edit::new_only);
  } else if (auto middle = shortest_edit(middle_a, middle_b, kMaxEdits)) {
    edits.insert(edits.end(), middle->begin(), middle->end());
  } else {
    gave_up = true;
    for (std::size_t i = 0; i < std::max(middle_a.size(), middle_b.size()); ++i) {
      if (i < middle_a.size()) edits.push_back(Edit::recorded_only);
      if (i < middle_b.size()) edits.push_back(Edit::new_only);
    }
  }
  edits.insert(edits.end(), tail, Edit::same);
  return edits;
}

}  // namespace

std::string against_virtual_rules_usage() {
  std::string text;
  std::string plain;
  for (const devices::CodecRow* row : devices::codec_rows()) {
    const CodecCommands* commands = codec_commands(row->codec);
    if (commands == nullptr || !commands->monitor_decoder) continue;
    if (commands->replay_rules.empty()) {
      plain += (plain.empty() ? "" : ", ") + std::string(row->name);
    } else {
      text += "    " + std::string(row->name) + ": " + std::string(commands->replay_rules) + "\n";
    }
  }
  if (!plain.empty()) text += "    " + plain + ": every frame compared byte for byte\n";
  text += "    all: a partial frame where the recording or the run ended counted, not compared\n";
  return text;
}

int replay_against_virtual(const AgainstVirtual& run, const CommandText& text) {
  const transports::Capture& capture = *run.capture;

  const std::size_t link = run.link;
  const transports::CaptureInterface& interface = capture.interfaces[link];
  const devices::DeviceConfig& device = run.device;
  const devices::CodecRow& row = devices::codec_row(device.codec);
  const CodecCommands& commands = *codec_commands(device.codec);  // the device was decoded through its row

  // The image: found as `--virtual` finds it, and of the capture's codec when its name says one.
  const fs::path image = firmware_image(run.image);
  if (const std::optional<std::string> problem = firmware_image_problem(image)) return text.fail(*problem);
  if (const devices::CodecRow* named = codec_row_of_image(image); named != nullptr && named->codec != device.codec) {
    return text.fail(image.filename().string() + " is a " + std::string(named->name) + " image, and device '" +
                     printable(interface.name) + "' of " + run.file + " speaks " + std::string(row.name));
  }

  // A codec on rings runs the board as `--virtual IMAGE` does: a ring of one, set up by the codec (an Elcano
  // node's settings in its EEPROM).
  std::vector<std::uint8_t> eeprom;
  if (row.virtual_boards != devices::VirtualBoards::single) {
    devices::DeviceConfig lone = device;
    const devices::VirtualRingTransport* ring = nullptr;
    try {
      if (commands.lone_virtual_board) commands.lone_virtual_board(image, DeviceOptions(), lone);
      ring = std::get_if<devices::VirtualRingTransport>(&lone.transport);
    } catch (const devices::ConfigError& failure) {
      return text.fail(failure.what());
    }
    if (ring == nullptr || ring->boards.size() != 1) {
      return text.fail(run.file + ": device '" + printable(interface.name) + "' speaks " + std::string(row.name) +
                       ", whose virtual devices are rings, and its codec gives no lone board to run");
    }
    eeprom = ring->boards.front().eeprom;
  }

  // The link's packets.
  const std::uint64_t first = capture.packets.empty() ? 0 : capture.packets.front().timestamp_us;
  const auto since_first = [first](std::uint64_t timestamp) {
    return timestamp >= first ? static_cast<std::int64_t>(timestamp - first) : 0;
  };
  std::vector<const transports::CapturePacket*> sent;
  std::int64_t last_us = 0;
  for (const transports::CapturePacket& packet : capture.packets) {
    if (packet.interface != link) continue;
    last_us = std::max(last_us, since_first(packet.timestamp_us));
    if (packet.direction == CaptureDirection::outbound && !packet.data.empty()) sent.push_back(&packet);
  }
  if (sent.empty()) {
    return text.fail(run.file + ": device '" + printable(interface.name) + "' has no host->device bytes to send");
  }
  const std::int64_t first_sent_us = since_first(sent.front()->timestamp_us);

  // The board, on this thread.
  transports::VirtualUnoOptions options;
  options.firmware = image;
  options.pacing = transports::Pacing::fast;
  std::error_code error;
  std::string message;
  std::unique_ptr<transports::VirtualUno> board = transports::VirtualUno::create(options, error, &message);
  if (!board) return text.fail(message.empty() ? image.string() + ": " + error.message() : message);
  struct Output {
    transports::SimDuration at;
    std::vector<std::uint8_t> bytes;
  };
  std::vector<Output> output;
  transports::VirtualUno& uno = *board;
  if (!eeprom.empty()) uno.write_eeprom(0, eeprom);
  uno.set_output_handler([&output, &uno](const std::uint8_t* data, std::size_t size) {
    output.push_back({uno.simulated_time(), std::vector<std::uint8_t>(data, data + size)});
  });
  const transports::SimDuration step = std::chrono::milliseconds(1);
  while (!uno.uart().rx_enabled && uno.simulated_time() < kBootLimit) uno.run_for(step);
  if (!uno.uart().rx_enabled) {
    return text.fail(image.filename().string() + " did not enable its UART receiver within " +
                     std::to_string(std::chrono::seconds(kBootLimit).count()) + " s of board time");
  }
  const transports::SimDuration boot = uno.simulated_time();
  // Board time -> the capture's timeline (microseconds since its first packet).
  const auto recorded_time = [&](transports::SimDuration at) {
    return first_sent_us + std::chrono::duration_cast<std::chrono::microseconds>(at - boot).count();
  };
  const auto board_time = [&](std::int64_t time_us) {
    return boot + std::chrono::microseconds(time_us - first_sent_us);
  };
  for (const transports::CapturePacket* packet : sent) {
    const transports::SimDuration due = board_time(since_first(packet->timestamp_us));
    if (due > uno.simulated_time()) uno.run_for(due - uno.simulated_time());
    uno.write(packet->data);
  }
  const transports::SimDuration end = board_time(last_us) + std::chrono::milliseconds(run.settle_ms);
  if (end > uno.simulated_time()) uno.run_for(end - uno.simulated_time());
  uno.set_output_handler({});
  const transports::VirtualUnoStats board_stats = uno.stats();

  // Both sides cut and decoded alike.
  Sequence recorded(device, row, commands);
  for (const transports::CapturePacket& packet : capture.packets) {
    if (packet.interface != link || packet.direction != CaptureDirection::inbound) continue;
    recorded.feed(since_first(packet.timestamp_us), packet.data);
  }
  recorded.close();
  Sequence answered(device, row, commands);
  for (const Output& each : output) answered.feed(recorded_time(each.at), each.bytes);
  answered.close();

  // Left out by the codec's rules, counted per rule; the rest keyed.
  struct RuleCount {
    bool ignored = false;
    std::size_t recorded = 0;
    std::size_t answered = 0;
  };
  std::map<std::string, RuleCount> rules;
  std::unordered_map<std::string, int> key_ids;
  const auto keep = [&](std::vector<Item>& items, bool is_recorded, std::vector<const Item*>& kept,
                        std::vector<int>& keys) {
    for (const Item& item : items) {
      if (!item.view.rule.empty()) {
        RuleCount& count = rules[item.view.rule];
        count.ignored = item.view.ignored;
        ++(is_recorded ? count.recorded : count.answered);
      }
      if (item.view.ignored) continue;
      kept.push_back(&item);
      keys.push_back(key_ids.emplace(key_of(item), static_cast<int>(key_ids.size())).first->second);
    }
  };
  std::vector<const Item*> old_items;
  std::vector<const Item*> new_items;
  std::vector<int> old_keys;
  std::vector<int> new_keys;
  keep(recorded.items(), true, old_items, old_keys);
  keep(answered.items(), false, new_items, new_keys);
  bool gave_up = false;
  const std::vector<Edit> edits = align(old_keys, new_keys, gave_up);

  // The report: each run of edits between equal items as changed pairs, then what is left of either side.
  std::size_t same = 0, changed = 0, recorded_only = 0, new_only = 0;
  const auto print_one = [&](const char* difference, const Item* old_item, const Item* new_item) {
    if (run.json) {
      nlohmann::ordered_json object;
      object["difference"] = difference;
      object["t_ms"] = static_cast<double>((old_item != nullptr ? old_item : new_item)->time_us) / 1000.0;
      if (old_item != nullptr) object["recorded"] = item_json(*old_item);
      if (new_item != nullptr) object["new"] = item_json(*new_item);
      out().line(dump(object));
      return;
    }
    const Item* shown = old_item != nullptr ? old_item : new_item;
    char label[32];
    std::snprintf(label, sizeof label, "%-13s", difference);
    out().line(time_text(shown->time_us) + " " + label + " " + item_text(*shown));
    if (old_item != nullptr && new_item != nullptr) {
      std::snprintf(label, sizeof label, "%-13s", "  now");
      out().line(time_text(new_item->time_us) + " " + label + " " + item_text(*new_item));
    }
  };
  std::size_t i = 0, j = 0;
  for (std::size_t e = 0; e < edits.size();) {
    if (edits[e] == Edit::same) {
      ++same, ++i, ++j, ++e;
      continue;
    }
    std::vector<const Item*> gone, come;
    for (; e < edits.size() && edits[e] != Edit::same; ++e) {
      if (edits[e] == Edit::recorded_only) gone.push_back(old_items[i++]);
      else come.push_back(new_items[j++]);
    }
    const std::size_t pairs = std::min(gone.size(), come.size());
    for (std::size_t p = 0; p < pairs; ++p, ++changed) print_one("changed", gone[p], come[p]);
    for (std::size_t p = pairs; p < gone.size(); ++p, ++recorded_only) print_one("recorded-only", gone[p], nullptr);
    for (std::size_t p = pairs; p < come.size(); ++p, ++new_only) print_one("new-only", nullptr, come[p]);
  }
  const std::size_t differ = changed + recorded_only + new_only;

  std::size_t ignored_recorded = 0, ignored_new = 0;
  for (const auto& [rule, count] : rules) {
    if (count.ignored) ignored_recorded += count.recorded, ignored_new += count.answered;
    if (run.json) {
      out().line(dump(nlohmann::ordered_json{{"rule", rule},
                                             {"compared", count.ignored ? "not" : "in part"},
                                             {"recorded", count.recorded},
                                             {"new", count.answered}}));
    } else {
      out().line(std::string(count.ignored ? "ignored: " : "compared in part: ") + std::to_string(count.recorded) +
                 " recorded, " + std::to_string(count.answered) + " new frames: " + rule);
    }
  }
  if (gave_up) {
    const std::string note = "more than " + std::to_string(kMaxEdits) +
                              " differences: the alignment gave up and paired the rest in order";
    if (run.json) {
      out().line(dump(nlohmann::ordered_json{{"note", note}}));
    } else {
      out().line("note: " + note);
    }
  }
  const std::string lost = board_stats.rx_bytes_lost == 0 ? std::string()
                                                          : std::to_string(board_stats.rx_bytes_lost) +
                                                                " host->device bytes reached the board while its "
                                                                "receiver was off (lost, as on a booting board)";
  if (run.json) {
    nlohmann::ordered_json summary;
    summary["result"] = differ == 0 ? "same" : "different";
    summary["same"] = same;
    summary["differ"] = differ;
    summary["changed"] = changed;
    summary["recorded_only"] = recorded_only;
    summary["new_only"] = new_only;
    summary["ignored_recorded"] = ignored_recorded;
    summary["ignored_new"] = ignored_new;
    summary["host_bytes_lost"] = board_stats.rx_bytes_lost;
    out().line(dump(nlohmann::ordered_json{{"summary", summary}}));
  } else {
    if (!lost.empty()) out().line("note: " + lost);
    std::string line = std::string(differ == 0 ? "same: " : "different: ") + std::to_string(same) +
                       (same == 1 ? " frame" : " frames") + " the same, " + std::to_string(differ) + " differ";
    if (differ != 0) {
      line += " (" + std::to_string(changed) + " changed, " + std::to_string(recorded_only) + " recorded only, " +
              std::to_string(new_only) + " new only)";
    }
    if (ignored_recorded + ignored_new != 0) {
      line += "; " + std::to_string(ignored_recorded) + " recorded and " + std::to_string(ignored_new) +
              " new frames ignored";
    }
    out().line(line);
  }
  out().flush();
  if (const std::string failure = out().write_failure(); !failure.empty()) return text.fail(failure);
  return differ == 0 ? 0 : 1;
}

}  // namespace tether::cli
