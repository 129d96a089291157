// CPU cycles of the codecs and the Romi device on the ATmega328P, measured on the virtual Uno (simavr
// counts AVR instruction cycles: exact for the image).
//   1. The bench-codecs image runs each operation between two writes to GPIOR0 (its row id, then 0;
//      firmware/bench-codecs/bench_rows.hpp): cycles between the two writes, minus the empty baseline
//      row. No interrupts; input and output in memory. Byte counts come from the image
//      (`bench_wire_bytes`, the encoders' results), not from this file.
//   2. The romi-bench image (4 handlers, Tether's UART driver, 115200) in a closed loop: the host sends
//      `#e:<id><crc>` as soon as the previous reply's last byte arrived. Turnaround: from the cycle the
//      firmware reads the request's '\n' from UDR0 to the cycle it writes the reply's first byte to UDR0.
//      Calls/s against the wire bound: (request + reply bytes) at the simulated UART's byte time.
//   3. Flash and static RAM of the images (their avr-size -C reports).
//   4. The Arduino libraries as sketches run them (arduino-builder, the Arduino core's Serial and its UART
//      interrupts; firmware/arduino/tests/bench/README.md): per request / frame / message, the host puts
//      the whole input into Serial's receive ring through the core's interrupt, then writes a row id to
//      GPIOR1, and the sketch makes one library call between two GPIOR0 writes with interrupts held
//      (cycles between the writes, the writes' own cycle removed). The closed loop of (2) on the
//      TetherRomi Blink example itself, unchanged (`L[1]` / `L[0]` alternately).
//   5. Whole exchanges on the deployed images (rpc-example, proxy), same method for both: the CPU's awake
//      cycles (`VirtualUnoStats::awake_cycles`: not asleep in the loop's idle) from a request frame's
//      arrival to its answers on the wire, minus what the same time costs the image at rest (its 1 ms clock
//      tick and loop pass); UART interrupts, the loop, decoding, the handler, encoding and queueing
//      included. Median of 20 exchanges. Their turnaround too: from the firmware's UDR0 read of the
//      request's closing 0x00 to its next UDR0 write (the answer's first byte): decode, dispatch, the
//      answer's encoding and framing, awake all along. And an rpc stream at 100 Hz: awake cycles per StreamMessage, and
//      the share of the CPU left asleep (idle) over 1 s of streaming, at rest for comparison.
//   build/benchmarks/tether_avr_cycle_report [--json FILE]
// tools/avr-cycle-table FILE [--write] prints the markdown tables from the JSON (or rewrites them in
// benchmarks/README.md).
#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include "bench_rows.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/transports/virtual_uno.hpp"

