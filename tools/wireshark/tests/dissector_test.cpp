// The Wireshark dissector (tools/wireshark/tether.lua) read back through Debian's tshark: captures of every
// codec, their frames made by the codecs' own encoders (real CRCs), damaged frames, unframed bytes, link
// events and request/answer pairs; every field the dissector shows is checked in tshark's JSON. Skipped,
// saying why, when tshark is not installed.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "capture_file.hpp"
#include "tether/elcano/encoder.hpp"
#include "tether/elcano/message.hpp"
#include "tether/proxy/cobs.hpp"
#include "tether/proxy/encoder.hpp"
#include "tether/romi/encoder.hpp"
#include "arm.pb.h"
#include "rocketry.pb.h"
#include "tether_proxy.pb.h"
#include "tether_rpc.pb.h"

namespace {

using tether::wireshark_test::CaptureFile;
using tether::wireshark_test::Direction;
namespace fs = std::filesystem;

constexpr std::uint64_t kStart = 1'800'000'000'000'000;  // microseconds since the epoch

// ---- frames from the codecs' encoders ----------------------------------------------------------------------

std::string romi_request(std::string_view payload, std::uint8_t id) {
  std::array<std::uint8_t, 128> out{};
  const auto size = tether::romi::encode_request(tether::ByteView::from_chars(payload.data(), payload.size()), id,
                                                 tether::MutableByteView(out.data(), out.size()));
  EXPECT_TRUE(size.ok());
  return std::string(reinterpret_cast<const char*>(out.data()), size.value());
}

std::string romi_manual(std::string_view payload) {
  std::array<std::uint8_t, 128> out{};
  const auto size = tether::romi::encode_manual_request(tether::ByteView::from_chars(payload.data(), payload.size()),
                                                        tether::MutableByteView(out.data(), out.size()));
  EXPECT_TRUE(size.ok());
  return std::string(reinterpret_cast<const char*>(out.data()), size.value());
}

std::string romi_response(char opcode, std::string_view body, std::uint8_t id) {
  std::array<std::uint8_t, 128> out{};
  const auto size = tether::romi::encode_response(opcode, tether::ByteView::from_chars(body.data(), body.size()), id,
                                                  tether::MutableByteView(out.data(), out.size()));
  EXPECT_TRUE(size.ok());
  return std::string(reinterpret_cast<const char*>(out.data()), size.value());
}

std::string romi_log(std::string_view text) {
  std::array<std::uint8_t, 128> out{};
  const auto size = tether::romi::encode_log(tether::ByteView::from_chars(text.data(), text.size()),
                                             tether::MutableByteView(out.data(), out.size()));
  EXPECT_TRUE(size.ok());
  return std::string(reinterpret_cast<const char*>(out.data()), size.value());
}

std::string proxy_frame(const std::string& payload, tether::proxy::Integrity integrity, bool leading_delimiter) {
  std::vector<std::uint8_t> out(tether::proxy::max_frame_size(payload.size()));
  const auto size = tether::proxy::encode_frame(tether::ByteView::from_chars(payload.data(), payload.size()),
                                                integrity, leading_delimiter,
                                                tether::MutableByteView(out.data(), out.size()));
  EXPECT_TRUE(size.ok());
  return std::string(reinterpret_cast<const char*>(out.data()), size.value());
}

// A frame whose CRC-16 is wrong: COBS(crc ^ 0x0101 ‖ payload) ‖ 0x00 (the wire damaged it).
std::string proxy_frame_with_bad_crc(const std::string& payload) {
  const std::string good = proxy_frame(payload, tether::proxy::Integrity::crc16, false);
  std::vector<std::uint8_t> decoded(good.size());
  const auto size = tether::proxy::cobs_decode(
      tether::ByteView::from_chars(good.data(), good.size() - 1), tether::MutableByteView(decoded.data(), decoded.size()));
  EXPECT_TRUE(size.ok());
  decoded.resize(size.value());
  decoded[0] ^= 0x01;
  decoded[1] ^= 0x01;
  std::vector<std::uint8_t> out(tether::proxy::cobs_max_encoded_size(decoded.size()));
  const auto encoded = tether::proxy::cobs_encode(tether::ByteView(decoded.data(), decoded.size()),
                                                  tether::MutableByteView(out.data(), out.size()));
  EXPECT_TRUE(encoded.ok());
  return std::string(reinterpret_cast<const char*>(out.data()), encoded.value()) + std::string(1, '\0');
}

std::string elcano(const tether::elcano::Message& message, tether::elcano::Generation generation) {
  std::array<std::uint8_t, 128> out{};
  const auto size = tether::elcano::encode_message(message, generation, tether::MutableByteView(out.data(), out.size()));
  EXPECT_TRUE(size.ok());
  return std::string(reinterpret_cast<const char*>(out.data()), size.value());
}

// ---- tshark ------------------------------------------------------------------------------------------------

// One packet's fields: every field name found in tshark's JSON tree, with its values in tree order.
using Fields = std::map<std::string, std::vector<std::string>>;

void flatten(const nlohmann::json& node, Fields& fields) {
  if (!node.is_object()) return;
  for (const auto& [key, value] : node.items()) {
    if (value.is_string()) {
      fields[key].push_back(value.get<std::string>());
    } else if (value.is_array()) {
      for (const auto& element : value) {
        if (element.is_string()) fields[key].push_back(element.get<std::string>());
        else flatten(element, fields);
      }
    } else if (value.is_object()) {
      flatten(value, fields);
    }
  }
}

std::string shell_quote(const std::string& text) {
  std::string quoted = "'";
  for (const char c : text) {
    if (c == '\'') quoted += "'\\''";
    else quoted += c;
  }
  return quoted + "'";
}

// The plugin and the .proto folders ('|'-separated): the source tree's, or an install's when the environment
// names them (package.wireshark_dissector: the installed files).
std::string plugin_path() {
  const char* path = std::getenv("TETHER_WIRESHARK_PLUGIN");
  return path != nullptr ? path : TETHER_WIRESHARK_PLUGIN;
}
std::string proto_dirs() {
  const char* dirs = std::getenv("TETHER_PROTO_DIRS");
  return dirs != nullptr ? dirs : TETHER_PROTO_DIRS;
}

// Standard output of a shell command.
std::string run(const std::string& command) {
  std::string output;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return output;
  std::array<char, 4096> buffer{};
  for (std::size_t n; (n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0;) output.append(buffer.data(), n);
  pclose(pipe);
  return output;
}

class Dissector : public testing::Test {
 protected:
  void SetUp() override {
    if (std::string(TETHER_TSHARK).empty() || !fs::exists(TETHER_TSHARK)) {
      GTEST_SKIP() << "package test skipped: tshark not found (Debian: apt install tshark)";
    }
    ASSERT_TRUE(fs::exists(plugin_path())) << plugin_path();
    const auto* info = testing::UnitTest::GetInstance()->current_test_info();
    scratch_ = fs::path(TETHER_WIRESHARK_TEST_DIR) / (std::string(info->test_suite_name()) + "." + info->name());
    fs::remove_all(scratch_);
    fs::create_directories(scratch_ / "home");  // tshark's HOME: no personal preferences or plugins
    // A tether.lua Wireshark loads by itself (an installed package's) would be the one tested: the plugin
    // keeps the first copy loaded.
    const std::string plugins = run("HOME=" + shell_quote((scratch_ / "home").string()) + " " +
                                    shell_quote(TETHER_TSHARK) + " -G plugins 2>/dev/null");
    if (plugins.find("tether.lua") != std::string::npos) {
      GTEST_SKIP() << "package test skipped: Wireshark already loads an installed tether.lua, which would be "
                      "tested instead of " << plugin_path() << ":\n" << plugins;
    }
  }

  // Dissects `capture` in two passes (so requests show their answers) with the plugin (the source tree's,
  // or the environment's), the .proto folders in Protobuf's search paths and protobuf fields as Wireshark
  // fields; `extra_options` go to tshark as they are.
  std::vector<Fields> dissect(const CaptureFile& capture, const std::string& extra_options = {}) {
    const std::string file = (scratch_ / "capture.pcapng").string();
    capture.write(file);
    return dissect_file(file, extra_options);
  }

  // `dissect` of a capture file as it is (one `tether --record` wrote, say).
  std::vector<Fields> dissect_file(const std::string& file, const std::string& extra_options = {}) {
    std::string command = "HOME=" + shell_quote((scratch_ / "home").string()) + " " + shell_quote(TETHER_TSHARK) +
                          " -n -2 -X lua_script:" + shell_quote(plugin_path());
    std::istringstream dirs(proto_dirs());
    for (std::string dir; std::getline(dirs, dir, '|');) {
      command += " -o " + shell_quote("uat:protobuf_search_paths:\"" + dir + "\",\"TRUE\"");
    }
    command += " -o protobuf.pbf_as_hf:TRUE " + extra_options + " -r " + shell_quote(file) +
               " -T json --no-duplicate-keys 2>" + shell_quote((scratch_ / "stderr.txt").string());
    std::string output;
    FILE* pipe = popen(command.c_str(), "r");
    if (pipe == nullptr) {
      ADD_FAILURE() << "cannot run " << command;
      return {};
    }
    std::array<char, 4096> buffer{};
    for (std::size_t n; (n = fread(buffer.data(), 1, buffer.size(), pipe)) > 0;) output.append(buffer.data(), n);
    const int status = pclose(pipe);
    std::ifstream stderr_file(scratch_ / "stderr.txt");
    std::string errors((std::istreambuf_iterator<char>(stderr_file)), std::istreambuf_iterator<char>());
    EXPECT_EQ(status, 0) << command << "\n" << errors;
    // Lua errors reach tshark's stderr or the tree; neither may have one.
    EXPECT_EQ(errors.find("Lua"), std::string::npos) << errors;
    std::ofstream(scratch_ / "dissection.json") << output;
    std::vector<Fields> packets;
    const auto json = nlohmann::json::parse(output, nullptr, false);
    if (json.is_discarded() || !json.is_array()) {
      ADD_FAILURE() << "tshark's output is not a JSON array:\n" << output.substr(0, 2000) << "\n" << errors;
      return {};
    }
    for (const auto& packet : json) {
      Fields fields;
      flatten(packet["_source"]["layers"], fields);
      for (const auto& [key, values] : fields) {
        EXPECT_EQ(key.find("_ws.lua"), key.find("_ws.lua.fake")) << "Lua error in packet: " << key;
      }
      packets.push_back(std::move(fields));
    }
    return packets;
  }

  fs::path scratch_;
};

// The values of `name` in `packet` (empty when absent).
std::vector<std::string> values(const Fields& packet, const std::string& name) {
  const auto found = packet.find(name);
  return found == packet.end() ? std::vector<std::string>{} : found->second;
}
// The single value of `name` (a failure when absent or repeated).
std::string value(const Fields& packet, const std::string& name) {
  const auto all = values(packet, name);
  EXPECT_EQ(all.size(), 1u) << name;
  return all.empty() ? std::string() : all.front();
}
bool has(const Fields& packet, const std::string& name) { return packet.count(name) != 0; }
// The dissector's expert messages of the packet, joined (Wireshark's own for the packet's comments left out).
std::string experts(const Fields& packet) {
  const auto comments = values(packet, "frame.comment");
  std::string joined;
  for (const auto& message : values(packet, "_ws.expert.message")) {
    if (std::find(comments.begin(), comments.end(), message) == comments.end()) joined += message + "\n";
  }
  return joined;
}

using Vs = std::vector<std::string>;

// ---- Romi --------------------------------------------------------------------------------------------------

TEST_F(Dissector, Romi) {
  CaptureFile capture;
  const auto arm = capture.add_link("arm", "tether codec=romi baud=115200 transport=serial");
  tether::romi::RequestBuilder shutdown('M');
  shutdown.add_int(16).add_string(tether::ByteView::from_literal("Shutdown"));
  ASSERT_EQ(shutdown.error(), tether::romi::Error::no_error);
  const std::string shutdown_payload(reinterpret_cast<const char*>(shutdown.payload().data()),
                                     shutdown.payload().size());
  std::string damaged = romi_response('b', "[0]", 9);
  damaged[damaged.size() - 3] = damaged[damaged.size() - 3] == '0' ? '1' : '0';  // the CRC's low digit

  capture.add_packet(arm, kStart, Direction::outbound, romi_request("a[1,2,3]", 7));                 // 1
  capture.add_packet(arm, kStart + 200, Direction::inbound, romi_log("moving: joint 2"));            // 2
  capture.add_packet(arm, kStart + 1500, Direction::inbound, romi_response('a', "[0,42,\"ok\"]", 7));  // 3
  capture.add_packet(arm, kStart + 10000, Direction::outbound, romi_request(shutdown_payload, 8));    // 4
  capture.add_packet(arm, kStart + 1010000, Direction::outbound, romi_request(shutdown_payload, 8));  // 5
  capture.add_packet(arm, kStart + 1012500, Direction::inbound, romi_response('M', "[-16]", 8));     // 6
  capture.add_packet(arm, kStart + 1020000, Direction::inbound, damaged);                            // 7
  capture.add_packet(arm, kStart + 1030000, Direction::inbound, "zz\x01", "unframed: noise");        // 8
  capture.add_packet(arm, kStart + 1040000, Direction::outbound, romi_manual("?"));                  // 9
  capture.add_packet(arm, kStart + 1041000, Direction::inbound, romi_response('?', "[0,\"romi\"]", 0));  // 10
  capture.add_packet(arm, kStart + 1050000, Direction::inbound, "", "link: down");                   // 11
  capture.add_packet(arm, kStart + 1060000, Direction::outbound, romi_request("g", 10));             // 12
  capture.add_packet(arm, kStart + 1061000, Direction::inbound, romi_response('g', "[3,\"no: power\"]", 10));  // 13
  const auto p = dissect(capture);
  ASSERT_EQ(p.size(), 13u);

  // Every packet: the link, from the interface, and the direction, from the flags.
  for (const auto& packet : p) {
    EXPECT_EQ(value(packet, "tether.device"), "arm");
    EXPECT_EQ(value(packet, "tether.codec"), "romi");
    EXPECT_EQ(value(packet, "tether.baud"), "115200");
    EXPECT_EQ(value(packet, "tether.transport"), "serial");
  }
  EXPECT_EQ(value(p[0], "tether.direction"), "2");
  EXPECT_EQ(value(p[1], "tether.direction"), "1");

  // A request: opcode, arguments, id, CRC; answered in frame 3 after 1.5 ms.
  EXPECT_EQ(value(p[0], "tether.romi.kind"), "request");
  EXPECT_EQ(value(p[0], "tether.romi.opcode"), "a");
  EXPECT_EQ(value(p[0], "tether.romi.args"), "[1,2,3]");
  EXPECT_EQ(values(p[0], "tether.romi.arg"), (Vs{"1", "2", "3"}));
  EXPECT_EQ(value(p[0], "tether.romi.id"), "7");
  EXPECT_EQ(value(p[0], "tether.romi.crc"), value(p[0], "tether.romi.crc.computed"));
  EXPECT_EQ(value(p[0], "tether.romi.crc.status"), "1");
  EXPECT_EQ(value(p[0], "tether.response_in"), "3");
  EXPECT_FALSE(has(p[0], "tether.request_in"));
  EXPECT_EQ(experts(p[0]), "");

  // A log line, between the request and its response.
  EXPECT_EQ(value(p[1], "tether.romi.kind"), "log");
  EXPECT_EQ(value(p[1], "tether.romi.log"), "moving: joint 2");
  EXPECT_FALSE(has(p[1], "tether.romi.id"));
  EXPECT_EQ(experts(p[1]), "");

  // The response: code 0 and its values.
  EXPECT_EQ(value(p[2], "tether.romi.kind"), "response");
  EXPECT_EQ(value(p[2], "tether.romi.opcode"), "a");
  EXPECT_EQ(value(p[2], "tether.romi.code"), "0");
  EXPECT_FALSE(has(p[2], "tether.romi.error"));
  EXPECT_EQ(values(p[2], "tether.romi.value"), (Vs{"42", "\"ok\""}));
  EXPECT_EQ(value(p[2], "tether.romi.id"), "7");
  EXPECT_EQ(value(p[2], "tether.romi.crc.status"), "1");
  EXPECT_EQ(value(p[2], "tether.request_in"), "1");
  EXPECT_EQ(value(p[2], "tether.response_time"), "0.001500000");
  EXPECT_EQ(experts(p[2]), "");

  // A string argument; the same bytes again are a re-send, and the answer goes to the last send.
  EXPECT_EQ(values(p[3], "tether.romi.arg"), (Vs{"16", "\"Shutdown\""}));
  EXPECT_EQ(value(p[3], "tether.romi.id"), "8");
  EXPECT_FALSE(has(p[3], "tether.resend_of"));
  EXPECT_EQ(value(p[4], "tether.resend_of"), "4");
  EXPECT_EQ(value(p[4], "tether.response_in"), "6");

  // An error reply: the code and its meaning, as expert info.
  EXPECT_EQ(value(p[5], "tether.romi.code"), "-16");
  EXPECT_EQ(value(p[5], "tether.romi.error"), "unknown opcode");
  EXPECT_EQ(value(p[5], "tether.request_in"), "5");
  EXPECT_EQ(value(p[5], "tether.response_time"), "0.002500000");
  EXPECT_EQ(experts(p[5]), "error -16: unknown opcode\n");

  // A damaged CRC: the frame is still decoded, its CRC marked bad.
  EXPECT_EQ(value(p[6], "tether.romi.opcode"), "b");
  EXPECT_EQ(value(p[6], "tether.romi.id"), "9");
  EXPECT_EQ(value(p[6], "tether.romi.crc.status"), "0");
  EXPECT_NE(value(p[6], "tether.romi.crc"), value(p[6], "tether.romi.crc.computed"));
  EXPECT_NE(experts(p[6]).find("CRC-8"), std::string::npos) << experts(p[6]);
  EXPECT_TRUE(has(p[6], "tether.bad_crc"));

  // Unframed bytes: shown as such, with their reason.
  EXPECT_EQ(value(p[7], "tether.unframed"), "noise");
  EXPECT_FALSE(has(p[7], "tether.romi.kind"));
  EXPECT_EQ(experts(p[7]), "3 bytes that formed no frame (noise)\n");

  // A manual request (`:xxxx`), answered with id 00.
  EXPECT_EQ(value(p[8], "tether.romi.kind"), "manual request");
  EXPECT_EQ(value(p[8], "tether.romi.opcode"), "?");
  EXPECT_FALSE(has(p[8], "tether.romi.id"));
  EXPECT_EQ(value(p[8], "tether.response_in"), "10");
  EXPECT_EQ(value(p[9], "tether.romi.id"), "0");
  EXPECT_EQ(values(p[9], "tether.romi.value"), (Vs{"\"romi\""}));
  EXPECT_EQ(value(p[9], "tether.request_in"), "9");

  // A link event.
  EXPECT_EQ(value(p[10], "tether.link_event"), "down");
  EXPECT_EQ(experts(p[10]), "link event: down\n");

  // No arguments; an application's error code (positive), its ':' sent as '-'.
  EXPECT_EQ(value(p[11], "tether.romi.opcode"), "g");
  EXPECT_FALSE(has(p[11], "tether.romi.args"));
  EXPECT_EQ(value(p[12], "tether.romi.code"), "3");
  EXPECT_EQ(value(p[12], "tether.romi.error"), "application error 3");
  EXPECT_EQ(values(p[12], "tether.romi.value"), (Vs{"\"no- power\""}));
  EXPECT_EQ(value(p[12], "tether.request_in"), "12");
}

// Two links whose requests use the same ids: with a protocol tree on the first pass (here a read filter;
// Wireshark with a display filter) each answer is linked on its own link. Without one (the test above) the
// links share one table, which is right while their ids do not overlap in time.
TEST_F(Dissector, RequestsOfTwoLinksWithTheSameIdsStayApartWhenTheFirstPassHasATree) {
  CaptureFile capture;
  const auto left = capture.add_link("left", "tether codec=romi baud=115200 transport=serial");
  const auto right = capture.add_link("right", "tether codec=romi baud=115200 transport=tcp");
  capture.add_packet(left, kStart, Direction::outbound, romi_request("a[1]", 5));
  capture.add_packet(right, kStart + 100, Direction::outbound, romi_request("a[2]", 5));
  capture.add_packet(right, kStart + 900, Direction::inbound, romi_response('a', "[0]", 5));
  capture.add_packet(left, kStart + 2000, Direction::inbound, romi_response('a', "[0]", 5));
  const auto p = dissect(capture, "-R tether");
  ASSERT_EQ(p.size(), 4u);
  EXPECT_EQ(value(p[0], "tether.device"), "left");
  EXPECT_EQ(value(p[1], "tether.transport"), "tcp");
  EXPECT_EQ(value(p[0], "tether.response_in"), "4");
  EXPECT_EQ(value(p[1], "tether.response_in"), "3");
  EXPECT_EQ(value(p[2], "tether.request_in"), "2");
  EXPECT_EQ(value(p[2], "tether.response_time"), "0.000800000");
  EXPECT_EQ(value(p[3], "tether.request_in"), "1");
  EXPECT_EQ(value(p[3], "tether.response_time"), "0.002000000");
}

// ---- proxy -------------------------------------------------------------------------------------------------

TEST_F(Dissector, Proxy) {
  using tether::proxy::Integrity;
  CaptureFile capture;
  const auto io = capture.add_link("io", "tether codec=proxy baud=115200 transport=serial crc=on");
  const auto legacy = capture.add_link("legacy", "tether codec=proxy-compat baud=57600 transport=pty");

  tether::proxy::ArduinoIn control;
  control.set_messageid(5);
  control.mutable_servocontrol()->set_pin(9);
  control.mutable_servocontrol()->set_position(120);
  tether::proxy::ArduinoOut ack;
  ack.mutable_ack()->set_messageid(5);
  tether::proxy::ArduinoIn too_far;
  too_far.set_messageid(6);
  too_far.mutable_servocontrol()->set_pin(9);
  too_far.mutable_servocontrol()->set_position(999);
  tether::proxy::ArduinoOut error;
  error.mutable_error()->set_text("pin 9: position 999 not in 0..180");
  tether::proxy::ArduinoOut refused;
  refused.mutable_ack()->set_messageid(6);
  refused.mutable_ack()->set_refused(true);
  tether::proxy::ArduinoOut info;
  info.mutable_info()->set_sessionid(0xBEEF);
  RocketryProto::ArduinoIn servo_init;
  servo_init.mutable_servoinit()->set_pin(9);
  servo_init.mutable_servoinit()->set_safeposition(90);
  RocketryProto::ArduinoOut event;
  event.mutable_eventmessage()->set_type(RocketryProto::SERVO_INIT);
  event.mutable_eventmessage()->set_data(9);

  capture.add_packet(io, kStart, Direction::outbound, proxy_frame(control.SerializeAsString(), Integrity::crc16, true));
  capture.add_packet(io, kStart + 3000, Direction::inbound, proxy_frame(ack.SerializeAsString(), Integrity::crc16, false));
  capture.add_packet(io, kStart + 4000, Direction::outbound,
                     proxy_frame(too_far.SerializeAsString(), Integrity::crc16, false));
  capture.add_packet(io, kStart + 6000, Direction::inbound, proxy_frame(error.SerializeAsString(), Integrity::crc16, false));
  capture.add_packet(io, kStart + 6500, Direction::inbound,
                     proxy_frame(refused.SerializeAsString(), Integrity::crc16, false));
  capture.add_packet(io, kStart + 7000, Direction::inbound, proxy_frame_with_bad_crc(info.SerializeAsString()));
  capture.add_packet(io, kStart + 8000, Direction::inbound, std::string("\x05\x01\x02", 3), "unframed: cut at close");
  capture.add_packet(legacy, kStart + 9000, Direction::outbound,
                     proxy_frame(servo_init.SerializeAsString(), Integrity::none, true));
  capture.add_packet(legacy, kStart + 9500, Direction::inbound,
                     proxy_frame(event.SerializeAsString(), Integrity::none, false));
  capture.add_packet(io, kStart + 10000, Direction::outbound, std::string(1, '\0'));
  RocketryProto::ArduinoIn move;  // no field 1: read as an envelope, it would be message id 0
  move.mutable_servocontrol()->set_pin(9);
  move.mutable_servocontrol()->set_position(45);
  RocketryProto::ArduinoOut reset;  // EventMessage{RESET}: read as an envelope, an ack of id 0
  reset.mutable_eventmessage()->set_type(RocketryProto::RESET);
  capture.add_packet(legacy, kStart + 11000, Direction::outbound, proxy_frame(move.SerializeAsString(), Integrity::none, true));
  capture.add_packet(legacy, kStart + 12000, Direction::inbound, proxy_frame(reset.SerializeAsString(), Integrity::none, false));
  const auto p = dissect(capture);
  ASSERT_EQ(p.size(), 12u);

  // A message: COBS undone, CRC good, the protobuf fields by name; acked in frame 2.
  EXPECT_EQ(value(p[0], "tether.device"), "io");
  EXPECT_EQ(value(p[0], "tether.codec"), "proxy");
  EXPECT_EQ(value(p[0], "tether.direction"), "2");
  EXPECT_EQ(value(p[0], "tether.cobs.leading_delimiter"), "00");
  EXPECT_EQ(value(p[0], "tether.crc16.status"), "1");
  EXPECT_EQ(value(p[0], "tether.crc16"), value(p[0], "tether.crc16.computed"));
  EXPECT_EQ(value(p[0], "tether.message"), "tether.proxy.ArduinoIn");
  EXPECT_EQ(value(p[0], "tether.message_id"), "5");
  EXPECT_EQ(value(p[0], "pbf.tether.proxy.ArduinoIn.messageId"), "5");
  EXPECT_EQ(value(p[0], "pbf.tether.proxy.ServoControl.pin"), "9");
  EXPECT_EQ(value(p[0], "pbf.tether.proxy.ServoControl.position"), "120");
  EXPECT_EQ(value(p[0], "tether.response_in"), "2");
  EXPECT_EQ(experts(p[0]), "");

  // Its ack, matched to the message id, with the response time.
  EXPECT_EQ(value(p[1], "tether.message"), "tether.proxy.ArduinoOut");
  EXPECT_EQ(value(p[1], "tether.ack.message_id"), "5");
  EXPECT_EQ(value(p[1], "tether.ack.refused"), "0");
  EXPECT_EQ(value(p[1], "pbf.tether.proxy.Ack.messageId"), "5");
  EXPECT_EQ(value(p[1], "tether.request_in"), "1");
  EXPECT_EQ(value(p[1], "tether.response_time"), "0.003000000");
  EXPECT_EQ(experts(p[1]), "");

  // A refused message: its Error, then its ack saying refused (expert info).
  EXPECT_EQ(value(p[2], "pbf.tether.proxy.ServoControl.position"), "999");
  EXPECT_EQ(value(p[2], "tether.response_in"), "5");
  EXPECT_EQ(value(p[3], "pbf.tether.proxy.Error.text"), "pin 9: position 999 not in 0..180");
  EXPECT_FALSE(has(p[3], "tether.request_in"));
  EXPECT_EQ(value(p[4], "tether.ack.message_id"), "6");
  EXPECT_EQ(value(p[4], "tether.ack.refused"), "1");
  EXPECT_EQ(value(p[4], "pbf.tether.proxy.Ack.refused"), "1");
  EXPECT_EQ(value(p[4], "tether.request_in"), "3");
  EXPECT_EQ(experts(p[4]), "message 6 refused\n");

  // A damaged CRC: marked bad, the message still shown.
  EXPECT_EQ(value(p[5], "tether.crc16.status"), "0");
  EXPECT_NE(value(p[5], "tether.crc16"), value(p[5], "tether.crc16.computed"));
  EXPECT_EQ(value(p[5], "pbf.tether.proxy.ArduinoInfo.sessionId"), "48879");
  EXPECT_NE(experts(p[5]).find("CRC-16"), std::string::npos) << experts(p[5]);

  // The filter docs/wireshark.md gives for tshark, on the generic protobuf fields (tshark compiles -Y before
  // the pbf.* fields exist).
  const auto filtered = dissect(capture, "-Y 'protobuf.field.name == \"position\" && protobuf.field.value.int32 > 100'");
  ASSERT_EQ(filtered.size(), 2u);
  EXPECT_EQ(value(filtered[0], "pbf.tether.proxy.ServoControl.position"), "120");
  EXPECT_EQ(value(filtered[1], "pbf.tether.proxy.ServoControl.position"), "999");

  // Unframed bytes.
  EXPECT_EQ(value(p[6], "tether.unframed"), "cut at close");
  EXPECT_EQ(experts(p[6]), "3 bytes that formed no frame (cut at close)\n");
  EXPECT_FALSE(has(p[6], "tether.message"));

  // Compatibility mode: no CRC, RocketryProto, no ids.
  EXPECT_EQ(value(p[7], "tether.device"), "legacy");
  EXPECT_EQ(value(p[7], "tether.codec"), "proxy-compat");
  EXPECT_FALSE(has(p[7], "tether.crc16"));
  EXPECT_FALSE(has(p[7], "tether.message_id"));
  EXPECT_EQ(value(p[7], "tether.message"), "RocketryProto.ArduinoIn");
  EXPECT_EQ(value(p[7], "pbf.RocketryProto.ServoInit.pin"), "9");
  EXPECT_EQ(value(p[7], "pbf.RocketryProto.ServoInit.safePosition"), "90");
  EXPECT_EQ(value(p[8], "tether.message"), "RocketryProto.ArduinoOut");
  EXPECT_EQ(value(p[8], "pbf.RocketryProto.EventMessage.type"), "1");
  EXPECT_EQ(value(p[8], "pbf.RocketryProto.EventMessage.data"), "9");
  EXPECT_EQ(experts(p[7]) + experts(p[8]), "");

  // A lone delimiter (a sender flushing the line).
  EXPECT_EQ(value(p[9], "tether.message"), "empty frame (a delimiter)");

  // Compatibility mode has no ids: nothing is linked, also when the first pass tells codecs by the bytes.
  EXPECT_EQ(value(p[10], "pbf.RocketryProto.ServoControl.position"), "45");
  EXPECT_TRUE(has(p[11], "pbf.RocketryProto.ArduinoOut.eventMessage"));
  for (const auto& packet : {p[7], p[8], p[10], p[11]}) {
    EXPECT_FALSE(has(packet, "tether.response_in"));
    EXPECT_FALSE(has(packet, "tether.request_in"));
  }
}

// ---- rpc ---------------------------------------------------------------------------------------------------

// The rpc frame of an envelope message: the proxy's framing with its CRC.
template <typename Message>
std::string rpc_frame(const Message& message) {
  return proxy_frame(message.SerializeAsString(), tether::proxy::Integrity::crc16, false);
}

TEST_F(Dissector, Rpc) {
  using tether::rpc::wire::DeviceMessage;
  using tether::rpc::wire::HostMessage;
  CaptureFile capture;
  const auto arm = capture.add_link("arm", "tether codec=rpc baud=115200 transport=pty schema=arm.proto package=arm");
  const auto other = capture.add_link("other", "tether codec=rpc baud=115200 transport=pty schema=missing.proto package=x");

  HostMessage move;
  move.set_id(3);
  move.mutable_call()->set_method(0);
  arm::JointRequest joint;
  joint.set_joint(2);
  joint.set_angle_cdeg(-4500);
  move.mutable_call()->set_request(joint.SerializeAsString());
  DeviceMessage ack;
  ack.mutable_ack()->set_id(3);
  DeviceMessage reply;
  reply.mutable_reply()->set_call(3);
  arm::JointReply reached;
  reached.set_reached_cdeg(-4500);
  reply.mutable_reply()->set_reply(reached.SerializeAsString());
  HostMessage watch;
  watch.set_id(4);
  watch.mutable_open()->set_method(1);
  watch.mutable_open()->set_period_ms(100);
  DeviceMessage watch_ack;
  watch_ack.mutable_ack()->set_id(4);
  DeviceMessage state;
  state.mutable_stream()->set_stream(4);
  state.mutable_stream()->set_seq(7);
  arm::State angles;
  for (const int angle : {100, 200, -300, 0}) angles.add_angles_cdeg(angle);
  angles.set_millis(1000);
  angles.set_mode(arm::MODE_ACTIVE);
  state.mutable_stream()->set_message(angles.SerializeAsString());
  HostMessage bad_joint;
  bad_joint.set_id(5);
  bad_joint.mutable_call()->set_method(0);
  joint.set_joint(9);
  bad_joint.mutable_call()->set_request(joint.SerializeAsString());
  DeviceMessage no_joint;
  no_joint.mutable_error()->set_call(5);
  no_joint.mutable_error()->set_code(1);
  no_joint.mutable_error()->set_text("no joint");
  HostMessage unknown;
  unknown.set_id(6);
  unknown.mutable_call()->set_method(9);
  DeviceMessage refused;
  refused.mutable_ack()->set_id(6);
  refused.mutable_ack()->set_refused(true);
  DeviceMessage unknown_method;
  unknown_method.mutable_error()->set_call(6);
  unknown_method.mutable_error()->set_code(0xFF01);
  DeviceMessage hello;
  hello.mutable_hello()->set_schema_hash(0x0123456789ABCDEFull);
  hello.mutable_hello()->set_session(77);
  hello.mutable_hello()->set_methods(4);

  capture.add_packet(arm, kStart, Direction::outbound, rpc_frame(move));             // 1
  capture.add_packet(arm, kStart + 1000, Direction::inbound, rpc_frame(ack));        // 2
  capture.add_packet(arm, kStart + 2500, Direction::inbound, rpc_frame(reply));      // 3
  capture.add_packet(arm, kStart + 3000, Direction::outbound, rpc_frame(watch));     // 4
  capture.add_packet(arm, kStart + 3500, Direction::inbound, rpc_frame(watch_ack));  // 5
  capture.add_packet(arm, kStart + 103500, Direction::inbound, rpc_frame(state));    // 6
  capture.add_packet(arm, kStart + 104000, Direction::outbound, rpc_frame(bad_joint));  // 7
  capture.add_packet(arm, kStart + 105000, Direction::inbound, rpc_frame(no_joint));    // 8
  capture.add_packet(arm, kStart + 106000, Direction::outbound, rpc_frame(unknown));    // 9
  capture.add_packet(arm, kStart + 106500, Direction::inbound, rpc_frame(refused));     // 10
  capture.add_packet(arm, kStart + 107000, Direction::inbound, rpc_frame(unknown_method));  // 11
  capture.add_packet(arm, kStart + 108000, Direction::inbound, rpc_frame(hello));       // 12
  capture.add_packet(other, kStart + 109000, Direction::outbound, rpc_frame(move));     // 13
  HostMessage home = move;
  home.set_id(7);
  joint.set_joint(1);
  joint.set_angle_cdeg(0);
  home.mutable_call()->set_request(joint.SerializeAsString());
  DeviceMessage at_zero;  // a reply whose message has every field at its default: no bytes at all
  at_zero.mutable_reply()->set_call(7);
  capture.add_packet(arm, kStart + 110000, Direction::outbound, rpc_frame(home));     // 14
  capture.add_packet(arm, kStart + 111000, Direction::inbound, rpc_frame(at_zero));   // 15
  const std::string schemas = TETHER_RPC_EXAMPLE_DIR;
  const auto p = dissect(capture, "-o " + shell_quote("uat:protobuf_search_paths:\"" + schemas + "\",\"TRUE\"") +
                                      " -o " + shell_quote("tether.schema_dirs:" + schemas));
  ASSERT_EQ(p.size(), 15u);

  // A call: the envelope, its method by name and its request as the method's input type.
  EXPECT_EQ(value(p[0], "tether.codec"), "rpc");
  EXPECT_EQ(value(p[0], "tether.crc16.status"), "1");
  EXPECT_EQ(value(p[0], "tether.message"), "tether.rpc.wire.HostMessage");
  EXPECT_EQ(value(p[0], "tether.message_id"), "3");
  EXPECT_EQ(value(p[0], "tether.rpc.method_index"), "0");
  EXPECT_EQ(value(p[0], "tether.rpc.method"), "MoveJoint");
  EXPECT_EQ(value(p[0], "tether.rpc.type"), "arm.JointRequest");
  EXPECT_EQ(value(p[0], "pbf.tether.rpc.wire.HostMessage.id"), "3");
  EXPECT_TRUE(has(p[0], "pbf.tether.rpc.wire.HostMessage.call"));  // method 0: not on the wire (proto3)
  EXPECT_TRUE(has(p[0], "pbf.tether.rpc.wire.Call.request"));
  EXPECT_EQ(value(p[0], "pbf.arm.JointRequest.joint"), "2");
  EXPECT_EQ(value(p[0], "pbf.arm.JointRequest.angle_cdeg"), "-4500");
  EXPECT_EQ(value(p[0], "tether.ack_in"), "2");
  EXPECT_EQ(value(p[0], "tether.response_in"), "3");
  EXPECT_EQ(experts(p[0]), "");

  // Its ack (a receipt) and its reply (the answer), both pointing back with their times.
  EXPECT_EQ(value(p[1], "tether.message"), "tether.rpc.wire.DeviceMessage");
  EXPECT_EQ(value(p[1], "tether.ack.message_id"), "3");
  EXPECT_EQ(value(p[1], "tether.ack.refused"), "0");
  EXPECT_EQ(value(p[1], "tether.request_in"), "1");
  EXPECT_EQ(value(p[1], "tether.response_time"), "0.001000000");
  EXPECT_EQ(value(p[2], "tether.rpc.call"), "3");
  EXPECT_EQ(value(p[2], "tether.rpc.method"), "MoveJoint");
  EXPECT_EQ(value(p[2], "tether.rpc.type"), "arm.JointReply");
  EXPECT_EQ(value(p[2], "pbf.arm.JointReply.reached_cdeg"), "-4500");
  EXPECT_EQ(value(p[2], "tether.request_in"), "1");
  EXPECT_EQ(value(p[2], "tether.response_time"), "0.002500000");
  EXPECT_EQ(experts(p[2]), "");

  // A stream: opened, acked; its messages as the method's output type.
  EXPECT_EQ(value(p[3], "tether.rpc.method"), "Watch");
  EXPECT_EQ(value(p[3], "pbf.tether.rpc.wire.OpenStream.period_ms"), "100");
  EXPECT_EQ(value(p[3], "tether.ack_in"), "5");
  EXPECT_EQ(value(p[5], "tether.rpc.stream"), "4");
  EXPECT_EQ(value(p[5], "tether.rpc.seq"), "7");
  EXPECT_EQ(value(p[5], "tether.rpc.method"), "Watch");
  EXPECT_EQ(value(p[5], "tether.rpc.type"), "arm.State");
  EXPECT_EQ(values(p[5], "pbf.arm.State.angles_cdeg"), (Vs{"100", "200", "-300", "0"}));
  EXPECT_EQ(value(p[5], "pbf.arm.State.millis"), "1000");
  EXPECT_EQ(value(p[5], "pbf.arm.State.mode"), "1");
  EXPECT_FALSE(has(p[5], "tether.request_in"));

  // An application's error and Tether's own, with their meaning; a refused message.
  EXPECT_EQ(value(p[7], "tether.rpc.call"), "5");
  EXPECT_EQ(value(p[7], "tether.rpc.method"), "MoveJoint");
  EXPECT_EQ(value(p[7], "tether.rpc.error_code"), "1");
  EXPECT_EQ(value(p[7], "tether.rpc.error"), "application error");
  EXPECT_EQ(value(p[7], "pbf.tether.rpc.wire.DeviceError.text"), "no joint");
  EXPECT_EQ(value(p[7], "tether.request_in"), "7");
  EXPECT_EQ(experts(p[7]), "error 1: application error\n");
  EXPECT_EQ(value(p[8], "tether.rpc.method_index"), "9");
  EXPECT_FALSE(has(p[8], "tether.rpc.method"));
  EXPECT_EQ(value(p[9], "tether.ack.refused"), "1");
  EXPECT_EQ(experts(p[9]), "message 6 refused\n");
  EXPECT_EQ(value(p[10], "tether.rpc.error_code"), "65281");
  EXPECT_EQ(value(p[10], "tether.rpc.error"), "unknown method");
  EXPECT_EQ(value(p[10], "tether.request_in"), "9");

  // The device's hello.
  EXPECT_EQ(value(p[11], "pbf.tether.rpc.wire.DeviceHello.session"), "77");
  EXPECT_EQ(value(p[11], "pbf.tether.rpc.wire.DeviceHello.methods"), "4");

  // A schema that is not found: the envelope still, the method by its index, and why not by name.
  EXPECT_EQ(value(p[12], "tether.device"), "other");
  EXPECT_EQ(value(p[12], "tether.rpc.method_index"), "0");
  EXPECT_FALSE(has(p[12], "tether.rpc.method"));
  EXPECT_EQ(value(p[12], "pbf.tether.rpc.wire.HostMessage.id"), "3");
  EXPECT_NE(experts(p[12]).find("schema missing.proto not found"), std::string::npos) << experts(p[12]);

  // An empty reply message (every field at its default).
  EXPECT_EQ(value(p[13], "pbf.arm.JointRequest.joint"), "1");
  EXPECT_EQ(value(p[14], "tether.rpc.method"), "MoveJoint");
  EXPECT_EQ(value(p[14], "tether.rpc.type"), "arm.JointReply");
  EXPECT_EQ(value(p[14], "tether.request_in"), "14");
  EXPECT_EQ(experts(p[14]), "");
}

// A schema with nanopb's options inline (`import "nanopb.proto"`): named when nanopb's folder (which has
// nanopb.proto and the descriptor.proto it imports) is in Protobuf's search paths, not loaded as a whole.
TEST_F(Dissector, RpcSchemaImportingNanopb) {
  if (std::string(TETHER_NANOPB_PROTO_DIR).empty()) GTEST_SKIP() << "nanopb.proto not found (Debian: nanopb)";
  using tether::rpc::wire::DeviceMessage;
  using tether::rpc::wire::HostMessage;
  const auto schemas = scratch_ / "schemas";
  fs::create_directories(schemas);
  fs::copy_file(TETHER_RPC_NANOPB_SCHEMA, schemas / "arm_nanopb.proto");
  CaptureFile capture;
  const auto arm = capture.add_link("arm", "tether codec=rpc baud=115200 transport=serial schema=arm_nanopb.proto package=arm");
  HostMessage watch;
  watch.set_id(1);
  watch.mutable_open()->set_method(1);
  watch.mutable_open()->set_period_ms(50);
  DeviceMessage state;
  state.mutable_stream()->set_stream(1);
  arm::State angles;
  angles.add_angles_cdeg(-1);
  angles.set_millis(20);
  state.mutable_stream()->set_message(angles.SerializeAsString());
  capture.add_packet(arm, kStart, Direction::outbound, rpc_frame(watch));
  capture.add_packet(arm, kStart + 50000, Direction::inbound, rpc_frame(state));
  const auto p = dissect(capture, "-o " + shell_quote("uat:protobuf_search_paths:\"" + schemas.string() + "\",\"TRUE\"") +
                                      " -o " + shell_quote(std::string("uat:protobuf_search_paths:\"") +
                                                           TETHER_NANOPB_PROTO_DIR + "\",\"FALSE\"") +
                                      " -o " + shell_quote("tether.schema_dirs:" + schemas.string()));
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(value(p[0], "tether.rpc.method"), "Watch");
  EXPECT_EQ(value(p[1], "tether.rpc.method"), "Watch");
  EXPECT_EQ(value(p[1], "tether.rpc.type"), "arm.State");
  EXPECT_EQ(value(p[1], "pbf.arm.State.angles_cdeg"), "-1");
  EXPECT_EQ(value(p[1], "pbf.arm.State.millis"), "20");
}

// Method types named as protobuf scopes them: a nested type of the schema's package and an imported
// well-known type (found in protobuf's include folder, in the search paths without loading it all).
TEST_F(Dissector, RpcMethodTypesNestedAndImported) {
  using tether::rpc::wire::DeviceMessage;
  using tether::rpc::wire::HostMessage;
  const auto schemas = scratch_ / "schemas";
  fs::create_directories(schemas);
  std::ofstream(schemas / "shop.proto") << R"(syntax = "proto3";
package shop;
import "google/protobuf/wrappers.proto";
message Outer {
  message Inner { int32 x = 1; }
}
service Shop {
  // Not a method: rpc Fake(Outer) returns (Outer);
  rpc Count(google.protobuf.Int32Value) returns (Outer.Inner);
}
)";
  CaptureFile capture;
  const auto shop = capture.add_link("shop", "tether codec=rpc baud=115200 transport=serial schema=shop.proto package=shop");
  HostMessage count;
  count.set_id(1);
  count.mutable_call()->set_request(std::string("\x08\x07", 2));  // Int32Value{value: 7}
  DeviceMessage reply;
  reply.mutable_reply()->set_call(1);
  reply.mutable_reply()->set_reply(std::string("\x08\x05", 2));  // Outer.Inner{x: 5}
  capture.add_packet(shop, kStart, Direction::outbound, rpc_frame(count));
  capture.add_packet(shop, kStart + 700, Direction::inbound, rpc_frame(reply));
  const auto p = dissect(capture, "-o " + shell_quote("uat:protobuf_search_paths:\"" + schemas.string() + "\",\"TRUE\"") +
                                      " -o " + shell_quote(std::string("uat:protobuf_search_paths:\"") +
                                                           TETHER_PROTOBUF_INCLUDE_DIR + "\",\"FALSE\"") +
                                      " -o " + shell_quote("tether.schema_dirs:" + schemas.string()));
  ASSERT_EQ(p.size(), 2u);
  EXPECT_EQ(value(p[0], "tether.rpc.method"), "Count");
  EXPECT_EQ(value(p[0], "tether.rpc.type"), "google.protobuf.Int32Value");
  EXPECT_EQ(value(p[0], "pbf.google.protobuf.Int32Value.value"), "7");
  EXPECT_EQ(value(p[1], "tether.rpc.method"), "Count");
  EXPECT_EQ(value(p[1], "tether.rpc.type"), "shop.Outer.Inner");
  EXPECT_EQ(value(p[1], "pbf.shop.Outer.Inner.x"), "5");
  EXPECT_EQ(value(p[1], "tether.request_in"), "1");
}

// ---- Elcano ------------------------------------------------------------------------------------------------

TEST_F(Dissector, Elcano) {
  using tether::elcano::Generation;
  using tether::elcano::Message;
  CaptureFile capture;
  const auto ring = capture.add_link("ring", "tether codec=elcano baud=115200 transport=serial generation=B");
  const auto ring_d = capture.add_link("ring-d", "tether codec=elcano baud=115200 transport=serial generation=D");
  std::string damaged = elcano(Message::drive(50, 25), Generation::d);
  damaged[damaged.size() - 2] = damaged[damaged.size() - 2] == '0' ? '1' : '0';

  capture.add_packet(ring, kStart, Direction::outbound, elcano(Message::drive(50, 25), Generation::b));
  capture.add_packet(ring, kStart + 100, Direction::inbound, elcano(Message::sensor(69, -12, 432, 420, 90210), Generation::b));
  capture.add_packet(ring, kStart + 200, Direction::outbound, elcano(Message::goal(1, 90, 100, 200, 75), Generation::b));
  capture.add_packet(ring, kStart + 300, Direction::inbound, "D{s}{a 25}\n");
  capture.add_packet(ring, kStart + 400, Direction::inbound, "D{s 1}\n");
  capture.add_packet(ring_d, kStart + 500, Direction::inbound, elcano(Message::segment(4, 160, 80, 3200, -64000), Generation::d));
  capture.add_packet(ring_d, kStart + 600, Direction::outbound, damaged);
  capture.add_packet(ring_d, kStart + 700, Direction::inbound, "X{n4", "unframed: cut at close");
  const auto p = dissect(capture);
  ASSERT_EQ(p.size(), 8u);

  EXPECT_EQ(value(p[0], "tether.codec"), "elcano");
  EXPECT_EQ(value(p[0], "tether.elcano.generation"), "B");
  EXPECT_EQ(value(p[0], "tether.elcano.type"), "D (drive)");
  EXPECT_EQ(value(p[0], "tether.elcano.speed"), "50");
  EXPECT_EQ(value(p[0], "tether.elcano.angle"), "25");
  EXPECT_FALSE(has(p[0], "tether.elcano.crc"));
  EXPECT_EQ(experts(p[0]), "");

  EXPECT_EQ(value(p[1], "tether.elcano.type"), "S (sensor)");
  EXPECT_EQ(value(p[1], "tether.elcano.speed"), "69");
  EXPECT_EQ(value(p[1], "tether.elcano.angle"), "-12");
  EXPECT_EQ(value(p[1], "tether.elcano.bearing"), "432");
  EXPECT_EQ(value(p[1], "tether.elcano.east"), "420");
  EXPECT_EQ(value(p[1], "tether.elcano.north"), "90210");
  EXPECT_EQ(experts(p[1]), "");

  EXPECT_EQ(value(p[2], "tether.elcano.type"), "G (goal)");
  EXPECT_EQ(value(p[2], "tether.elcano.number"), "1");
  EXPECT_EQ(value(p[2], "tether.elcano.bearing"), "90");
  EXPECT_EQ(value(p[2], "tether.elcano.probability"), "75");
  EXPECT_EQ(value(p[2], "tether.elcano.east"), "100");
  EXPECT_EQ(value(p[2], "tether.elcano.north"), "200");

  // Damaged messages, as the reader names them.
  EXPECT_NE(value(p[3], "tether.elcano.error").find("bad_number"), std::string::npos);
  EXPECT_NE(experts(p[3]).find("bad_number"), std::string::npos);
  EXPECT_NE(value(p[4], "tether.elcano.error").find("inval_comb"), std::string::npos);
  EXPECT_EQ(value(p[4], "tether.elcano.speed"), "1");

  // Generation D: `{p E}{q N}` and the decimal CRC-8 (the format's example).
  EXPECT_EQ(value(p[5], "tether.elcano.generation"), "D");
  EXPECT_EQ(value(p[5], "tether.elcano.type"), "X (segment)");
  EXPECT_EQ(value(p[5], "tether.elcano.number"), "4");
  EXPECT_EQ(value(p[5], "tether.elcano.speed"), "160");
  EXPECT_EQ(value(p[5], "tether.elcano.bearing"), "80");
  EXPECT_EQ(value(p[5], "tether.elcano.east"), "3200");
  EXPECT_EQ(value(p[5], "tether.elcano.north"), "-64000");
  EXPECT_EQ(value(p[5], "tether.elcano.crc"), "243");
  EXPECT_EQ(value(p[5], "tether.elcano.crc.computed"), "243");
  EXPECT_EQ(value(p[5], "tether.elcano.crc.status"), "1");
  EXPECT_EQ(experts(p[5]), "");

  EXPECT_EQ(value(p[6], "tether.elcano.type"), "D (drive)");
  EXPECT_EQ(value(p[6], "tether.elcano.crc.status"), "0");
  EXPECT_NE(experts(p[6]).find("CRC-8"), std::string::npos);

  EXPECT_EQ(value(p[7], "tether.unframed"), "cut at close");
  EXPECT_EQ(value(p[7], "tether.text"), "X{n4");
  EXPECT_FALSE(has(p[7], "tether.elcano.type"));
}

// ---- bad input ---------------------------------------------------------------------------------------------

// Damaged frames of every codec, made from each codec's alphabet (seeded: the same bytes every run), and
// links that are not Tether's or name a codec the dissector does not know: shown, never a Lua error (which
// dissect() fails on), with a tree on the first pass and without.
TEST_F(Dissector, DamagedFramesNeverRaiseALuaError) {
  CaptureFile capture;
  struct Link {
    std::uint32_t id;
    std::string alphabet;
    bool cobs;
  };
  const std::string romi = "#!:[],\"-0123456789abcdefxAZ \r\n";
  const std::string elcano = "DSGX{}pqnsaobrz -0123456789,\n\t";
  std::vector<Link> links;
  links.push_back({capture.add_link("romi", "tether codec=romi baud=115200 transport=serial"), romi, false});
  links.push_back({capture.add_link("proxy", "tether codec=proxy baud=115200 transport=serial crc=on"), "", true});
  links.push_back({capture.add_link("compat", "tether codec=proxy-compat baud=57600 transport=serial"), "", true});
  links.push_back({capture.add_link("rpc", "tether codec=rpc baud=115200 transport=pty schema=arm.proto package=arm"), "",
                   true});
  links.push_back({capture.add_link("elcano-b", "tether codec=elcano baud=115200 transport=serial generation=B"),
                   elcano, false});
  links.push_back({capture.add_link("elcano-d", "tether codec=elcano baud=115200 transport=serial generation=D"),
                   elcano, false});
  links.push_back({capture.add_link("plugin", "tether codec=mycodec baud=- transport=virtual"), romi, false});
  links.push_back({capture.add_link("other", "not a tether link"), romi, false});
  links.push_back({capture.add_link("bare", "tether"), "", true});
  std::mt19937 random(20261206);
  std::uint64_t time = kStart;
  std::size_t packets = 0;
  for (const auto& link : links) {
    for (int i = 0; i < 60; ++i) {
      std::string bytes;
      const auto size = std::uniform_int_distribution<std::size_t>(0, 40)(random);
      for (std::size_t k = 0; k < size; ++k) {
        if (link.cobs) {
          bytes.push_back(static_cast<char>(std::uniform_int_distribution<int>(0, 255)(random)));
        } else {
          bytes.push_back(link.alphabet[std::uniform_int_distribution<std::size_t>(0, link.alphabet.size() - 1)(random)]);
        }
      }
      if (link.cobs && i % 4 == 0) bytes.push_back('\0');
      if (link.cobs && i % 4 == 1) {  // valid COBS around random bytes: the CRC and protobuf layers see them
        std::vector<std::uint8_t> out(tether::proxy::cobs_max_encoded_size(bytes.size()));
        const auto encoded = tether::proxy::cobs_encode(tether::ByteView::from_chars(bytes.data(), bytes.size()),
                                                        tether::MutableByteView(out.data(), out.size()));
        ASSERT_TRUE(encoded.ok());
        bytes.assign(reinterpret_cast<const char*>(out.data()), encoded.value());
        bytes.push_back('\0');
      }
      if (link.cobs && i % 4 == 2) {  // a message with a good CRC and a random protobuf payload
        bytes = proxy_frame(bytes, tether::proxy::Integrity::crc16, i % 8 == 2);
      }
      if (!link.cobs && i % 2 == 0) bytes += "\n";
      const auto direction = i % 3 == 0 ? Direction::outbound : Direction::inbound;
      const char* comment = i % 17 == 0 ? "unframed" : i % 19 == 0 ? "link: up ready after 37 ms" : "";
      capture.add_packet(link.id, time += 100, direction, bytes, comment);
      ++packets;
    }
  }
  // Frames at the edges of each syntax.
  for (const char* text : {"#", "#!", "#:", "#!:", "#a[", "#a]:0000\r\n", "#a[1,[2,\"x]:00zz\r\n", "#:ffff\r\n"}) {
    capture.add_packet(links[0].id, time += 100, Direction::inbound, text);
    ++packets;
  }
  for (const char* text : {"D", "D{", "D{s", "D{s 1", "D{s 1,2}{a 2}", "S{p ,}\n", "G{n 99999999999}\n", "X{q 1}12\n"}) {
    capture.add_packet(links[5].id, time += 100, Direction::inbound, text);
    ++packets;
  }
  for (const std::string& bytes : {std::string("\x05\x01\x00", 3), std::string("\xff\x00", 2), std::string("\x01\x00", 2),
                                   std::string("\x03\xff\xff\x00", 4), std::string("\x04\x01\x02\x0a\x00", 5)}) {
    for (const auto index : {1, 2, 3}) {
      capture.add_packet(links[static_cast<std::size_t>(index)].id, time += 100, Direction::inbound, bytes);
      capture.add_packet(links[static_cast<std::size_t>(index)].id, time += 100, Direction::outbound, bytes);
      packets += 2;
    }
  }
  EXPECT_EQ(dissect(capture).size(), packets);
  EXPECT_EQ(dissect(capture, "-R frame").size(), packets);
}

// A capture `tether demo --record` made under line noise, read with the dissector: for every device, the
// frames from the device it shows damaged (a CRC that does not check, COBS or a line that does not parse,
// bytes that formed no frame) are the ones the demo's clients dropped (its crc_errors + framing_errors), and for
// the codecs whose requests carry ids (romi, proxy, rpc) the requests it marks as re-sent are the demo's
// retries. The capture holds the bytes the host read, after the noise, and the ones it wrote, before it.
TEST_F(Dissector, ADemoRecordedUnderNoiseShowsTheDamageAndTheResendsTheDemoCounted) {
  if (!fs::exists(TETHER_BINARY) || !fs::exists(std::string(TETHER_FIRMWARE_DIR) + "/romi-rover.elf")) {
    GTEST_SKIP() << "the tether command or the demo's images are not built";
  }
  const std::string file = (scratch_ / "demo.pcapng").string();
  const std::string report_file = (scratch_ / "demo.json").string();
  const std::string command = shell_quote(TETHER_BINARY) +
                              " demo --iterations 30 --period 10 --ber 0.001 --no-reset --seed 3 --json --record " +
                              shell_quote(file) + " > " + shell_quote(report_file) + " 2>/dev/null";
  ASSERT_EQ(std::system(command.c_str()), 0) << command;
  std::ifstream report_stream(report_file);
  const auto report = nlohmann::json::parse(report_stream, nullptr, false);
  ASSERT_TRUE(report.is_object() && report.contains("devices")) << report_file;

  struct Seen {
    std::size_t damaged = 0;  // from the device
    std::size_t resends = 0;  // to the device
    std::size_t cuts = 0;     // Romi frames cut by a new frame's `#`: the client's resyncs, not its errors
    bool closed = false;      // the link's close cut a frame: what follows was read after the client's end
  };
  std::map<std::string, Seen> seen;
  const auto packets = dissect_file(file);
  ASSERT_FALSE(packets.empty());
  for (const Fields& packet : packets) {
    if (!has(packet, "tether.device")) continue;
    Seen& device = seen[value(packet, "tether.device")];
    const std::string codec = value(packet, "tether.codec");
    if (value(packet, "tether.direction") == "2") {
      if (has(packet, "tether.resend_of")) ++device.resends;
      continue;
    }
    if (has(packet, "tether.link_event") || device.closed) continue;
    // A frame the close cut, and anything read after it, came when the demo's client had stopped counting.
    if (values(packet, "tether.unframed") == std::vector<std::string>{"cut at close"}) {
      device.closed = true;
      continue;
    }
    if (codec == "romi" && values(packet, "tether.unframed") == std::vector<std::string>{"cut by a new frame"}) {
      ++device.cuts;
      continue;
    }
    bool damaged = has(packet, "tether.unframed");
    if (codec == "romi" && !has(packet, "tether.romi.log")) {
      damaged = damaged || values(packet, "tether.romi.crc.status") != std::vector<std::string>{"1"};
    } else if (codec == "proxy" || codec == "rpc") {
      damaged = damaged || values(packet, "tether.crc16.status") != std::vector<std::string>{"1"};
    } else if (codec == "proxy-compat") {  // no CRC: only COBS that does not decode
      damaged = damaged || !has(packet, "tether.cobs.decoded_length");
    } else if (codec == "elcano") {
      damaged = damaged || has(packet, "tether.elcano.error") ||
                values(packet, "tether.elcano.crc.status") == std::vector<std::string>{"0"};
    }
    if (damaged) ++device.damaged;
  }
  std::size_t damaged_in_all = 0;
  for (const auto& device : report["devices"]) {
    const std::string name = device["device"].get<std::string>();
    const std::string codec = device["codec"].get<std::string>();
    SCOPED_TRACE(name + " (" + codec + ")");
    const auto dropped = device["crc_errors"].get<std::size_t>() + device["framing_errors"].get<std::size_t>();
    EXPECT_EQ(seen[name].damaged, dropped);
    EXPECT_LE(seen[name].cuts, device["resyncs"].get<std::size_t>());
    damaged_in_all += dropped;
    if (codec == "romi" || codec == "proxy" || codec == "rpc") {
      EXPECT_EQ(seen[name].resends, device["retries"].get<std::size_t>());
    }
  }
  EXPECT_GT(damaged_in_all, 0u) << "the noise damaged nothing: the test shows nothing";
}

}  // namespace
