# Sources of the portable core, shared by the host build (core/CMakeLists.txt) and the AVR sub-build
# (firmware/CMakeLists.txt). Paths are relative to this file's directory.
set(TETHER_CORE_PORTABLE_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/src/status.cpp)
set(TETHER_CORE_HOST_SOURCES ${CMAKE_CURRENT_LIST_DIR}/src/crc_boost.cpp)
set(TETHER_CORE_AVR_SOURCES ${CMAKE_CURRENT_LIST_DIR}/src/crc_avr_libc.cpp ${CMAKE_CURRENT_LIST_DIR}/src/crc8_avr.cpp)
set(TETHER_CORE_INCLUDE_DIR ${CMAKE_CURRENT_LIST_DIR}/include)
