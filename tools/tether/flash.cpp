// `tether flash --port PATH IMAGE [--baud N] [--avrdude PATH] [--json]`: uploads an image through the board's
// bootloader (an Uno's optiboot) with Debian's avrdude, `-c arduino`, written and verified.
//
// Everything that can be checked before talking to the board is: the image (an AVR avr5 ELF or Intel HEX
// whose bytes all lie below optiboot's boot section), avrdude on PATH, the port (exists, can be opened,
// not held exclusively by another program). avrdude's failures are then told apart from its output: no
// bootloader answer (not in sync), another part's signature, a verification error. Exit status 0 when the
// image is written and verified, 2 otherwise (message on stderr).
#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/file.h>
#include <sys/ioctl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "cli_support.hpp"
#include "commands.hpp"
#include "device_options.hpp"
#include "flash_image.hpp"
#include "tether/devices/codecs.hpp"
#include "tether/devices/config.hpp"

extern char** environ;

namespace tether::cli {

namespace {

// The codec whose boards take an EEPROM file (`--eeprom`): the first row with a parser, or null.
const devices::CodecRow* eeprom_file_codec() {
  for (const devices::CodecRow* row : devices::codec_rows()) {
    if (row->eeprom_file.parse) return row;
  }
  return nullptr;
}

// The lines under `--eeprom` in the usage text: what the codec's file is.
std::string eeprom_file_usage() {
  const devices::CodecRow* codec = eeprom_file_codec();
  return codec != nullptr ? std::string(codec->eeprom_file.usage)
                          : "                  a board's EEPROM configuration (no codec of this build takes one)\n";
}

// The usage text around the lines of the codec's EEPROM file (`eeprom_file_usage`).
constexpr const char* kUsageHead =
    "usage: tether flash --port PATH IMAGE [--eeprom NODE.json] [--baud N] [--attempts N] [--reopen N]\n"
    "                    [--avrdude PATH] [--timeout S] [--json]\n"
    "\n"
    "Uploads IMAGE to the board on PATH through its bootloader with avrdude (Debian's; `-c arduino -p\n"
    "atmega328p`), then reads it back to verify. IMAGE is an .elf or .hex path (build/firmware/romi-test.hex),\n"
    "or an image name looked up like `--virtual` (romi-test: its .hex in the firmware folder).\n"
    "An Uno resets when the port opens (DTR) and optiboot waits about 1 s for avrdude; a board without\n"
    "auto-reset needs its reset button pressed just before. avrdude's progress is shown on stderr. When the\n"
    "bootloader stops answering (it gives up after 1 s of silence), avrdude runs again (--reopen).\n"
    "\n"
    "Checked before anything is sent: the image is for an ATmega328P (ELF: AVR machine, avr5; all bytes below\n"
    "0x7E00, where optiboot lives), avrdude is on PATH, the port exists and no program holds it exclusively.\n"
    "\n"
    "  --port PATH     the board's serial port (/dev/ttyACM0) or a `tether sim --bootloader` pty\n"
    "  --eeprom NODE.json\n";
constexpr const char* kUsageTail =
    "  --baud N        the bootloader's speed (default 115200: an Uno's optiboot; 57600 for older boards)\n"
    "  --attempts N    how often avrdude tries to get in sync with the bootloader (default 10, avrdude's;\n"
    "                  each failed try costs avrdude about 5 s)\n"
    "  --reopen N      when the bootloader stops answering mid-upload, open the port again (which resets an\n"
    "                  Uno into it) and run avrdude again, up to N times (default 1; 0..9)\n"
    "  --avrdude PATH  the avrdude program (default: `avrdude` on PATH)\n"
    "  --timeout S     give up when avrdude has not finished after S seconds (default 120)\n"
    "  --json          print {\"port\",\"image\",\"bytes\",\"verified\"} on success\n"
    "\n"
    "Try it without a board:\n"
    "  tether sim --bootloader optiboot      # prints PTY /dev/pts/N: a blank Uno with optiboot\n"
    "  tether flash --port /dev/pts/N romi-test\n"
    "  tether call --port /dev/pts/N --boot-wait 2000 e   # [0,1,2]\n"
    "\n"
    "Exit status: 0 written and verified; 2 usage errors, a bad image, no avrdude, a busy or missing port,\n"
    "no bootloader answer, a verification error.\n";

const CommandText& flash_command() {
  static const CommandText text("flash", std::string(kUsageHead) + eeprom_file_usage() + kUsageTail);
  return text;
}

struct FlashArguments {
  std::string port;
  std::filesystem::path image;
  std::uint32_t baud = 115200;
  std::string avrdude = "avrdude";
  std::uint32_t timeout_ms = 120'000;
  std::uint32_t attempts = 10;
  std::uint32_t reopen = 1;  // avrdude runs after the first one when the bootloader stopped answering
  std::optional<std::filesystem::path> eeprom;  // a board's EEPROM configuration (its codec's file)
  bool json = false;
};

std::optional<int> parse_flash_arguments(int argc, char** argv, FlashArguments& arguments) {
  const CommandText& text = flash_command();
  bool have_image = false;
  const auto own = [&](std::string_view argument, int& i) -> std::optional<int> {
    if (argument == "--json") {
      arguments.json = true;
      return std::nullopt;
    }
    if (argument == "--port" || argument == "--baud" || argument == "--avrdude" || argument == "--timeout" ||
        argument == "--attempts" || argument == "--reopen" || argument == "--eeprom") {
      if (i + 1 >= argc) return text.usage_error(std::string(argument) + " needs a value");
      const std::string_view value = argv[++i];
      if (value.empty()) return text.usage_error(std::string(argument) + " needs a value");
      if (argument == "--port") {
        arguments.port = value;
      } else if (argument == "--avrdude") {
        arguments.avrdude = value;
      } else if (argument == "--eeprom") {
        arguments.eeprom = std::filesystem::path(value);
      } else if (argument == "--attempts") {
        const auto attempts = parse_number(value, 1, 99);
        if (!attempts) return text.usage_error("--attempts needs a number in 1..99, got '" + std::string(value) + "'");
        arguments.attempts = *attempts;
      } else if (argument == "--reopen") {
        const auto reopen = parse_number(value, 0, 9);
        if (!reopen) return text.usage_error("--reopen needs a number in 0..9, got '" + std::string(value) + "'");
        arguments.reopen = *reopen;
      } else if (argument == "--baud") {
        const auto baud = parse_number(value, 300, 2'000'000);
        if (!baud) return text.usage_error("--baud needs a speed in 300..2000000, got '" + std::string(value) + "'");
        arguments.baud = *baud;
      } else {
        const auto timeout = parse_seconds(value, 3600);
        if (!timeout || *timeout == 0) return text.usage_error("--timeout needs seconds in (0, 3600], got '" + std::string(value) + "'");
        arguments.timeout_ms = *timeout;
      }
      return std::nullopt;
    }
    if (argument.starts_with("-")) return text.unexpected_argument(argument);
    if (have_image) return text.usage_error("more than one image given");
    have_image = true;
    std::string name(argument);
    // An image name means its Intel HEX in the firmware folder (the .elf when only that exists).
    if (name.find('/') == std::string::npos && !name.ends_with(".hex") && !name.ends_with(".elf")) {
      const std::filesystem::path hex = std::filesystem::path(firmware_dir()) / (name + ".hex");
      arguments.image = std::filesystem::exists(hex) ? hex : firmware_image(name);
    } else {
      arguments.image = name.find('/') == std::string::npos ? std::filesystem::path(firmware_dir()) / name
                                                            : std::filesystem::path(name);
    }
    return std::nullopt;
  };
  if (const auto status = parse_arguments(argc, argv, text, own)) return status;
  if (arguments.port.empty()) return text.usage_error("no port given (--port PATH)");
  if (!have_image) return text.usage_error("no image given");
  return std::nullopt;
}

// `name` with a `/`: that file if executable; else the first executable `name` on $PATH.
std::optional<std::string> find_program(const std::string& name) {
  if (name.find('/') != std::string::npos) {
    if (::access(name.c_str(), X_OK) == 0) return name;
    return std::nullopt;
  }
  const char* path = std::getenv("PATH");
  std::string_view rest = path != nullptr ? path : "";
  while (!rest.empty()) {
    const std::size_t colon = rest.find(':');
    const std::string_view folder = rest.substr(0, colon);
    rest = colon == std::string_view::npos ? std::string_view() : rest.substr(colon + 1);
    const std::string candidate = (folder.empty() ? std::string(".") : std::string(folder)) + "/" + name;
    struct stat status {};
    if (::stat(candidate.c_str(), &status) == 0 && S_ISREG(status.st_mode) && ::access(candidate.c_str(), X_OK) == 0) {
      return candidate;
    }
  }
  return std::nullopt;
}

// The port exists, can be opened, and no other program holds it exclusively (TIOCEXCL, as Tether's serial
// transport and pyserial's exclusive mode set it; root's open ignores that flag, so it is read back) or
// under a flock(). The empty string when usable, else the message.
std::string check_port(const std::string& port) {
  const int fd = ::open(port.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd < 0) {
    const int error = errno;
    if (error == EBUSY) return port + ": port busy: another program has it open exclusively (close it first)";
    if (error == EACCES) return port + ": permission denied (add yourself to the dialout group)";
    if (error == ENOENT) return port + ": no such port (is the board plugged in?)";
    return port + ": cannot open: " + std::strerror(error);
  }
  std::string problem;
  int exclusive = 0;
  if (!::isatty(fd)) {
    problem = port + ": not a serial port (not a terminal device)";
  } else if (::ioctl(fd, TIOCGEXCL, &exclusive) == 0 && exclusive != 0) {
    problem = port + ": port busy: another program has it open exclusively (close it first)";
  } else if (::flock(fd, LOCK_EX | LOCK_NB) != 0 && errno == EWOULDBLOCK) {
    problem = port + ": port busy: another program holds a lock on it (close it first)";
  }
  ::close(fd);
  return problem;
}

struct AvrdudeRun {
  int status = -1;        // exit status; -1: ended by tether (time limit or a stop signal)
  bool stopped = false;   // ended because tether was asked to stop (SIGINT, SIGTERM)
  std::string output;     // stdout and stderr, merged
};

// How long avrdude (and what it started) gets to end after SIGTERM before SIGKILL: it restores the port.
constexpr std::chrono::milliseconds kAvrdudeGrace{2000};

// Runs avrdude with its output piped through (shown on stderr when `show`), killed after `limit`.
std::optional<AvrdudeRun> run_avrdude(const std::vector<std::string>& arguments, bool show,
                                      std::chrono::milliseconds limit, std::string& error) {
  int pipe_fds[2];
  if (::pipe2(pipe_fds, O_CLOEXEC) != 0) {
    error = std::string("pipe: ") + std::strerror(errno);
    return std::nullopt;
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, pipe_fds[1], STDERR_FILENO);
  // A process group of its own, so that ending it ends what it started too; a terminal's Ctrl-C reaches
  // tether, which ends the group (below).
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETPGROUP);
  posix_spawnattr_setpgroup(&attributes, 0);
  std::vector<std::string> strings = arguments;
  std::vector<char*> argv;
  for (std::string& text : strings) argv.push_back(text.data());
  argv.push_back(nullptr);
  const std::atomic<bool>& stop = catch_stop_signals();
  pid_t pid = -1;
  const int spawned = ::posix_spawn(&pid, argv[0], &actions, &attributes, argv.data(), environ);
  posix_spawnattr_destroy(&attributes);
  posix_spawn_file_actions_destroy(&actions);
  ::close(pipe_fds[1]);
  if (spawned != 0) {
    ::close(pipe_fds[0]);
    error = arguments[0] + ": " + std::strerror(spawned);
    return std::nullopt;
  }
  AvrdudeRun run;
  const auto deadline = std::chrono::steady_clock::now() + limit;
  bool killed = false;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0 || stop) {
      run.stopped = stop;
      killed = true;
      break;
    }
    pollfd readable{pipe_fds[0], POLLIN, 0};
    const int ready = ::poll(&readable, 1, static_cast<int>(std::min<long long>(left.count(), 50)));
    if (ready < 0 && errno == EINTR) continue;
    if (ready <= 0) continue;
    char buffer[4096];
    const ssize_t got = ::read(pipe_fds[0], buffer, sizeof buffer);
    if (got <= 0) break;  // avrdude closed its output: it is ending
    run.output.append(buffer, static_cast<std::size_t>(got));
    if (run.output.size() > (std::size_t{1} << 20)) run.output.erase(0, run.output.size() - (std::size_t{1} << 19));
    if (show) {
      std::fwrite(buffer, 1, static_cast<std::size_t>(got), stderr);
      std::fflush(stderr);
    }
  }
  ::close(pipe_fds[0]);
  int status = 0;
  if (killed) {
    status = end_process_group(pid, kAvrdudeGrace);
  } else {
    while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
    }
  }
  run.status = killed ? -1 : (WIFEXITED(status) ? WEXITSTATUS(status) : -1);
  return run;
}

