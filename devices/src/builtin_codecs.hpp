// The functions of the built-in codec rows (codec_table.cpp): options parsed and checked in config.cpp,
// clients opened in rover.cpp.
#pragma once

#include <memory>
#include <string>

#include "tether/devices/codecs.hpp"

namespace tether::devices::detail {

CodecOptions parse_romi(const OptionsContext& context);
CodecOptions parse_proxy(const OptionsContext& context);  // proxy and proxy-compat (the mode from the codec)
CodecOptions parse_elcano(const OptionsContext& context);

void validate_romi(const CodecOptions& options, const std::string& options_path);
void validate_proxy(const CodecOptions& options, const std::string& options_path, Codec codec);
void validate_elcano(const CodecOptions& options, const std::string& options_path);

DeviceClient open_romi(std::shared_ptr<transports::ByteStream> stream, const DeviceConfig& device,
                         std::shared_ptr<transports::LinkClock> clock);
DeviceClient open_proxy(std::shared_ptr<transports::ByteStream> stream, const DeviceConfig& device,
                         std::shared_ptr<transports::LinkClock> clock);
DeviceClient open_elcano(std::shared_ptr<transports::ByteStream> stream, const DeviceConfig& device,
                         std::shared_ptr<transports::LinkClock> clock);

/// Proxy: the configured inits and, in primary mode, the session handshake, within the open timeout.
void await_proxy(const DeviceClient& client, const DeviceConfig& device, const std::string& device_path);

}  // namespace tether::devices::detail
