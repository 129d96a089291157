# Portable sources of the proxy codec (COBS + CRC-16 frames), shared by the host and the AVR sub-build.
set(TETHER_PROXY_PORTABLE_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/src/cobs.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/errors.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/encoder.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/session_policy.cpp)
set(TETHER_PROXY_INCLUDE_DIR ${CMAKE_CURRENT_LIST_DIR}/include)
