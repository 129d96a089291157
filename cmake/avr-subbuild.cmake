# Drives the AVR sub-build (firmware/CMakeLists.txt) with the avr-gcc toolchain. BUILD_ALWAYS makes every
# `cmake --build` re-check it, so a change in core/ or codecs/ that breaks avr-gcc fails the build at once.
find_program(TETHER_AVR_GXX avr-g++)
if(NOT TETHER_AVR_GXX)
  message(FATAL_ERROR "avr-g++ not found: run tools/setup (installs gcc-avr), or configure with -DTETHER_BUILD_AVR=OFF")
endif()

# nanopb runtime sources for the AVR: found before the codecs (nanopb-source.cmake), or the sub-build fails.
if(NOT TETHER_NANOPB_SOURCE_DIR)
  message(FATAL_ERROR "nanopb runtime sources not found: run tools/setup deps (or tools/fetch-nanopb-source) first")
endif()

# What the sub-build takes from this build, generically (a codec is its folder and its registration):
#   - TETHER_CODECS: the codecs built here; firmware/CMakeLists.txt adds codecs/<codec>/firmware/ of each;
#   - the host programs an AVR part runs at build time (a generator): a codec appends `NAME=target` to the
#     global property TETHER_AVR_HOST_PROGRAMS, the sub-build gets TETHER_HOST_PROGRAM_<NAME> = the program's
#     path, and is built after them. Paths, not configurations: the sub-build is configured once, and
#     $<TARGET_FILE> of a single-configuration build stays put whatever its build type.
set(_tether_avr_codecs "")
foreach(_codec IN LISTS TETHER_CODECS)
  if(_codec IN_LIST TETHER_BUILT_COMPONENTS)
    list(APPEND _tether_avr_codecs ${_codec})
  endif()
endforeach()
get_property(_tether_avr_programs GLOBAL PROPERTY TETHER_AVR_HOST_PROGRAMS)
set(_tether_avr_program_paths "")
set(_tether_avr_program_targets "")
foreach(_entry IN LISTS _tether_avr_programs)
  if(NOT _entry MATCHES "^([A-Za-z0-9_]+)=(.+)$")
    message(FATAL_ERROR "TETHER_AVR_HOST_PROGRAMS: '${_entry}' is not NAME=target")
  endif()
  list(APPEND _tether_avr_program_paths "${CMAKE_MATCH_1}=$<TARGET_FILE:${CMAKE_MATCH_2}>")
  list(APPEND _tether_avr_program_targets ${CMAKE_MATCH_2})
endforeach()
# Lists cross the ExternalProject boundary with `|` for `;` (LIST_SEPARATOR).
string(REPLACE ";" "|" _tether_avr_codecs_arg "${_tether_avr_codecs}")
string(REPLACE ";" "|" _tether_avr_programs_arg "${_tether_avr_program_paths}")

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
    -DTETHER_CODECS=${_tether_avr_codecs_arg}
    -DTETHER_HOST_PROGRAMS=${_tether_avr_programs_arg}
  LIST_SEPARATOR |
  DEPENDS ${_tether_avr_program_targets}
  BUILD_ALWAYS ON
  INSTALL_COMMAND ""
  USES_TERMINAL_BUILD ON)
