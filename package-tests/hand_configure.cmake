# cmake -P hand_configure.cmake: the project configured by hand as docs/building.md writes it (`cmake -S .
# -B build`, nothing else), after `tools/setup deps` has unpacked the nanopb sources under .deps/: the
# configure finds them before the codecs, so the rpc codec's kit for `tether generate` is built and installed
# (found only by the AVR sub-build, after the codecs, the kit was left out with a STATUS line).
# SOURCE: Tether's source tree; BINARY: scratch folder.
cmake_minimum_required(VERSION 3.25)

file(GLOB fetched LIST_DIRECTORIES true ${SOURCE}/.deps/nanopb-*)
if(NOT fetched)
  message(FATAL_ERROR "${SOURCE}/.deps has no nanopb sources: run tools/setup deps (or tools/fetch-nanopb-source)")
endif()
file(REMOVE_RECURSE ${BINARY})
# Tests, benchmarks and the Python module off: what is checked is the configure of the libraries and tools.
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE} -B ${BINARY} -DTETHER_BUILD_TESTS=OFF
                        -DTETHER_BUILD_BENCHMARKS=OFF -DTETHER_BUILD_PYTHON=OFF
                OUTPUT_VARIABLE output ERROR_VARIABLE errors RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "the hand-run configure failed (${status}):\n${output}\n${errors}")
endif()
if(output MATCHES "no kit for `tether generate`")
  message(FATAL_ERROR "the hand-run configure left out the kit of `tether generate`:\n${output}")
endif()
if(NOT EXISTS ${BINARY}/codecs/rpc/arduino/Makefile)
  message(FATAL_ERROR "no build of the kit (codecs/rpc/arduino) in ${BINARY}")
endif()
file(REMOVE_RECURSE ${BINARY})