// Puts a board's EEPROM configuration (the file at `path`, in the format of the codec whose boards take one)
// into the flash page its image copies into EEPROM at boot. False with `error` for a bad file or an image
// that reaches that page.
bool add_eeprom_configuration(transports::HexImage& image, const std::filesystem::path& path, std::string& error) {
  const devices::CodecRow* codec = eeprom_file_codec();
  if (codec == nullptr) {
    error = path.string() + ": no codec of this build takes an EEPROM file";
    return false;
  }
  std::ifstream file(path, std::ios::binary);
  if (!file) {
    error = path.string() + ": " + std::strerror(errno);
    return false;
  }
  const std::string text((std::istreambuf_iterator<char>(file)), std::istreambuf_iterator<char>());
  devices::EepromUpload upload;
  try {
    upload = codec->eeprom_file.parse(text);
  } catch (const devices::ConfigError& failure) {
    error = path.string() + ": " + failure.what();
    return false;
  }
  const std::uint32_t page = upload.flash_address;
  if (image.end() > page) {
    char where[96];
    std::snprintf(where, sizeof where, "the image reaches the configuration page at 0x%04X (it ends at 0x%04X)",
                  static_cast<unsigned>(page), static_cast<unsigned>(image.end()));
    error = std::string(where) + ": --eeprom needs an image below it, such as " +
            std::string(codec->eeprom_file.image);
    return false;
  }
  image.segments.push_back({page, std::move(upload.bytes)});
  return true;
}

