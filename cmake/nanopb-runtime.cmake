# nanopb runtime (pb_common.c pb_encode.c pb_decode.c) as the static library `nanopb_runtime`, for the
# AVR sub-build (firmware/CMakeLists.txt, avr-gcc toolchain).
#
# Why from source: Debian ships the nanopb generator and headers, but the runtime only as an x86-64
# static lib. tools/fetch-nanopb-source unpacks Debian's source package of exactly the installed nanopb
# version into .deps/nanopb-<version>/ and tools/setup passes that directory as TETHER_NANOPB_SOURCE_DIR.
include_guard(GLOBAL)

set(TETHER_NANOPB_SOURCE_DIR "" CACHE PATH
  "nanopb source tree with pb_*.c matching the installed nanopb (from tools/fetch-nanopb-source)")

if(NOT CMAKE_C_COMPILER_LOADED)
  message(FATAL_ERROR "nanopb-runtime.cmake needs the C language: add C to project(... LANGUAGES ...)")
endif()

set(_tether_nanopb_hint
  "Run tools/fetch-nanopb-source (or tools/setup deps) and pass the directory it prints as -DTETHER_NANOPB_SOURCE_DIR=<dir>.")
if(NOT TETHER_NANOPB_SOURCE_DIR)
  message(FATAL_ERROR "TETHER_NANOPB_SOURCE_DIR is not set; the AVR images need the nanopb runtime sources. ${_tether_nanopb_hint}")
endif()
set(_tether_nanopb_missing "")
foreach(_f pb.h pb_common.h pb_encode.h pb_decode.h pb_common.c pb_encode.c pb_decode.c)
  if(NOT EXISTS "${TETHER_NANOPB_SOURCE_DIR}/${_f}")
    list(APPEND _tether_nanopb_missing ${_f})
  endif()
endforeach()
if(_tether_nanopb_missing)
  list(JOIN _tether_nanopb_missing ", " _tether_nanopb_missing)
  message(FATAL_ERROR "TETHER_NANOPB_SOURCE_DIR=${TETHER_NANOPB_SOURCE_DIR} lacks ${_tether_nanopb_missing}. ${_tether_nanopb_hint}")
endif()

add_library(nanopb_runtime STATIC
  ${TETHER_NANOPB_SOURCE_DIR}/pb_common.c
  ${TETHER_NANOPB_SOURCE_DIR}/pb_encode.c
  ${TETHER_NANOPB_SOURCE_DIR}/pb_decode.c)
# SYSTEM: third-party headers, so our -Wconversion/-Werror targets are not failed by nanopb's own code.
target_include_directories(nanopb_runtime SYSTEM PUBLIC ${TETHER_NANOPB_SOURCE_DIR})
# PUBLIC so the runtime, the generated *.pb.c and our code all see the same pb.h configuration; a
# mismatch silently changes struct layouts. No 64-bit fields, no error strings and buffer-only streams
# (Tether always encodes to and decodes from memory) keep flash/RAM down.
target_compile_definitions(nanopb_runtime PUBLIC PB_WITHOUT_64BIT PB_NO_ERRMSG PB_BUFFER_ONLY)
# Deliberately no tether_warnings(): this is upstream code, warnings are not ours to fix.
# Smaller code for the AVR, measured on proxy.elf (each option on its own, then together): no switch jump
# tables (-32 B), 32-bit values kept whole instead of split into bytes (-44 B), small functions not inlined
# (-14 B); together 17108 -> 17012 B of .text. Per-function options: LTO keeps them for this code only.
target_compile_options(nanopb_runtime PRIVATE -fno-jump-tables -fno-split-wide-types -fno-inline-small-functions)

unset(_f)
unset(_tether_nanopb_missing)
unset(_tether_nanopb_hint)