namespace {

namespace reg = tether::transports::atmega328p;
using tether::transports::IoAccess;
using tether::transports::VirtualUno;
using tether::transports::VirtualUnoOptions;

struct RowResult {
  const tether_bench::RowInfo* row;
  unsigned bytes = 0;
  double cycles = 0;
};

struct LoopResult {
  unsigned calls = 0;
  unsigned request_bytes = 0;
  unsigned reply_bytes = 0;
  std::uint64_t cycles_per_byte = 0;
  double calls_per_second = 0;
  double wire_bound = 0;  // calls/s with zero turnaround
  std::uint64_t turnaround_min = 0, turnaround_median = 0, turnaround_max = 0;
};

// One measurement of an Arduino sketch (section 4).
struct SketchRow {
  std::string key;
  std::string what;
  unsigned bytes = 0;  // the input (and reply, for Romi) bytes the call handled
  double cycles = 0;
};

struct ImageSize {
  std::string image;
  unsigned flash = 0;
  unsigned ram = 0;
};

std::string json_string(const std::string& text) {
  std::string out = "\"";
  for (const char c : text) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

// Cycles of each row: pairs every write of a row id to GPIOR0 with the next write of 0.
std::optional<std::vector<std::pair<int, std::uint64_t>>> marker_spans(const std::vector<IoAccess>& accesses) {
  std::vector<std::pair<int, std::uint64_t>> spans;
  const IoAccess* open = nullptr;
  for (const IoAccess& access : accesses) {
    if (!access.write) continue;
    if (access.value != 0) {
      if (open != nullptr) return std::nullopt;  // nested markers: the image is broken
      open = &access;
    } else if (open != nullptr) {
      spans.emplace_back(open->value, access.cycle - open->cycle);
      open = nullptr;
    }
  }
  return spans;
}

int measure_rows(std::vector<RowResult>& results, double& baseline) {
  VirtualUnoOptions options;
  options.firmware = TETHER_FIRMWARE_DIR "/bench-codecs.elf";
  VirtualUno uno(options);
  uno.watch_io(reg::GPIOR0);
  for (int i = 0; i < 50 && uno.cpu_state() != tether::transports::CpuState::halted; ++i) {
    uno.run_for(std::chrono::milliseconds(10));
  }
  const auto symbol = uno.symbol("bench_wire_bytes");
  if (!symbol || symbol->space != tether::transports::FirmwareSymbol::Space::data ||
      symbol->size < tether_bench::kRowCount) {
    std::fprintf(stderr, "bench-codecs.elf has no bench_wire_bytes[%d] in SRAM: rebuild the firmware\n",
                 tether_bench::kRowCount);
    return 1;
  }
  const std::vector<std::uint8_t> wire_bytes =
      uno.read_memory(static_cast<std::uint16_t>(symbol->address), tether_bench::kRowCount);
  const auto spans = marker_spans(uno.io_accesses(reg::GPIOR0));
  if (!spans) {
    std::fprintf(stderr, "bench-codecs.elf wrote a row id to GPIOR0 inside another row\n");
    return 1;
  }
  std::vector<std::optional<std::uint64_t>> cycles(tether_bench::kRowCount);
  for (const auto& [row, span] : *spans) {
    if (row > 0 && row < tether_bench::kRowCount) cycles[static_cast<std::size_t>(row)] = span;
  }
  if (!cycles[tether_bench::kBaseline]) {
    std::fprintf(stderr, "bench-codecs.elf did not run its baseline row\n");
    return 1;
  }
  baseline = static_cast<double>(*cycles[tether_bench::kBaseline]);
  int status = 0;
  for (const auto& row : tether_bench::kRows) {
    RowResult result{&row};
    result.bytes = wire_bytes[row.id];
    if (!cycles[row.id] || result.bytes == 0) {
      std::fprintf(stderr, "%s: the image did not run this operation, or it failed\n", row.what);
      status = 1;
      continue;
    }
    result.cycles = static_cast<double>(*cycles[row.id]) - baseline;
    results.push_back(result);
  }
  return status;
}

// CRC-8/SMBUS (poly 0x07, init 0), the Romi frame check, for building requests here.
std::uint8_t crc8(const std::string& text) {
  std::uint8_t crc = 0;
  for (const char c : text) {
    crc = static_cast<std::uint8_t>(crc ^ static_cast<std::uint8_t>(c));
    for (int bit = 0; bit < 8; ++bit) {
      crc = static_cast<std::uint8_t>((crc & 0x80) != 0 ? (crc << 1) ^ 0x07 : crc << 1);
    }
  }
  return crc;
}

std::string romi_request(const std::string& payload, std::uint8_t id) {
  char hex[8];
  std::string frame = "#" + payload + ":";
  std::snprintf(hex, sizeof hex, "%02x", id);
  frame += hex;
  std::snprintf(hex, sizeof hex, "%02x", crc8(frame));
  return frame + hex + "\r\n";
}

// The host sends a request as soon as the previous reply's last byte arrived; `payloads` are sent in turn
// and each reply must start with `#<payload's opcode>` + `reply_body` + ':'.
int closed_loop(LoopResult& result, const std::string& firmware, const std::vector<std::string>& payloads,
                const std::string& reply_body) {
  VirtualUnoOptions options;
  options.firmware = firmware;
  options.quantum = std::chrono::microseconds(1);  // the host answers within 16 cycles of a reply's end
  VirtualUno uno(options);
  uno.run_for(std::chrono::milliseconds(20));  // boot: the UART is up
  uno.watch_io(reg::UDR0);
  constexpr auto kWindow = std::chrono::milliseconds(500);
  std::uint8_t id = 1;
  std::size_t turn = 0;
  std::string reply;
  std::uint64_t first_send = uno.cycles();
  std::uint64_t last_reply = 0;
  bool bad_reply = false;
  std::string request = romi_request(payloads[0], id);
  result.request_bytes = static_cast<unsigned>(request.size());
  uno.set_output_handler([&](const std::uint8_t* data, std::size_t size) {
    for (std::size_t i = 0; i < size; ++i) {
      reply += static_cast<char>(data[i]);
      if (data[i] != '\n') continue;
      // Appended, not `"#" + ...`: g++ 12 at -O3 warns a bogus overlap (-Wrestrict) there.
      std::string expected = "#";
      expected += payloads[turn].substr(0, 1);
      expected += reply_body;
      expected += ':';
      if (reply.rfind(expected, 0) != 0) bad_reply = true;
      result.reply_bytes = static_cast<unsigned>(reply.size());
      reply.clear();
      ++result.calls;
      last_reply = uno.cycles();
      id = static_cast<std::uint8_t>(id == 255 ? 1 : id + 1);
      turn = (turn + 1) % payloads.size();
      uno.write(romi_request(payloads[turn], id));
    }
  });
  uno.write(request);
  uno.run_for(kWindow);
  uno.set_output_handler({});
  if (bad_reply || result.calls == 0) {
    std::fprintf(stderr, "%s did not answer every request with %s in the closed loop\n", firmware.c_str(),
                 reply_body.c_str());
    return 1;
  }
  result.cycles_per_byte = uno.uart().cycles_per_byte;
  const double seconds = static_cast<double>(last_reply - first_send) / uno.frequency_hz();
  result.calls_per_second = result.calls / seconds;
  result.wire_bound = static_cast<double>(uno.frequency_hz()) /
                      static_cast<double>(result.cycles_per_byte * (result.request_bytes + result.reply_bytes));
  // Turnaround of each call: the read of a request's '\n', then the next write.
  std::vector<std::uint64_t> turnarounds;
  std::optional<std::uint64_t> last_byte_read;
  for (const IoAccess& access : uno.io_accesses(reg::UDR0)) {
    if (!access.write && access.value == '\n') last_byte_read = access.cycle;
    if (access.write && last_byte_read) {
      turnarounds.push_back(access.cycle - *last_byte_read);
      last_byte_read.reset();
    }
  }
  if (turnarounds.empty()) {
    std::fprintf(stderr, "%s: no UDR0 read of a '\\n' followed by a write\n", firmware.c_str());
    return 1;
  }
  std::sort(turnarounds.begin(), turnarounds.end());
  result.turnaround_min = turnarounds.front();
  result.turnaround_median = turnarounds[turnarounds.size() / 2];
  result.turnaround_max = turnarounds.back();
  return 0;
}

// --- 4. The Arduino libraries as sketches run them --------------------------------------------------------

constexpr std::uint16_t kGpior1 = 0x4A;  // the host's row id for the sketch (bench/README.md)
constexpr std::uint16_t kGpior2 = 0x4B;  // the ElcanoBench sketch's outcome + 1

std::string sketch_path(const std::string& name) { return std::string(TETHER_ARDUINO_SKETCH_DIR "/") + name + ".elf"; }

// A bench sketch on the virtual Uno: `call` puts `input` into Serial's receive ring (the core's UART
// interrupt takes each byte as the wire delivers it), then has the sketch run its measured call once.
class BenchSketch {
 public:
  explicit BenchSketch(const std::string& name) : uno_(options(name)) {
    uno_.run_for(std::chrono::milliseconds(30));  // boot: setup() done, Serial up
    uno_.watch_io(reg::GPIOR0);
    uno_.set_output_handler([this](const std::uint8_t* data, std::size_t size) {
      output_.append(reinterpret_cast<const char*>(data), size);
    });
  }
  ~BenchSketch() { uno_.set_output_handler({}); }

  // Cycles of the call that handled `input` (std::nullopt: no single marked call); `output` is what the
  // sketch sent meanwhile.
  std::optional<double> call(const std::string& input, std::uint8_t row, std::string& output) {
    output_.clear();
    const std::uint64_t byte_cycles = uno_.uart().cycles_per_byte;
    uno_.write(input);
    uno_.run_for(uno_.to_duration(byte_cycles * (input.size() + 2)));  // every byte in the ring
    const std::size_t before = uno_.io_accesses(reg::GPIOR0).size();
    uno_.io_write(kGpior1, row);
    uno_.run_for(std::chrono::milliseconds(5));  // the call, then its output on the wire
    const std::vector<IoAccess> accesses = uno_.io_accesses(reg::GPIOR0);
    output = output_;
    // Exactly two writes: the row id, then 0.
    if (accesses.size() != before + 2 || !accesses[before].write || accesses[before].value != row ||
        accesses[before + 1].value != 0) {
      return std::nullopt;
    }
    // The first write's own cycle (OUT) is inside the span.
    return static_cast<double>(accesses[before + 1].cycle - accesses[before].cycle - 1);
  }
  VirtualUno& uno() { return uno_; }

 private:
  static VirtualUnoOptions options(const std::string& name) {
    VirtualUnoOptions options;
    options.firmware = sketch_path(name);
    options.quantum = std::chrono::microseconds(10);
    return options;
  }
  VirtualUno uno_;
  std::string output_;
};

int measure_sketches(std::vector<SketchRow>& rows) {
  int status = 0;
  const auto fail = [&](const char* what) {
    std::fprintf(stderr, "%s: the sketch did not run this call, or it failed\n", what);
    status = 1;
  };
  {  // TetherRomi: the Blink example's structure with romi-bench's handlers
    BenchSketch sketch("bench.RomiBench");
    struct Request {
      const char* key;
      const char* payload;
      const char* body;
      const char* what;
    };
    const Request requests[] = {
        {"arduino.romi.request.a", "a", "[0]", "TetherRomi (Arduino core): #a in -> #a[0] out"},
        {"arduino.romi.request.e", "e", "[0,1,2]", "TetherRomi (Arduino core): #e in -> #e[0,1,2] out"},
        {"arduino.romi.request.c", "c[1000,-2000]", "[0]", "TetherRomi (Arduino core): #c[1000,-2000] in -> #c[0] out"},
        {"arduino.romi.request.d", "d[\"Hello there\"]", "[0]",
         "TetherRomi (Arduino core): #d[\"Hello there\"] in -> #d[0] out"},
    };
    // One request first, not measured: every row then finds the state the chip is in after its first
    // reply (simavr 1.6 leaves UDRE0 clear after reset, where the ATmega328P sets it, so the first reply
    // after boot found the UART "busy" and queued its '#': 11 cycles more on the first row alone) and the
    // device holding a cached reply (as every later row does).
    std::string warm_up;
    if (!sketch.call(romi_request("e", 0xff), 1, warm_up) || warm_up.empty()) fail("TetherRomi: warm-up request");
    std::uint8_t id = 1;
    for (const Request& request : requests) {
      const std::string in = romi_request(request.payload, id);
      std::string out;
      const auto cycles = sketch.call(in, 1, out);
      std::string expected = "#";  // appended: see closed_loop
      expected += request.payload[0];
      expected += request.body;
      expected += ':';
      if (!cycles || out.rfind(expected, 0) != 0 || out.back() != '\n') {
        fail(request.what);
      } else {
        rows.push_back({request.key, request.what, static_cast<unsigned>(in.size() + out.size()), *cycles});
      }
      ++id;
    }
  }
  {  // TetherProxy: the Proxy example
    BenchSketch sketch("bench.ProxyBench");
    std::uint8_t payload[32];
    for (std::size_t i = 0; i < sizeof payload; ++i) payload[i] = static_cast<std::uint8_t>(i * 37 + 1);
    std::uint8_t frame[48];
    const std::size_t size = tether::proxy::encode_frame(tether::ByteView(payload, sizeof payload),
                                                         tether::proxy::Integrity::crc16, true,
                                                         tether::MutableByteView(frame, sizeof frame))
                                 .value();
    // A data byte (not a COBS code byte, never 0 before or after) changed: the whole frame is decoded and
    // its CRC-16 checked, and the frame dropped there (nothing else runs).
    std::size_t code = 1;  // frame[0] is the leading delimiter
    std::size_t corrupt = 0;
    for (std::size_t i = 1; i + 1 < size && corrupt == 0; ++i) {
      if (i == code) {
        code += frame[i];
      } else if (i > 8 && frame[i] > 1) {
        corrupt = i;
      }
    }
    frame[corrupt] ^= 1;
    const std::string bad_crc(reinterpret_cast<const char*>(frame), size);
    std::string out;
    auto cycles = sketch.call(bad_crc, 1, out);
    const char* decode = "TetherProxy (Arduino core): decode frame, 32 B payload (CRC-16 checked, dropped)";
    if (!cycles || !out.empty()) {
      fail(decode);
    } else {
      rows.push_back({"arduino.proxy.decode.32", decode, static_cast<unsigned>(size), *cycles});
    }
    {  // the same frame with Serial passed as a Stream& (recognised as the core's port)
      BenchSketch stream_sketch("bench.ProxyStreamBench");
      const char* what = "TetherProxy (Arduino core), Serial as a plain Stream&: decode frame, 32 B payload (dropped)";
      const auto stream_cycles = stream_sketch.call(bad_crc, 1, out);
      if (!stream_cycles || !out.empty()) {
        fail(what);
      } else {
        rows.push_back({"arduino.proxy.decode.32.stream", what, static_cast<unsigned>(size), *stream_cycles});
      }
    }
    {  // through the path of any other Stream: a sketch's own Stream relaying Serial
      BenchSketch relay_sketch("bench.ProxyOwnStreamBench");
      const char* what = "TetherProxy (Arduino core) over a sketch's own Stream: decode frame, 32 B payload (dropped)";
      const auto relay_cycles = relay_sketch.call(bad_crc, 1, out);
      if (!relay_cycles || !out.empty()) {
        fail(what);
      } else {
        rows.push_back({"arduino.proxy.decode.32.own_stream", what, static_cast<unsigned>(size), *relay_cycles});
      }
    }
    {  // the deployed variant (no CRC): a 32-byte block announced as 47, so the frame is decoded to its
       // delimiter and dropped there (framing error; nothing else runs)
      BenchSketch compat_sketch("bench.ProxyCompatBench");
      std::string compat(1, '\0');
      compat += static_cast<char>(48);
      for (std::size_t i = 0; i < sizeof payload; ++i) compat += static_cast<char>(payload[i]);
      compat += '\0';
      const char* what = "TetherProxyCompat (Arduino core): decode frame, 32 B payload (no CRC, dropped)";
      const auto compat_cycles = compat_sketch.call(compat, 1, out);
      if (!compat_cycles || !out.empty()) {
        fail(what);
      } else {
        rows.push_back({"arduino.proxy_compat.decode.32", what, static_cast<unsigned>(compat.size()), *compat_cycles});
      }
    }
    const char* encode = "TetherProxy (Arduino core): encode frame, 32 B payload, queued on Serial";
    cycles = sketch.call("", 255, out);
    if (!cycles || out.size() != size) {
      fail(encode);
    } else {
      rows.push_back({"arduino.proxy.encode.32", encode, static_cast<unsigned>(size), *cycles});
    }
    // Ping{messageId 1}: 08 01 12 00; answered by Ack{messageId 1}.
    const std::uint8_t ping[] = {0x08, 0x01, 0x12, 0x00};
    const std::size_t ping_size = tether::proxy::encode_frame(tether::ByteView(ping, sizeof ping),
                                                              tether::proxy::Integrity::crc16, true,
                                                              tether::MutableByteView(frame, sizeof frame))
                                      .value();
    const char* handle = "TetherProxy (Arduino core): Ping in -> Ack out (whole poll())";
    cycles = sketch.call(std::string(reinterpret_cast<const char*>(frame), ping_size), 1, out);
    if (!cycles || out.empty() || out.back() != 0) {
      fail(handle);
    } else {
      rows.push_back({"arduino.proxy.ping", handle, static_cast<unsigned>(ping_size + out.size()), *cycles});
    }
  }
  {  // TetherElcano: the DriveNode example (capturing drives and segments)
    BenchSketch sketch("bench.ElcanoBench");
    struct Message {
      const char* key;
      const char* text;
      const char* what;
    };
    const Message messages[] = {
        {"arduino.elcano.b.read.drive", "D{s 50}{a 25}\n", "TetherElcano (Arduino core): update() captures D{s 50}{a 25}"},
        {"arduino.elcano.b.read.segment", "X{n 4}{s 160}{b 80}{p 3200,-64000}\n",
         "TetherElcano (Arduino core): update() captures X{n 4}...{p 3200,-64000}"},
    };
    for (const Message& message : messages) {
      std::string out;
      const auto cycles = sketch.call(message.text, 1, out);
      // ParseStateError::success + 1
      if (!cycles || sketch.uno().io_read(kGpior2) != 1) {
        fail(message.what);
      } else {
        rows.push_back({message.key, message.what, static_cast<unsigned>(std::strlen(message.text)), *cycles});
      }
    }
  }
  return status;
}

// avr-size -C writes "Program:   6804 bytes (20.8% Full)" and "Data:        710 bytes (34.7% Full)".
std::optional<ImageSize> image_size(const std::string& image) {
  std::ifstream file(std::string(TETHER_FIRMWARE_DIR "/") + image + ".size.txt");
  if (!file) return std::nullopt;
  ImageSize size{image};
  bool flash = false, ram = false;
  std::string line;
  while (std::getline(file, line)) {
    unsigned value = 0;
    if (std::sscanf(line.c_str(), "Program: %u", &value) == 1) size.flash = value, flash = true;
    if (std::sscanf(line.c_str(), "Data: %u", &value) == 1) size.ram = value, ram = true;
  }
  if (!flash || !ram) return std::nullopt;
  return size;
}

// --- 5. Whole exchanges on the deployed images ------------------------------------------------------------

// Protobuf encoding by hand (the images' schemas are nanopb's; the report has no libprotobuf classes of them).
void put_varint(std::string& out, std::uint64_t value) {
  do {
    auto byte = static_cast<std::uint8_t>(value & 0x7F);
    value >>= 7;
    if (value != 0) byte |= 0x80;
    out += static_cast<char>(byte);
  } while (value != 0);
}
void put_uint(std::string& out, unsigned field, std::uint64_t value) {
  put_varint(out, field << 3);
  put_varint(out, value);
}
void put_int32(std::string& out, unsigned field, std::int32_t value) {  // int32: negative as 10 bytes
  put_uint(out, field, static_cast<std::uint64_t>(static_cast<std::int64_t>(value)));
}
void put_bytes(std::string& out, unsigned field, const std::string& bytes) {
  put_varint(out, (field << 3) | 2);
  put_varint(out, bytes.size());
  out += bytes;
}
std::string frame_of(const std::string& payload) {
  std::uint8_t frame[300];
  const auto size = tether::proxy::encode_frame(
                        tether::ByteView(reinterpret_cast<const std::uint8_t*>(payload.data()), payload.size()),
                        tether::proxy::Integrity::crc16, true, tether::MutableByteView(frame, sizeof frame))
                        .value();
  return std::string(reinterpret_cast<const char*>(frame), size);
}

// rpc: HostMessage{id, call{method, request}} / {id, open{method, request, period_ms}}; the method indices
// of arm.proto (MoveJoint 0, Watch 1) and servos.proto (Move 0, Watch 1), whose requests have the same fields.
std::string rpc_move_joint(std::uint32_t id, std::uint32_t joint, std::int32_t angle) {
  std::string request, call, message;
  put_uint(request, 1, joint);
  put_int32(request, 2, angle);
  put_uint(call, 1, 0);
  put_bytes(call, 2, request);
  put_uint(message, 1, id);
  put_bytes(message, 3, call);
  return frame_of(message);
}
std::string rpc_open_watch(std::uint32_t id, std::uint32_t period_ms) {
  std::string open, message;
  put_uint(open, 1, 1);
  put_uint(open, 3, period_ms);
  put_uint(message, 1, id);
  put_bytes(message, 4, open);
  return frame_of(message);
}
// proxy: ArduinoIn{messageId, servoInit{pin, safePosition}} / {messageId, servoControl{pin, position}}.
std::string proxy_servo(std::uint32_t id, bool init, std::int32_t position) {
  std::string body, message;
  put_uint(body, 1, 9);
  put_int32(body, 2, position);
  put_uint(message, 1, id);
  put_bytes(message, init ? 3 : 4, body);
  return frame_of(message);
}

struct ExchangeResult {
  std::string key;
  std::string what;
  unsigned bytes = 0;  // request + answers on the wire
  double cycles = 0;   // awake cycles of one exchange (median)
};

// An image on the virtual Uno with its output counted in frames (0x00 delimiters).
class ImageBench {
 public:
  explicit ImageBench(const std::string& image) : uno_(options(image)) {
    uno_.set_output_handler([this](const std::uint8_t* data, std::size_t size) {
      for (std::size_t i = 0; i < size; ++i) {
        ++bytes_;
        if (data[i] == 0) ++delimiters_;
      }
    });
    uno_.run_for(std::chrono::milliseconds(50));  // boot, ResetEvent / banner
    uno_.watch_io(reg::UDR0);
  }
  ~ImageBench() { uno_.set_output_handler({}); }
  // Awake cycles per millisecond at rest.
  double rest_per_ms(int ms) {
    const std::uint64_t before = uno_.stats().awake_cycles;
    uno_.run_for(std::chrono::milliseconds(ms));
    return static_cast<double>(uno_.stats().awake_cycles - before) / ms;
  }
  // Sends `frame` and runs `ms`; the awake cycles over that time minus `rest` per ms, the bytes that came
  // out and the frames (a leading and a closing delimiter each: frames are counted by pairs elsewhere).
  double exchange(const std::string& frame, int ms, double rest, unsigned& out_bytes, unsigned& out_delimiters) {
    const std::uint64_t before = uno_.stats().awake_cycles;
    const unsigned bytes = bytes_, delimiters = delimiters_;
    const std::size_t accesses = uno_.io_accesses(reg::UDR0).size();
    uno_.write(frame);
    uno_.run_for(std::chrono::milliseconds(ms));
    out_bytes = bytes_ - bytes;
    out_delimiters = delimiters_ - delimiters;
    // Turnaround: from the UDR0 read of the request's closing 0x00 to the next UDR0 write.
    const std::vector<IoAccess> io = uno_.io_accesses(reg::UDR0);
    turnaround_ = 0;
    std::optional<std::uint64_t> delimiter_read;
    for (std::size_t i = accesses; i < io.size(); ++i) {
      if (!io[i].write && io[i].value == 0) delimiter_read = io[i].cycle;
      if (io[i].write && delimiter_read) {
        turnaround_ = io[i].cycle - *delimiter_read;
        break;
      }
    }
    return static_cast<double>(uno_.stats().awake_cycles - before) - rest * ms;
  }
  // Cycles from the last exchange's request delimiter read to its first answer byte written (0: none).
  std::uint64_t turnaround() const { return turnaround_; }
  VirtualUno& uno() { return uno_; }

 private:
  static VirtualUnoOptions options(const std::string& image) {
    VirtualUnoOptions options;
    options.firmware = std::string(TETHER_FIRMWARE_DIR "/") + image + ".elf";
    options.quantum = std::chrono::microseconds(100);
    return options;
  }
  VirtualUno uno_;
  unsigned bytes_ = 0;
  unsigned delimiters_ = 0;
  std::uint64_t turnaround_ = 0;
};

double median(std::vector<double> values) {
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

// The CPU asleep on an rpc image at rest and while it streams at 100 Hz.
struct StreamIdle {
  std::string image;
  double at_rest = 0;
  double streaming = 0;
};

// An rpc image's rows (its first method is unary with JointRequest's fields, its second a stream: the
// frames are the same for rpc-example and rpc-servos): a call exchange and its turnaround, a stream message
// at 100 Hz, and the idle time left while streaming. `key` prefixes the rows' keys, `call` and `stream` name
// the exchanges in the rows' texts.
int measure_rpc_image(const std::string& image, const std::string& key, const std::string& call,
                      const std::string& stream, std::vector<ExchangeResult>& rows, std::vector<StreamIdle>& idle) {
  constexpr int kExchangeMs = 12;  // request in (<= 3 ms), answers out (<= 4 ms) at 115200, and margin
  int status = 0;
  ImageBench bench(image);
  std::vector<double> cycles, turnarounds;
  unsigned bytes = 0;
  std::size_t frame_size = 0;
  for (int i = 0; i < 21; ++i) {
    const double rest = bench.rest_per_ms(20);
    const std::string frame = rpc_move_joint(static_cast<std::uint32_t>(1000 + i), 2, -4500 + i);
    frame_size = frame.size();
    unsigned out = 0, delimiters = 0;
    const double spent = bench.exchange(frame, kExchangeMs, rest, out, delimiters);
    if (delimiters < 2) {  // Reply and Ack (each frame ends with 0x00; the device writes no leading one)
      std::fprintf(stderr, "%s did not answer its first method (%u bytes out)\n", image.c_str(), out);
      status = 1;
      break;
    }
    if (i > 0) {  // the first after boot includes one-off work
      cycles.push_back(spent);
      turnarounds.push_back(static_cast<double>(bench.turnaround()));
    }
    bytes = static_cast<unsigned>(frame.size()) + out;
  }
  if (!cycles.empty()) {
    rows.push_back({key + ".move_joint", image + ": " + call + " in -> Reply + Ack out (whole loop, UART interrupts)",
                    bytes, median(cycles)});
    rows.push_back({key + ".move_joint.turnaround",
                    image + ": " + call + " turnaround, request's 0x00 read -> Reply's first byte written",
                    static_cast<unsigned>(frame_size), median(turnarounds)});
  }
  // The stream: its second method at 10 ms for 1 s, against 1 s at rest.
  const double rest = bench.rest_per_ms(1000);
  StreamIdle measured{image};
  measured.at_rest = 1.0 - rest * 1000.0 / bench.uno().frequency_hz();
  unsigned out = 0, delimiters = 0;
  bench.exchange(rpc_open_watch(5000, 10), 100, rest, out, delimiters);  // opened, streaming
  const std::uint64_t before = bench.uno().stats().awake_cycles;
  const double spent = bench.exchange("", 1000, rest, out, delimiters);
  const double awake = static_cast<double>(bench.uno().stats().awake_cycles - before);
  measured.streaming = 1.0 - awake / bench.uno().frequency_hz();
  if (delimiters < 95) {
    std::fprintf(stderr, "%s streamed %u frames in 1 s at 10 ms\n", image.c_str(), delimiters);
    status = 1;
  } else {
    rows.push_back({key + ".stream_message", image + ": " + stream + " at 100 Hz, per StreamMessage", out / delimiters,
                    spent / delimiters});
    idle.push_back(measured);
  }
  return status;
}

int measure_exchanges(std::vector<ExchangeResult>& rows, std::vector<StreamIdle>& idle) {
  int status = 0;
  constexpr int kExchangeMs = 12;  // request in (<= 3 ms), answers out (<= 4 ms) at 115200, and margin
  status |= measure_rpc_image("rpc-example", "image.rpc", "MoveJoint{2, -4500}", "Watch (State, 4 angles)", rows, idle);
  status |= measure_rpc_image("rpc-servos", "image.rpc_servos", "Move{2, -4500}", "Watch (Telemetry, 4 angles)", rows,
                              idle);
  {
    ImageBench bench("proxy");
    unsigned out = 0, delimiters = 0;
    bench.exchange(proxy_servo(1, true, 90), kExchangeMs, 0, out, delimiters);  // ServoInit{9, 90}
    std::vector<double> cycles, turnarounds;
    unsigned bytes = 0;
    std::size_t frame_size = 0;
    for (int i = 0; i < 21; ++i) {
      const double rest = bench.rest_per_ms(20);
      const std::string frame = proxy_servo(static_cast<std::uint32_t>(2 + i), false, 100 + i);
      frame_size = frame.size();
      const double spent = bench.exchange(frame, kExchangeMs, rest, out, delimiters);
      if (delimiters < 2) {  // PinState and Ack
        std::fprintf(stderr, "proxy did not answer ServoControl (%u bytes out)\n", out);
        status = 1;
        break;
      }
      if (i > 0) {
        cycles.push_back(spent);
        turnarounds.push_back(static_cast<double>(bench.turnaround()));
      }
      bytes = static_cast<unsigned>(frame.size()) + out;
    }
    if (!cycles.empty()) {
      rows.push_back({"image.proxy.servo_control",
                      "proxy: ServoControl{9, 100} in -> PinState + Ack out (whole loop, UART interrupts)", bytes,
                      median(cycles)});
      rows.push_back({"image.proxy.servo_control.turnaround",
                      "proxy: ServoControl turnaround, request's 0x00 read -> PinState's first byte written",
                      static_cast<unsigned>(frame_size), median(turnarounds)});
    }
  }
  return status;
}

}  // namespace

int main(int argc, char** argv) {
  const char* json_path = nullptr;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--json") == 0 && i + 1 < argc) {
      json_path = argv[++i];
    } else {
      std::fprintf(stderr, "usage: %s [--json FILE]\n", argv[0]);
      return 2;
    }
  }
  std::vector<RowResult> rows;
  double baseline = 0;
  int status = measure_rows(rows, baseline);
  std::printf("ATmega328P @ 16 MHz, avr-gcc 5.4 -Os LTO (simavr cycles between GPIOR0 markers; baseline %.0f "
              "cycles removed)\n",
              baseline);
  std::printf("%-52s %6s %8s %8s %12s\n", "operation", "bytes", "cycles", "us", "cycles/byte");
  for (const RowResult& r : rows) {
    std::printf("%-52s %6u %8.0f %8.1f %12.1f\n", r.row->what, r.bytes, r.cycles, r.cycles / 16.0,
                r.cycles / r.bytes);
  }

