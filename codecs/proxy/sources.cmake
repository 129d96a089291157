# Portable sources of the proxy codec (COBS + CRC-16 frames), shared by the host and the AVR sub-build.
set(TETHER_PROXY_PORTABLE_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/src/cobs.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/frame.cpp)
set(TETHER_PROXY_INCLUDE_DIR ${CMAKE_CURRENT_LIST_DIR}/include)
