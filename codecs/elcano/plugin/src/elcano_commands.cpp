// The Elcano codec's rows of the `tether` command (tools/tether/codec_commands.hpp): its shell,
// monitor decoder, counters, stats probe and command-line defaults.
#include <nlohmann/json.hpp>

#include <algorithm>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>
#include <vector>

#include "cli_support.hpp"
#include "codec_commands.hpp"
#include "device_options.hpp"
#include "elcano_text.hpp"
#include "monitor_decoding.hpp"
#include "shell_text.hpp"
#include "tether/elcano/node_settings.hpp"
#include "tether/elcano/plugin.hpp"

namespace tether::cli {

namespace {

// Behaviour bits of the board of a lone `--virtual elcano-node` (a ring of one, which captures drive
// messages): drive the servos (0x08) and report each drive as a sensor message `S{s}{a}{b 0}{p 0,0}` (0x10).
constexpr std::uint8_t kLoneVirtualNodeBehaviour = 0x08 | 0x10;

// `--generation`: B or D (either case).
std::optional<elcano::Generation> parse_generation(std::string_view text) {
  if (text == "B" || text == "b") return elcano::Generation::b;
  if (text == "D" || text == "d") return elcano::Generation::d;
  return std::nullopt;
}

std::shared_ptr<elcano::RingClient> ring_client(const devices::DeviceClient& client) {
  return client.get<elcano::RingClient>();
}

// What became of the messages sent into an Elcano ring: each one ends captured somewhere (what the host
// sees is the answer it captures) or back at the host undelivered. End of input waits for these (bounded),
// so `echo 'D{s 50}{a 25}' | tether shell ...` prints the answer before it exits.
class RingReplies {
 public:
  /// How long end of input waits, at most, for the replies still outstanding.
  static constexpr std::chrono::seconds kWait{3};

  void sent() {
    const std::lock_guard lock(mutex_);
    ++sent_;
  }
  /// A captured message or an undelivered one came back.
  void settled() {
    const std::lock_guard lock(mutex_);
    ++settled_;
    changed_.notify_all();
  }
  /// The link failed: nothing more will come back.
  void link_failed() {
    const std::lock_guard lock(mutex_);
    link_failed_ = true;
    changed_.notify_all();
  }
  /// Waits until every message sent has settled, the link failed or `kWait` passed (or `stop` is set).
  void wait(const std::atomic<bool>& stop) {
    std::unique_lock lock(mutex_);
    const auto deadline = std::chrono::steady_clock::now() + kWait;
    while (settled_ < sent_ && !link_failed_ && !stop && std::chrono::steady_clock::now() < deadline) {
      changed_.wait_for(lock, std::chrono::milliseconds(50));  // 50 ms steps: notices a stop signal
    }
  }