bool contains(const std::string& text, std::string_view what) { return text.find(what) != std::string::npos; }

// avrdude got no STK500 answer (at the start or in the middle of the upload), or other bytes than STK500's
// sync/OK answers: the bootloader timed out mid-upload and started the half-written application, which
// talks (an echo image sends the page data back: "protocol expects sync byte 0x14 but got 0x65").
bool lost_bootloader(const AvrdudeRun& run) {
  return run.status > 0 && (contains(run.output, "not in sync") || contains(run.output, "not responding") ||
                            contains(run.output, "protocol expects sync byte") ||
                            contains(run.output, "protocol expects OK byte"));
}

// What went wrong, from avrdude's words (avrdude 7.1).
std::string explain_failure(const AvrdudeRun& run, const FlashArguments& arguments) {
  const std::string& out = run.output;
  if (run.status == -1) {
    return "avrdude did not finish within " + std::to_string(arguments.timeout_ms / 1000) + " s (stopped)";
  }
  if (contains(out, "Device or resource busy")) return arguments.port + ": port busy (avrdude could not open it)";
  if (lost_bootloader(run)) {
    return arguments.port + ": no bootloader answer: the board did not talk STK500 at " + std::to_string(arguments.baud) +
           " baud (an application is running, or it has no optiboot; an Uno resets into it when the port opens, "
           "other boards need the reset button pressed just before flashing)";
  }
  if (contains(out, "signature") && (contains(out, "xpected") || contains(out, "mismatch"))) {
    return arguments.port + ": the board is not an ATmega328P (avrdude read another device signature)";
  }
  if (contains(out, "verification error") || contains(out, "verification mismatch")) {
    return arguments.port + ": verification failed: the flash read back differs from the image";
  }
  if (contains(out, "can't open device") || contains(out, "cannot open")) {
    return arguments.port + ": avrdude cannot open the port";
  }
  return "avrdude failed (exit status " + std::to_string(run.status) + ")";
}

