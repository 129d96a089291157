// The hand-written envelope (envelope.hpp) against libprotobuf's classes of tether_rpc.proto, the reference
// it must equal: shared by the envelope test and the client's fuzz target.
//
// What it must accept is what libprotobuf's parser accepts when a DeviceError's text is not UTF-8 (the
// device's text is whatever its firmware wrote): libprotobuf's DeviceMessage with `text` declared `bytes`
// (a dynamic message of the same file, that one field changed). What it reads must be what the client read
// before, proxy::parse_device_message (the text repaired as `\xNN`). That function also accepted some
// payloads libprotobuf refuses (after a failed parse it re-reads them as unknown fields with the older,
// more lenient reader: tags of up to 10 bytes); envelope::decode refuses those, as libprotobuf does.
#pragma once

#include <google/protobuf/descriptor.h>
#include <google/protobuf/descriptor.pb.h>
#include <google/protobuf/dynamic_message.h>
#include <google/protobuf/stubs/logging.h>

#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "tether/proxy/device_message.hpp"
#include "tether/rpc/envelope.hpp"
#include "tether_rpc.pb.h"

namespace tether::rpc::envelope_reference {

/// `bytes` in hex, for failure messages.
inline std::string hex(const std::string& bytes) {
  std::string out;
  char digits[4];
  for (const char c : bytes) {
    std::snprintf(digits, sizeof digits, "%02x ", static_cast<unsigned>(static_cast<std::uint8_t>(c)));
    out += digits;
  }
  return out;
}

/// libprotobuf's HostMessage of `message`.
inline wire::HostMessage to_libprotobuf(const envelope::HostMessage& message) {
  wire::HostMessage out;
  out.set_id(message.id);
  const std::string request(reinterpret_cast<const char*>(message.request.data()), message.request.size());
  switch (message.body) {
    case envelope::HostBody::none:
      break;
    case envelope::HostBody::hello:
      out.mutable_hello();
      break;
    case envelope::HostBody::call:
      out.mutable_call()->set_method(message.method);
      out.mutable_call()->set_request(request);
      break;
    case envelope::HostBody::open:
      out.mutable_open()->set_method(message.method);
      out.mutable_open()->set_request(request);
      out.mutable_open()->set_period_ms(message.period_ms);
      break;
    case envelope::HostBody::close:
      out.mutable_close()->set_stream(message.stream);
      break;
    case envelope::HostBody::ping:
      out.mutable_ping();
      break;
    case envelope::HostBody::reset:
      out.mutable_reset();
      break;
  }
  return out;
}

/// libprotobuf's DeviceMessage whose DeviceError.text is `bytes` (built once).
inline const google::protobuf::Message& bytes_text_device_message() {
  namespace pb = google::protobuf;
  static const pb::Message* const prototype = [] {
    pb::FileDescriptorProto file;
    wire::DeviceMessage::descriptor()->file()->CopyTo(&file);
    for (pb::DescriptorProto& type : *file.mutable_message_type()) {
      if (type.name() != "DeviceError") continue;
      for (pb::FieldDescriptorProto& field : *type.mutable_field()) {
        if (field.name() == "text") field.set_type(pb::FieldDescriptorProto::TYPE_BYTES);
      }
    }
    static pb::DescriptorPool pool;
    static pb::DynamicMessageFactory factory(&pool);
    const pb::FileDescriptor* built = pool.BuildFile(file);
    return factory.GetPrototype(built->FindMessageTypeByName("DeviceMessage"));
  }();
  return *prototype;
}

/// Where `envelope::decode` and libprotobuf differ on `payload`; empty when they agree: both refuse it,
/// or both read it (libprotobuf with a text that need not be UTF-8, see above) with the same body and
/// fields as proxy::parse_device_message reads.
inline std::string compare_decoders(const std::string& payload) {
  const std::unique_ptr<google::protobuf::Message> bytes_text(bytes_text_device_message().New());
  const bool reference_ok = bytes_text->ParseFromString(payload);
  wire::DeviceMessage reference;
  if (reference_ok && !proxy::parse_device_message(reference, ByteView::from_chars(payload.data(), payload.size()))) {
    return "proxy::parse_device_message refuses what libprotobuf accepts with a bytes text: " + hex(payload);
  }
  envelope::DeviceMessage mine;
  const envelope::DecodeError error = envelope::decode(ByteView::from_chars(payload.data(), payload.size()), mine);
  const std::string where = " for payload " + hex(payload);
  if (reference_ok != (error == envelope::DecodeError::none)) {
    return std::string("libprotobuf ") + (reference_ok ? "accepts" : "refuses") + ", envelope::decode " +
           (error == envelope::DecodeError::none ? "accepts" : std::string("refuses: ") + envelope::describe(error)) +
           where;
  }
  if (!reference_ok) return "";
  const auto bytes = [](ByteView view) { return std::string(reinterpret_cast<const char*>(view.data()), view.size()); };
  if (static_cast<int>(reference.body_case()) != static_cast<int>(mine.body)) {
    return "body " + std::to_string(reference.body_case()) + " vs " + std::to_string(static_cast<int>(mine.body)) + where;
  }
  bool same = true;
  switch (mine.body) {
    case envelope::DeviceBody::none:
      break;
    case envelope::DeviceBody::ack:
      same = reference.ack().id() == mine.ack.id && reference.ack().refused() == mine.ack.refused;
      break;
    case envelope::DeviceBody::reply:
      same = reference.reply().call() == mine.reply.call && reference.reply().reply() == bytes(mine.reply.reply);
      break;
    case envelope::DeviceBody::error:
      same = reference.error().call() == mine.error.call && reference.error().code() == mine.error.code &&
             reference.error().text() == envelope::device_text(mine.error.text);
      break;
    case envelope::DeviceBody::stream:
      same = reference.stream().stream() == mine.stream.stream && reference.stream().seq() == mine.stream.seq &&
             reference.stream().message() == bytes(mine.stream.message);
      break;
    case envelope::DeviceBody::hello:
      same = reference.hello().schema_hash() == mine.hello.schema_hash &&
             reference.hello().session() == mine.hello.session &&
             reference.hello().max_payload() == mine.hello.max_payload &&
             reference.hello().methods() == mine.hello.methods;
      break;
    case envelope::DeviceBody::reset:
      same = reference.reset().session() == mine.reset.session;
      break;
  }
  if (!same) return "fields differ: libprotobuf reads " + reference.ShortDebugString() + where;
  return "";
}

}  // namespace tether::rpc::envelope_reference
