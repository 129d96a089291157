// `tether sim IMAGE [--fast] [--link PATH] [--baud N] [--json]`: runs the image (a path, or a name in the
// firmware folder as `--virtual` takes it) on a virtual Arduino Uno and bridges its UART0 to a
// pseudo-terminal that picocom, screen, pyserial or a tether client can open.
//
// Output contract (scripts rely on it): once the port is ready (the firmware has enabled its UART
// receiver, or 5 s passed), exactly one line `PTY <slave path>` on stdout, flushed (with --json instead one
// JSON object `{"pty":"<slave path>","firmware":"<image>"}`); nothing else ever goes to stdout. Runs until
// SIGINT or SIGTERM, then stops the simulation, closes the pty, removes the --link symlink it made, and
// exits 0. Errors: a message on stderr and exit status 2.
#include <signal.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <optional>
#include <string>
#include <string_view>
#include <system_error>
#include <thread>

#include "cli_support.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "flash_image.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace tether::cli {

namespace {

const CommandText& sim_command() {
  static const CommandText text(
      "sim",
      "usage: tether sim IMAGE [--fast] [--link PATH] [--baud N] [--json]\n"
      "       tether sim [IMAGE] --bootloader optiboot|HEX [--link PATH] [--json]\n"
      "\n"
      "Runs IMAGE on a virtual Arduino Uno (ATmega328P, 16 MHz, libsimavr) and bridges its UART0 to a\n"
      "pseudo-terminal. Prints `PTY <path>` once the port is ready; runs until SIGINT/SIGTERM.\n"
      "IMAGE is a path to an .elf (with a `/`: build/firmware/echo.elf) or an image name (echo, romi-test,\n"
      "proxy, elcano-node, ...) in the firmware folder ($TETHER_FIRMWARE_DIR, default: the installed images,\n"
      "else the build's), as `--virtual` takes it.\n"
      "\n"
      "Open the pty with a `tether` subcommand (`tether shell --port /dev/pts/N`) or a terminal program. With\n"
      "picocom on a Romi image (romi-test, romi-blink, ...):\n"
      "  picocom -b 115200 --omap crcrlf --echo /dev/pts/N\n"
      "then type `#e:xxxx` and Enter (answer `#e[0,1,2]:00dc` on romi-test). --omap crcrlf: picocom's Enter\n"
      "sends CR alone, and the firmware wants CR LF (without it, it answers -30 after 1 s); --echo shows what\n"
      "you type. Ctrl-A Ctrl-X leaves picocom.\n"
      "\n"
      "  --fast       run as fast as possible instead of in real time\n"
      "  --link PATH  also make PATH a symlink to the pty (replaces a stale symlink; removed at exit)\n"
      "  --baud N     the host's line speed (default 115200): reported to pty clients, and a warning is\n"
      "               printed if the firmware's UART runs more than 5% off it (a real board would garble)\n"
      "  --bootloader optiboot|HEX\n"
      "               an Uno with a bootloader: HEX (Intel HEX) in the boot section and the reset vector\n"
      "               there; `optiboot` is the build's (firmware/optiboot-atmega328.hex, from Debian's\n"
      "               arduino-core-avr source). Like an Uno, the board resets when a\n"
      "               client opens the pty (the open stands for DTR) and on SIGUSR1 (the reset button), so\n"
      "               `tether flash --port PTY IMAGE` uploads through it. Without IMAGE the application flash\n"
      "               starts blank. Real-time only (the bootloader's 1 s timeout races avrdude's wall clock)\n"
      "  --json       print {\"pty\":\"/dev/pts/N\",\"firmware\":\"<path of the image>\"} instead of\n"
      "               `PTY /dev/pts/N`\n"
      "\n"
      "Exit status: 0 after SIGINT/SIGTERM; 2 usage errors and an image that cannot run.\n");
  return text;
}

struct SimArguments {
  std::filesystem::path image;
  bool fast = false;
  std::optional<std::filesystem::path> link;
  std::uint32_t baud = 115200;
  bool json = false;
  std::filesystem::path bootloader;
};

// Returns an exit status if parsing ends the program (help or error).
std::optional<int> parse_sim_arguments(int argc, char** argv, SimArguments& arguments) {
  const CommandText& text = sim_command();
  bool have_image = false;
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--fast") {
      arguments.fast = true;
    } else if (argument == "--json") {
      arguments.json = true;
    } else if (argument == "--bootloader") {
      if (i + 1 >= argc) return text.usage_error("--bootloader needs `optiboot` or a path to an Intel HEX file");
      const std::string_view value = argv[++i];
      arguments.bootloader = value == "optiboot" ? std::filesystem::path(firmware_dir()) / kOptibootImage : std::filesystem::path(value);
    } else if (argument == "--link" || argument == "--baud") {
      if (i + 1 >= argc) return text.usage_error(std::string(argument) + " needs a value");
      const std::string_view value = argv[++i];
      if (argument == "--link") {
        if (value.empty()) return text.usage_error("--link needs a path");
        arguments.link = std::filesystem::path(value);
      } else {
        const auto baud = parse_number(value, 1, 0xFFFFFFFFu);
        if (!baud) return text.usage_error("--baud needs a positive number, got '" + std::string(value) + "'");
        arguments.baud = *baud;
      }
    } else if (argument.starts_with("-")) {
      return text.usage_error("unknown option " + std::string(argument));
    } else if (have_image) {
      return text.usage_error("more than one image given");
    } else {
      arguments.image = firmware_image(std::string(argument));
      have_image = true;
    }
    return std::nullopt;
  };
  if (const auto status = parse_arguments(argc, argv, text, own)) return status;
  if (!have_image && arguments.bootloader.empty()) return text.usage_error("no image given");
  if (arguments.fast && !arguments.bootloader.empty()) {
    return text.usage_error("--fast and --bootloader: the bootloader's timeout must run in real time");
  }
  return std::nullopt;
}

}  // namespace