 private:
  std::mutex mutex_;
  std::condition_variable changed_;
  std::uint64_t sent_ = 0;
  std::uint64_t settled_ = 0;
  bool link_failed_ = false;
};

// Prints every captured message: one receive at a time, re-armed from its completion.
void receive_captured(std::weak_ptr<elcano::RingClient> weak, ShellPrinter printer, elcano::Generation generation,
                      std::shared_ptr<RingReplies> replies) {
  const auto ring = weak.lock();
  if (!ring || !ring->is_open()) return;
  ring->async_receive([weak, printer, generation, replies](elcano::error_code error, elcano::Message message) {
    if (error) return;  // closed, or the link failed (reported as an event)
    printer.event(captured_line(message, generation));
    replies->settled();
    receive_captured(weak, printer, generation, replies);
  });
}

class ElcanoShell final : public ShellSession {
 public:
  ElcanoShell(std::shared_ptr<elcano::RingClient> client, const devices::DeviceConfig& config,
              const ShellContext& context)
      : client_(std::move(client)),
        printer_(context.printer),
        generation_(config.options.get<elcano::DeviceOptions>().generation),
        lone_board_(context.options != nullptr && !context.options->firmware.empty()),
        capture_given_(context.options != nullptr && context.options->codec_flag("--capture") != nullptr) {
    const ShellPrinter printer = context.printer;
    const std::function<void()> link_failed = context.link_failed;
    const elcano::Generation generation = generation_;
    const auto replies = replies_;
    client_->on_event([printer, generation, link_failed, replies](const elcano::Event& event) {
      printer.event(ring_event_line(event, generation));
      if (std::holds_alternative<elcano::events::Undeliverable>(event)) replies->settled();
      if (std::holds_alternative<elcano::events::LinkFailed>(event)) {
        link_failed();            // first: the shell's exit status reads it as soon as the wait below ends
        replies->link_failed();
      }
    });
    receive_captured(client_, printer_, generation_, replies_);
  }
  void greet() override {
    if (!lone_board_) return;  // --virtual: a ring of one
    const std::string capture = capture_given_ ? "as --capture says" : "sensor messages";
    printer_.info("note",
                  "the virtual board captures drive messages and answers each with a sensor report; the host "
                  "captures " + capture + "; other messages come back undelivered",
                  {{"board_captures", "drive"}});
  }
  void send(const std::string& line) override {
    std::string error;
    const auto message = parse_elcano(line, error);
    if (!message) {
      printer_.error(error);
      return;
    }
    elcano::error_code send_error;
    replies_->sent();  // before sending: the reply can come back before `send` returns
    client_->send(*message, send_error);
    const std::string text = format_elcano(*message, generation_);
    if (send_error) {
      replies_->settled();  // nothing will come of it
      printer_.answer({"send failed: " + send_error.message(),
                       {{"text", text}, {"sent", false}, {"error", send_error.message()}}});
    } else {
      printer_.answer({"sent " + text, {{"text", text}, {"sent", true}, {"message", elcano_json(*message)}}});
    }
  }
  bool command(const std::vector<std::string>& words) override {
    if (words.empty() || words[0] != ":capture") return false;
    const std::optional<elcano::TypeSet> set =
        words.size() == 2 ? parse_elcano_types(words[1]) : std::optional<elcano::TypeSet>();
    if (!set) {
      printer_.error(":capture needs TYPES: drive,sensor,goal,segment or none");
    } else {
      client_->set_capture(*set);
      printer_.info("capture", "capturing " + words[1], {{"capture", words[1]}});
    }
    return true;
  }
  void finish(const std::atomic<bool>& stop) override { replies_->wait(stop); }

