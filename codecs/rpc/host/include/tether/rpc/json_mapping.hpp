/// @file json_mapping.hpp
/// protobuf's JSON mapping for the messages of one descriptor pool, kept between calls: the dynamic
/// client's `call_json` (the CLI's and Python's path) converts every request and reply with it.
///
/// `util::JsonStringToMessage` and `util::MessageToJsonString` build a type resolver for the message's
/// pool and describe each type they meet as a `google.protobuf.Type`, on every call, then run a chain of
/// object writers; here the descriptions are made once per type, and messages of plain types (integers,
/// bools, enums, strings and nested messages; json_mapping.cpp lists what) in plain JSON are converted
/// directly with reflection. Everything else goes through protobuf's conversion as before. Either way the
/// results are protobuf's: the same JSON, the same messages, the same error texts (tested against it).
///
/// @code
///   rpc::JsonMapping json(schema.pool());
///   auto status = json.from_json(R"({"joint": 2})", *request);    // as util::JsonStringToMessage
///   std::string text;
///   status = json.to_json(*reply, text, options);                 // as util::MessageToJsonString
/// @endcode
#pragma once

#include <google/protobuf/util/json_util.h>

#include <memory>
#include <string>
#include <string_view>

namespace google::protobuf {
class DescriptorPool;
class Message;
}  // namespace google::protobuf

namespace tether::rpc {

/// protobuf's JSON mapping of one pool's messages, its type descriptions kept. Thread-safe.
class JsonMapping {
 public:
  /// The mapping of the messages of `pool` (which outlives it).
  explicit JsonMapping(const google::protobuf::DescriptorPool& pool);
  ~JsonMapping();
  JsonMapping(const JsonMapping&) = delete;
  JsonMapping& operator=(const JsonMapping&) = delete;

  /// `util::JsonStringToMessage(json, &message, options)`: `message` (of this pool) replaced by `json`.
  google::protobuf::util::Status from_json(std::string_view json, google::protobuf::Message& message,
                                           const google::protobuf::util::JsonParseOptions& options = {}) const;
  /// `util::MessageToJsonString(message, &json, options)`: `message` (of this pool) appended to `json`.
  google::protobuf::util::Status to_json(const google::protobuf::Message& message, std::string& json,
                                         const google::protobuf::util::JsonPrintOptions& options = {}) const;

 private:
  class Types;
  class Direct;
  std::unique_ptr<Types> types_;
  std::unique_ptr<Direct> direct_;
};

}  // namespace tether::rpc