int run_sim(int argc, char** argv) {
  SimArguments arguments;
  if (const auto status = parse_sim_arguments(argc, argv, arguments)) return *status;

  // Block the stop signals in every thread (the simulation thread inherits the mask); sigtimedwait
  // below takes them synchronously.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGINT);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGUSR1);  // the reset button (taken only with --bootloader, ignored otherwise)
  if (const int error = pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr); error != 0) {
    return sim_command().fail(std::string("cannot block signals: ") + std::strerror(error));
  }

  transports::VirtualUnoOptions options;
  options.firmware = arguments.image;
  options.pacing = arguments.fast ? transports::Pacing::fast : transports::Pacing::real_time;
  options.pty_baud = arguments.baud;
  options.bootloader = arguments.bootloader;
  options.reset_on_open = !arguments.bootloader.empty();
  std::error_code error;
  std::string message;
  auto uno = transports::VirtualUno::create(options, error, &message);
  if (!uno) return sim_command().fail(message.empty() ? error.message() : message);

  // Open the pty before starting, so the boot output waits in it for the first client.
  const std::string path = uno->open_pty(error);
  if (error) return sim_command().fail("cannot open a pseudo-terminal: " + error.message());
  if (arguments.link) {
    if (make_link(*arguments.link, path, message)) return sim_command().fail(message);
  }
  try {
    uno->start();
  } catch (const std::exception& failure) {
    if (arguments.link) remove_link(*arguments.link, path);
    return sim_command().fail(failure.what());
  }
  // "Ready" means the firmware listens: bytes a client writes before the firmware enables its UART
  // receiver would be lost (a proxy client's opening Reset, a first Romi request), as on a booting board.
  // With a bootloader the port is ready at once: opening it resets the board into the bootloader.
  const auto boot_limit = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (arguments.bootloader.empty() && !uno->uart().rx_enabled && std::chrono::steady_clock::now() < boot_limit) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  if (arguments.bootloader.empty() && !uno->uart().rx_enabled) {
    std::fprintf(stderr, "tether sim: warning: the firmware did not enable its UART receiver within 5 s\n");
  }

  if (arguments.json) {
    const nlohmann::ordered_json object = {{"pty", path}, {"firmware", arguments.image.string()}};
    std::printf("%s\n", dump(object).c_str());
  } else {
    std::printf("PTY %s\n", path.c_str());
  }
  cli::out().flush();

  bool baud_checked = false;
  const timespec poll_interval{0, 200'000'000};
  for (;;) {
    const int signal = sigtimedwait(&stop_signals, nullptr, &poll_interval);
    if (signal == SIGINT || signal == SIGTERM) break;
    if (signal == SIGUSR1) {
      if (!arguments.bootloader.empty()) uno->reset(transports::ResetKind::external);
      continue;
    }
    if (signal < 0 && errno != EAGAIN && errno != EINTR) {
      std::fprintf(stderr, "tether sim: sigtimedwait: %s\n", std::strerror(errno));
      break;
    }
    if (!baud_checked) {
      // Once the firmware has sent something, its baud rate is the one it meant (simavr powers up with
      // TXEN0 set and UBRR0 = 0, so the registers alone say nothing before that).
      const auto uart = uno->uart();
      if (uart.tx_enabled && uno->stats().tx_bytes > 0) {
        baud_checked = true;
        const double off = (static_cast<double>(uart.baud) - arguments.baud) / arguments.baud;
        if (off > 0.05 || off < -0.05) {
          std::fprintf(stderr,
                       "tether sim: warning: the firmware's UART runs at %u bit/s, %.1f%% off the host's %u: "
                       "a real board would garble the bytes\n",
                       uart.baud, off * 100.0, arguments.baud);
        }
      }
    }
  }

  uno->stop();
  if (arguments.link) remove_link(*arguments.link, path);
  return 0;
}

}  // namespace tether::cli