// The last `count` lines of avrdude's output (for the error message's context).
std::string tail_lines(const std::string& text, int count) {
  std::size_t at = text.size();
  while (at > 0 && (text[at - 1] == '\n' || text[at - 1] == '\r')) --at;
  const std::size_t end = at;
  for (int seen = 0; at > 0; --at) {
    if (text[at - 1] == '\n' && ++seen == count) break;
  }
  return text.substr(at, end - at);
}

}  // namespace

int run_flash(int argc, char** argv) {
  FlashArguments arguments;
  if (const auto status = parse_flash_arguments(argc, argv, arguments)) return *status;
  const CommandText& text = flash_command();

  std::string problem;
  auto image = read_flash_image(arguments.image, problem);
  if (!image) return text.fail(problem);
  if (arguments.eeprom && !add_eeprom_configuration(*image, *arguments.eeprom, problem)) return text.fail(problem);
  const auto avrdude = find_program(arguments.avrdude);
  if (!avrdude) {
    return text.fail(arguments.avrdude == "avrdude"
                         ? "avrdude not found on PATH: install Debian's avrdude (tools/setup installs it)"
                         : arguments.avrdude + ": not an executable program");
  }
  problem = check_port(arguments.port);
  if (!problem.empty()) return text.fail(problem);

  // avrdude reads a file: the checked bytes as Intel HEX (the same whatever the input format was).
  const std::filesystem::path hex = std::filesystem::temp_directory_path() /
                                    ("tether-flash-" + std::to_string(::getpid()) + ".hex");
  {
    std::ofstream file(hex, std::ios::trunc);
    file << transports::to_intel_hex(*image);
    if (!file) return text.fail(hex.string() + ": cannot write the temporary image");
  }
  const std::vector<std::string> command = {*avrdude, "-c", "arduino", "-p", "atmega328p", "-P", arguments.port,
                                            "-b", std::to_string(arguments.baud), "-D",
                                            "-x", "attempts=" + std::to_string(arguments.attempts),
                                            "-U", "flash:w:" + hex.string() + ":i"};
  const bool show = !arguments.json || stderr_is_terminal();
  // The bootloader gives up after 1 s without a command (optiboot's watchdog): a host that stalls that
  // long (a loaded machine, a USB hiccup) loses it, before the first sync or between two pages. Opening
  // the port again resets an Uno into its bootloader, so a lost bootloader is worth another run (--reopen):
  // the upload is idempotent and verified either way.
  std::optional<AvrdudeRun> run;
  for (std::uint32_t reopened = 0;; ++reopened) {
    run = run_avrdude(command, show, std::chrono::milliseconds(arguments.timeout_ms), problem);
    if (!run || run->status == 0 || !lost_bootloader(*run) || reopened == arguments.reopen) break;
    std::fprintf(stderr, "tether flash: the bootloader stopped answering; opening the port again (it resets an Uno)\n");
  }
  std::filesystem::remove(hex);
  if (!run) return text.fail(problem);
  if (run->stopped) return text.fail("stopped by a signal: avrdude was ended; the board may hold a partial image");
  if (run->status != 0) {
    const std::string reason = explain_failure(*run, arguments);
    if (!show) std::fprintf(stderr, "%s\n", tail_lines(run->output, 4).c_str());
    return text.fail(reason);
  }
  if (arguments.json) {
    const nlohmann::ordered_json object = {{"port", arguments.port},
                                           {"image", arguments.image.string()},
                                           {"bytes", image->size()},
                                           {"verified", true}};
    out().line(dump(object));
  } else {
    out().line("flashed " + arguments.image.string() + " (" + std::to_string(image->size()) + " bytes) to " +
               arguments.port + ", verified");
  }
  return 0;
}

}  // namespace tether::cli