 private:
  std::shared_ptr<elcano::RingClient> client_;
  ShellPrinter printer_;
  elcano::Generation generation_;
  bool lone_board_;
  bool capture_given_;
  std::shared_ptr<RingReplies> replies_ = std::make_shared<RingReplies>();
};

CodecCommands elcano_commands() {
  CodecCommands row;
  row.name = "elcano";
  row.image_prefixes = {"elcano"};
  row.example_image = "elcano-node";
  row.stats_activity = "the host's ring node: messages it does not capture are forwarded\n";
  row.flags = {
      {"--generation", "    --generation B|D  the ring's wire generation (default B)\n",
       [](std::string_view value) -> std::optional<std::string> {
         if (parse_generation(value)) return std::nullopt;
         return "B or D";
       }},
      {"--capture",
       "    --capture TYPES   message types the host consumes: a comma-separated list of drive, sensor, goal,\n"
       "                      segment (default: none; everything else is forwarded round the ring)\n",
       [](std::string_view value) -> std::optional<std::string> {
         if (parse_elcano_types(value)) return std::nullopt;
         return "message types (drive,sensor,goal,segment)";
       }},
  };
  row.usage_note =
      "  --virtual with an elcano image is a ring of one board that captures drive messages and answers each\n"
      "  with a sensor report S{s}{a}{b 0}{p 0,0}, which the host captures (default --capture sensor).\n";
  row.default_options = [](std::uint32_t baud, const DeviceOptions& options) -> devices::CodecOptions {
    elcano::DeviceOptions elcano_options;
    if (const std::string* generation = options.codec_flag("--generation")) {
      elcano_options.generation = *parse_generation(*generation);  // checked when parsed
    }
    if (const std::string* capture = options.codec_flag("--capture")) {
      elcano_options.capture = *parse_elcano_types(*capture);
    }
    elcano_options.pacing.baud = baud;
    return elcano_options;
  };
  row.lone_virtual_board = [](const std::filesystem::path& firmware, const DeviceOptions& options,
                              devices::DeviceConfig& config) {
    // The host and one board make a ring of one (host TX -> board -> host RX). An unconfigured board
    // captures nothing, so everything would come back undelivered: the board drives the servos from drive
    // messages and answers each with a sensor report (`kLoneVirtualNodeBehaviour`).
    devices::VirtualRingTransport ring;
    devices::RingBoardConfig node;
    node.firmware = firmware;
    elcano::RingNodeSettings settings;
    settings.capture = elcano::TypeSet::of(elcano::Type::drive);
    settings.behaviour_bits = kLoneVirtualNodeBehaviour;
    // ... which the host captures (unless --capture says otherwise).
    auto& host = config.options.get<elcano::DeviceOptions>();
    if (options.codec_flag("--capture") == nullptr) host.capture = elcano::TypeSet::of(elcano::Type::sensor);
    node.eeprom = elcano::encode_node_block(settings, host.generation, host.pacing.baud,
                                            "transport.virtual_ring.boards[0].eeprom");
    ring.boards.push_back(node);
    ring.pacing = transports::Pacing::real_time;
    config.name = firmware.stem().string();
    config.transport = ring;
  };
  row.counters = [](const devices::DeviceClient& client) {
    const elcano::Counters counters = ring_client(client)->counters();
    nlohmann::ordered_json report;
    report["link"] = link_counters_json(counters.link);
    report["ring"] = {{"captured", counters.ring.captured},
                      {"forwarded", counters.ring.forwarded},
                      {"originated", counters.ring.originated},
                      {"undeliverable", counters.ring.undeliverable},
                      {"queue_full_drops", counters.ring.queue_full_drops},
                      {"origins_expired", counters.ring.origins_expired},
                      {"origins_evicted", counters.ring.origins_evicted},
                      {"replies", counters.replies},
                      {"receive_overflows", counters.receive_overflows},
                      {"bytes_written", counters.bytes_written}};
    return report;
  };
  row.shell_help = [](const devices::DeviceConfig&) {
    return std::string(
               "Type a message: D{s 50}{a 25} (drive), S{s 1}{a 2}{b 3}{p 4,5} (sensor), G{n 1}{p 0,0}{b 90} (goal),\n"
               "X{n 1}{p 0,0}{b 90}{s 50} (segment); it is sent into the ring. Captured messages and messages that\n"
               "came back undelivered appear as they arrive. :capture TYPES sets the types the host consumes\n"
               "(drive,sensor,goal,segment or none).\n") +
           kShellCommands;
  };
  row.open_shell = [](const devices::DeviceClient& client, const devices::DeviceConfig& config,
                      const ShellContext& context) {
    return std::unique_ptr<ShellSession>(std::make_unique<ElcanoShell>(ring_client(client), config, context));
  };
  row.monitor_decoder = make_elcano_monitor_decoder;
  return row;
}

}  // namespace

}  // namespace tether::cli

namespace tether::elcano {

/// The command's rows of this codec (collected by tools/tether/CMakeLists.txt: plugin_commands.cpp.in).
std::vector<cli::CodecCommands> command_rows();

std::vector<cli::CodecCommands> command_rows() { return {{cli::elcano_commands()}}; }

}  // namespace tether::elcano