  LoopResult loop;
  const int loop_status = closed_loop(loop, TETHER_FIRMWARE_DIR "/romi-bench.elf", {"e"}, "[0,1,2]");
  status |= loop_status;
  if (loop_status == 0) {
    std::printf("\nromi-bench closed loop at 115200 (#e, %u + %u bytes, %llu cycles per byte on the wire):\n",
                loop.request_bytes, loop.reply_bytes, static_cast<unsigned long long>(loop.cycles_per_byte));
    std::printf("  turnaround (UDR0 read of '\\n' -> first UDR0 write): min %llu, median %llu, max %llu cycles\n",
                static_cast<unsigned long long>(loop.turnaround_min),
                static_cast<unsigned long long>(loop.turnaround_median),
                static_cast<unsigned long long>(loop.turnaround_max));
    std::printf("  %u calls, %.1f calls/s, wire bound %.1f calls/s: %.1f %%\n", loop.calls, loop.calls_per_second,
                loop.wire_bound, 100.0 * loop.calls_per_second / loop.wire_bound);
  }

  std::vector<ExchangeResult> exchanges;
  std::vector<StreamIdle> idle;
  status |= measure_exchanges(exchanges, idle);
  std::printf("\nWhole exchanges on the images (awake cycles, the image at rest removed; median of 20)\n");
  std::printf("%-84s %6s %8s %12s\n", "exchange", "bytes", "cycles", "cycles/byte");
  for (const ExchangeResult& r : exchanges) {
    std::printf("%-84s %6u %8.0f %12.1f\n", r.what.c_str(), r.bytes, r.cycles, r.cycles / r.bytes);
  }
  for (const StreamIdle& i : idle) {
    std::printf("%s CPU asleep (idle): %.2f %% at rest, %.2f %% streaming at 100 Hz (%.2f %% of the idle time left)\n",
                i.image.c_str(), 100.0 * i.at_rest, 100.0 * i.streaming, 100.0 * i.streaming / i.at_rest);
  }

