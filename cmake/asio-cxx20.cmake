# Boost.Asio's awaitable.hpp (Boost 1.74, Debian 12's libboost-dev) uses std::exchange without including
# <utility>; libstdc++ 12 no longer brings <utility> in through the headers asio includes before it, so under
# C++20 (which Tether's targets require of their users) `#include <boost/asio.hpp>` alone does not compile.
# When, and only when, this machine's Boost headers fail that way, TETHER_ASIO_CXX20_FLAGS holds the one
# workaround: <utility> included first in every C++ unit of the targets that use asio (tether_transports
# carries it to its users, in the build tree, the installed package and pkg-config's Cflags alike).
include_guard(GLOBAL)
include(CheckCXXSourceCompiles)
include(CMakePushCheckState)

set(TETHER_ASIO_CXX20_FLAGS "")
cmake_push_check_state(RESET)
set(CMAKE_REQUIRED_LIBRARIES Boost::headers)
set(CMAKE_REQUIRED_QUIET ON)
set(_asio_unit "#include <boost/asio/awaitable.hpp>\nint main() { return 0; }\n")
check_cxx_source_compiles("${_asio_unit}" TETHER_ASIO_AWAITABLE_COMPILES)
if(NOT TETHER_ASIO_AWAITABLE_COMPILES)
  check_cxx_source_compiles("#include <utility>\n${_asio_unit}" TETHER_ASIO_AWAITABLE_COMPILES_AFTER_UTILITY)
  if(TETHER_ASIO_AWAITABLE_COMPILES_AFTER_UTILITY)
    set(TETHER_ASIO_CXX20_FLAGS -include utility)
    message(STATUS "Boost ${Boost_VERSION}: <boost/asio.hpp> needs <utility> first under C++${CMAKE_CXX_STANDARD}; "
      "Tether's asio targets include it for their users")
  endif()
endif()
cmake_pop_check_state()
