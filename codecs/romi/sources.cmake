# Portable sources of the Romi codec, shared by the host build and the AVR sub-build.
set(TETHER_ROMI_PORTABLE_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/src/errors.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/encoder.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/request_parser.cpp)
set(TETHER_ROMI_INCLUDE_DIR ${CMAKE_CURRENT_LIST_DIR}/include)