  std::vector<ImageSize> sizes;
  std::printf("\n%-16s %8s %8s\n", "image", "flash B", "RAM B");
  for (const char* image : {"romi-bench", "romi-blink", "romi-test", "proxy", "proxy-compat", "elcano-node", "rpc-example",
                            "rpc-servos"}) {
    if (const auto size = image_size(image)) {
      sizes.push_back(*size);
      std::printf("%-16s %8u %8u\n", image, size->flash, size->ram);
    } else {
      std::fprintf(stderr, "%s.size.txt missing or unreadable\n", image);
      status = 1;
    }
  }

  std::vector<SketchRow> sketch_rows;
  status |= measure_sketches(sketch_rows);
  std::printf("\nArduino libraries as sketches (arduino-builder, Arduino core; one call, interrupts held)\n");
  std::printf("%-84s %6s %8s %12s\n", "operation", "bytes", "cycles", "cycles/byte");
  for (const SketchRow& r : sketch_rows) {
    std::printf("%-84s %6u %8.0f %12.1f\n", r.what.c_str(), r.bytes, r.cycles, r.cycles / r.bytes);
  }
  LoopResult blink;
  const int blink_status = closed_loop(blink, sketch_path("TetherRomi.Blink"), {"L[1]", "L[0]"}, "[0]");
  status |= blink_status;
  if (blink_status == 0) {
    std::printf("\nTetherRomi Blink example closed loop at 115200 (L[1]/L[0], %u + %u bytes):\n", blink.request_bytes,
                blink.reply_bytes);
    std::printf("  turnaround (UDR0 read of '\\n' -> first UDR0 write): min %llu, median %llu, max %llu cycles\n",
                static_cast<unsigned long long>(blink.turnaround_min),
                static_cast<unsigned long long>(blink.turnaround_median),
                static_cast<unsigned long long>(blink.turnaround_max));
    std::printf("  %u calls, %.1f calls/s, wire bound %.1f calls/s: %.1f %%\n", blink.calls, blink.calls_per_second,
                blink.wire_bound, 100.0 * blink.calls_per_second / blink.wire_bound);
  }

