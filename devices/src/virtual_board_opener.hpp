// How opening a rover reaches the virtual boards: their code (virtual-boards/src/virtual_boards.cpp) lives in
// the library that links the simulator (Tether::virtual_uno), so a service that drives only hardware links no
// libsimavr; enable_virtual_boards() there installs the opener.
#pragma once

#include <string>

#include <boost/asio/any_io_executor.hpp>

#include "tether/devices/rover.hpp"

namespace tether::devices::detail {

/// Opens a `virtual` or `virtual_ring` transport of `device`; errors are ConfigErrors naming
/// `transport_path`.
using VirtualBoardOpener = OpenedTransport (*)(const DeviceConfig& device, const std::string& transport_path,
                                               const boost::asio::any_io_executor& executor);

/// Installs the opener (enable_virtual_boards). Without one, virtual transports fail to open with
/// `DevicesError::not_supported` and a message naming the call and the library.
void register_virtual_board_opener(VirtualBoardOpener opener) noexcept;

}  // namespace tether::devices::detail
