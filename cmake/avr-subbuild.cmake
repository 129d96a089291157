# Drives the AVR sub-build (firmware/CMakeLists.txt) with the avr-gcc toolchain. BUILD_ALWAYS makes every
# `cmake --build` re-check it, so a change in core/ or codecs/ that breaks avr-gcc fails the build at once.
find_program(TETHER_AVR_GXX avr-g++)
if(NOT TETHER_AVR_GXX)
  message(FATAL_ERROR "avr-g++ not found: run tools/setup (installs gcc-avr), or configure with -DTETHER_BUILD_AVR=OFF")
endif()

# nanopb runtime sources for the AVR (see tools/fetch-nanopb-source). tools/setup passes the directory;
# a hand-run configure finds what a previous setup unpacked under .deps/.
if(NOT TETHER_NANOPB_SOURCE_DIR)
  file(GLOB _nanopb_dirs LIST_DIRECTORIES true ${PROJECT_SOURCE_DIR}/.deps/nanopb-*)
  if(_nanopb_dirs)
    list(SORT _nanopb_dirs)
    list(GET _nanopb_dirs -1 _nanopb_dir)
    set(TETHER_NANOPB_SOURCE_DIR ${_nanopb_dir} CACHE PATH "nanopb source tree (from tools/fetch-nanopb-source)")
  else()
    message(FATAL_ERROR "nanopb runtime sources not found: run tools/setup deps (or tools/fetch-nanopb-source) first")
  endif()
endif()

include(ExternalProject)
ExternalProject_Add(avr-firmware
  SOURCE_DIR ${PROJECT_SOURCE_DIR}/firmware
  BINARY_DIR ${PROJECT_BINARY_DIR}/avr-build
  CMAKE_ARGS
    -DCMAKE_TOOLCHAIN_FILE=${PROJECT_SOURCE_DIR}/cmake/avr-gcc.cmake
    -DCMAKE_BUILD_TYPE=MinSizeRel
    -DTETHER_ROOT=${PROJECT_SOURCE_DIR}
    -DTETHER_FIRMWARE_OUTPUT_DIR=${TETHER_FIRMWARE_DIR}
    -DTETHER_NANOPB_SOURCE_DIR=${TETHER_NANOPB_SOURCE_DIR}
  BUILD_ALWAYS ON
  INSTALL_COMMAND ""
  USES_TERMINAL_BUILD ON)