  if (json_path != nullptr) {
    std::ostringstream json;
    json << "{\n  \"cpu\": \"ATmega328P\", \"clock_hz\": 16000000, \"baseline_cycles\": " << baseline
         << ",\n  \"rows\": [\n";
    for (std::size_t i = 0; i < rows.size(); ++i) {
      const RowResult& r = rows[i];
      json << "    {\"key\": " << json_string(r.row->key) << ", \"what\": " << json_string(r.row->what)
           << ", \"bytes\": " << r.bytes << ", \"cycles\": " << r.cycles << "}" << (i + 1 < rows.size() ? "," : "")
           << "\n";
    }
    json << "  ]";
    if (loop_status == 0) {
      json << ",\n  \"romi_closed_loop\": {\"image\": \"romi-bench\", \"baud\": 115200, \"request_bytes\": "
           << loop.request_bytes << ", \"reply_bytes\": " << loop.reply_bytes
           << ", \"cycles_per_byte\": " << loop.cycles_per_byte << ", \"calls\": " << loop.calls
           << ", \"calls_per_second\": " << loop.calls_per_second << ", \"wire_bound\": " << loop.wire_bound
           << ", \"turnaround_min\": " << loop.turnaround_min << ", \"turnaround_median\": " << loop.turnaround_median
           << ", \"turnaround_max\": " << loop.turnaround_max << "}";
    }
    json << ",\n  \"arduino_rows\": [\n";
    for (std::size_t i = 0; i < sketch_rows.size(); ++i) {
      const SketchRow& r = sketch_rows[i];
      json << "    {\"key\": " << json_string(r.key) << ", \"what\": " << json_string(r.what)
           << ", \"bytes\": " << r.bytes << ", \"cycles\": " << r.cycles << "}"
           << (i + 1 < sketch_rows.size() ? "," : "") << "\n";
    }
    json << "  ]";
    if (blink_status == 0) {
      json << ",\n  \"arduino_closed_loop\": {\"sketch\": \"TetherRomi.Blink\", \"baud\": 115200, \"request_bytes\": "
           << blink.request_bytes << ", \"reply_bytes\": " << blink.reply_bytes
           << ", \"cycles_per_byte\": " << blink.cycles_per_byte << ", \"calls\": " << blink.calls
           << ", \"calls_per_second\": " << blink.calls_per_second << ", \"wire_bound\": " << blink.wire_bound
           << ", \"turnaround_min\": " << blink.turnaround_min << ", \"turnaround_median\": " << blink.turnaround_median
           << ", \"turnaround_max\": " << blink.turnaround_max << "}";
    }
    json << ",\n  \"image_exchanges\": [\n";
    for (std::size_t i = 0; i < exchanges.size(); ++i) {
      const ExchangeResult& r = exchanges[i];
      json << "    {\"key\": " << json_string(r.key) << ", \"what\": " << json_string(r.what)
           << ", \"bytes\": " << r.bytes << ", \"cycles\": " << r.cycles << "}"
           << (i + 1 < exchanges.size() ? "," : "") << "\n";
    }
    json << "  ],\n  \"rpc_stream_100hz\": [\n";
    for (std::size_t i = 0; i < idle.size(); ++i) {
      json << "    {\"image\": " << json_string(idle[i].image) << ", \"idle_at_rest\": " << idle[i].at_rest
           << ", \"idle_streaming\": " << idle[i].streaming << "}" << (i + 1 < idle.size() ? "," : "") << "\n";
    }
    json << "  ]";
    json << ",\n  \"images\": [\n";
    for (std::size_t i = 0; i < sizes.size(); ++i) {
      json << "    {\"image\": " << json_string(sizes[i].image) << ", \"flash\": " << sizes[i].flash
           << ", \"ram\": " << sizes[i].ram << "}" << (i + 1 < sizes.size() ? "," : "") << "\n";
    }
    json << "  ]\n}\n";
    std::ofstream out(json_path);
    out << json.str();
    if (!out) {
      std::fprintf(stderr, "cannot write %s\n", json_path);
      return 1;
    }
  }
  return status;
}
