// The test-only line-echo codec (see line_echo.hpp): wire format, client, and its row of the codec table.
#include "line_echo.hpp"

#include <boost/asio/buffer.hpp>
#include <boost/system/error_code.hpp>

#include <chrono>
#include <utility>

#include "codec_commands.hpp"
#include "tether/demo/workload.hpp"
#include "tether/devices/json_reader.hpp"
#include "tether/transports/transport_error.hpp"

namespace tether::line_echo {

LineDecoder::Event LineDecoder::feed(std::uint8_t byte) {
  if (byte == '\n') {
    const bool oversize = skipping_;
    skipping_ = false;
    line_.swap(pending_);
    pending_.clear();
    if (!line_.empty() && line_.back() == '\r') line_.pop_back();
    return oversize ? Event::oversize : Event::line;
  }
  if (skipping_) return Event::none;
  if (pending_.size() == kMaxLine + 1) {  // room for a '\r' before the newline
    pending_.clear();
    skipping_ = true;
    return Event::none;
  }
  pending_.push_back(static_cast<char>(byte));
  return Event::none;
}

Client::Client(std::shared_ptr<transports::ByteStream> stream, Options options)
    : stream_(std::move(stream)), options_(options) {}

std::string Client::call(std::string_view text, boost::system::error_code& error) {
  const std::lock_guard lock(mutex_);
  if (text.size() > kMaxLine || text.find('\n') != std::string_view::npos) {
    error = boost::system::errc::make_error_code(boost::system::errc::invalid_argument);
    return {};
  }
  const std::string frame = std::string(text) + "\n";
  stream_->write(boost::asio::buffer(frame), error);
  if (error) return {};
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(options_.timeout_ms);
  for (;;) {
    const auto left = deadline - std::chrono::steady_clock::now();
    if (left <= std::chrono::steady_clock::duration::zero()) break;
    std::uint8_t buffer[64];
    const std::size_t size = stream_->read_some(boost::asio::buffer(buffer), left, error);
    if (error == transports::TransportError::timed_out) break;
    if (error) return {};
    for (std::size_t i = 0; i < size; ++i) {
      const LineDecoder::Event event = decoder_.feed(buffer[i]);
      if (event == LineDecoder::Event::oversize) ++counters_.oversize_frames;
      if (event == LineDecoder::Event::line) {
        ++counters_.frames_ok;
        return decoder_.line();  // one call in flight: the next line is its echo
      }
    }
  }
  ++counters_.timeouts;
  error = boost::system::errc::make_error_code(boost::system::errc::timed_out);
  return {};
}

LinkCounters Client::counters() const {
  const std::lock_guard lock(mutex_);
  return counters_;
}

void Client::close() { stream_->close(); }

namespace {

std::shared_ptr<Client> client_of(const devices::DeviceClient& client) {
  return client.get<Client>();
}

const Options& options_of(const devices::DeviceConfig& device) {
  return device.options.get<Options>();
}

class Shell final : public cli::ShellSession {
 public:
  Shell(std::shared_ptr<Client> client, cli::ShellPrinter printer) : client_(std::move(client)), printer_(printer) {}
  void send(const std::string& line) override {
    boost::system::error_code error;
    const std::string echo = client_->call(line, error);
    if (error) {
      printer_.answer({"no echo: " + error.message(), {{"sent", line}, {"error", error.message()}}});
    } else {
      printer_.answer({"echo " + echo, {{"sent", line}, {"echo", echo}}});
    }
  }

 private:
  std::shared_ptr<Client> client_;
  cli::ShellPrinter printer_;
};

class Monitor final : public cli::MonitorDecoder {
 public:
  void feed(std::uint8_t byte, Millis, std::vector<cli::MonitorRecord>& records) override {
    switch (decoder_.feed(byte)) {
      case LineDecoder::Event::line:
        ++counters_.frames_ok;
        records.push_back({"frame", decoder_.line(), {{"text", decoder_.line()}}, true});
        break;
      case LineDecoder::Event::oversize:
        ++counters_.oversize_frames;
        records.push_back({"error", "line over " + std::to_string(kMaxLine) + " characters", {}, false});
        break;
      case LineDecoder::Event::none:
        break;
    }
  }
  LinkCounters counters() const override { return counters_; }

 private:
  LineDecoder decoder_;
  LinkCounters counters_;
};

// `tether demo` / `tether bench`: one line sent, the same line back (another line is a wrong answer).
class Workload final : public demo::Workload {
 public:
  explicit Workload(std::shared_ptr<Client> client) : client_(std::move(client)) {}
  std::string operation() const override { return "line \"op N\" -> the same line back"; }
  demo::Outcome run(unsigned i) override {
    demo::Outcome outcome;
    const std::string sent = "op " + std::to_string(i);
    boost::system::error_code error;
    const std::string echo = client_->call(sent, error);
    if (error) {
      outcome.error = error.message();
    } else if (echo != sent) {
      outcome.wrong = true;
      outcome.cause = "wrong answer";
      outcome.error = "echo \"" + echo + "\" for \"" + sent + "\"";
    } else {
      outcome.ok = true;
    }
    return outcome;
  }
  LinkCounters link() const override { return client_->counters(); }

 private:
  std::shared_ptr<Client> client_;
};

}  // namespace

devices::Codec register_line_echo() {
  static const devices::Codec codec = [] {
    devices::CodecRow row;
    row.name = "line-echo";
    row.client_name = "line_echo::Client";
    row.option_keys = {"timeout_ms"};
    row.parse_options = [](const devices::OptionsContext& context) -> devices::CodecOptions {
      Options options;
      // The configuration parser's own reader: errors name the value's path and what was expected.
      if (const auto object = context.object()) {
        if (const auto timeout = object->optional("timeout_ms")) {
          options.timeout_ms = static_cast<std::uint32_t>(devices::read_unsigned(*timeout, 1, 60000));
        }
      }
      return options;
    };
    row.open = [](std::shared_ptr<transports::ByteStream> stream, const devices::DeviceConfig& device,
                  std::shared_ptr<client::LinkClock>) -> devices::DeviceClient {  // its timeout is steady
      return std::make_shared<Client>(std::move(stream), options_of(device));
    };

    cli::CodecCommands commands;
    commands.image_prefixes = {"line-echo"};
    commands.default_options = [](std::uint32_t, const cli::DeviceOptions&) -> devices::CodecOptions {
      return Options();
    };
    commands.counters = [](const devices::DeviceClient& client) {
      return nlohmann::ordered_json{{"link", cli::link_counters_json(client_of(client)->counters())}};
    };
    commands.shell_help = [](const devices::DeviceConfig& device) {
      return "Type a line; the device sends it back (within " + std::to_string(options_of(device).timeout_ms) +
             " ms). Shell commands: :help, :stats, :quit.";
    };
    commands.open_shell = [](const devices::DeviceClient& client, const devices::DeviceConfig&,
                             const cli::ShellContext& context) {
      return std::unique_ptr<cli::ShellSession>(std::make_unique<Shell>(client_of(client), context.printer));
    };
    commands.monitor_decoder = [](const devices::DeviceConfig&, const cli::DecoderRole&, Millis) {
      return std::unique_ptr<cli::MonitorDecoder>(std::make_unique<Monitor>());
    };
    demo::register_workloads({"line-echo",
                              [](const devices::RoverDevice& device, const devices::DeviceConfig&,
                                 demo::WorkloadKind kind, demo::Payload, std::string& why)
                                  -> std::unique_ptr<demo::Workload> {
                                if (kind != demo::WorkloadKind::servo) {
                                  why = "line-echo has no sensor to read";
                                  return nullptr;
                                }
                                return std::make_unique<Workload>(client_of(device.client));
                              }});
    return cli::register_codec(std::move(row), std::move(commands));
  }();
  return codec;
}

}  // namespace tether::line_echo
