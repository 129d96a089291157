# tether_fuzz_target(NAME SOURCES... LIBRARIES... CORPUS DIR [ITERATIONS N]): one fuzz target per decoder.
#  - Normal builds: the target is linked with the corpus-and-random driver and registered as the ctest
#    test fuzz.NAME (a short, seeded run on every test command: N generated inputs, default 20000; fewer
#    for a target whose inputs are costly, so the test stays around ten seconds in the sanitizer build).
#  - TETHER_FUZZ=ON with clang (tools/fuzz): a real libFuzzer binary fuzz_NAME, run by tools/fuzz. Every
#    target of the project is then compiled with coverage feedback and ASan/UBSan (the top-level
#    CMakeLists.txt includes this file before its subdirectories), so the fuzzer sees and checks the codec
#    libraries, CRCs, clients and device loops a target calls, not only the target's own file.
include_guard(GLOBAL)
option(TETHER_FUZZ "Build fuzz targets with libFuzzer (needs clang)" OFF)
if(TETHER_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "TETHER_FUZZ=ON needs clang (tools/fuzz configures it)")
  endif()
  # Directory scope: applies to every target defined after the top-level include, libraries included.
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=undefined
    -fno-omit-frame-pointer)
  add_link_options(-fsanitize=address,undefined)
endif()

# LLVM's FuzzedDataProvider (Debian: libclang-rt-14-dev), for targets that build values out of the input:
# `#include <fuzzer/FuzzedDataProvider.h>`. Its folder holds clang's own stddef.h & co, which must not
# shadow g++'s, so only the `fuzzer` subfolder is linked into the build tree (a system include: its
# warnings are not the project's).
if(NOT TETHER_FUZZED_DATA_PROVIDER)
  file(GLOB _tether_clang_includes /usr/lib/llvm-*/lib/clang/*/include)
  find_file(TETHER_FUZZED_DATA_PROVIDER fuzzer/FuzzedDataProvider.h PATHS ${_tether_clang_includes} NO_DEFAULT_PATH)
  if(NOT TETHER_FUZZED_DATA_PROVIDER)
    message(FATAL_ERROR "fuzzer/FuzzedDataProvider.h not found: apt-get install libclang-rt-14-dev (tools/setup deps)")
  endif()
endif()
get_filename_component(_tether_fuzzer_dir "${TETHER_FUZZED_DATA_PROVIDER}" DIRECTORY)
set(TETHER_FUZZ_INCLUDE_DIR ${CMAKE_BINARY_DIR}/fuzz-include)
if(NOT EXISTS ${TETHER_FUZZ_INCLUDE_DIR}/fuzzer)
  file(MAKE_DIRECTORY ${TETHER_FUZZ_INCLUDE_DIR})
  file(CREATE_LINK ${_tether_fuzzer_dir} ${TETHER_FUZZ_INCLUDE_DIR}/fuzzer SYMBOLIC)
endif()

function(tether_fuzz_target name)
  cmake_parse_arguments(FUZZ "" "CORPUS;ITERATIONS" "SOURCES;LIBRARIES" ${ARGN})
  if(NOT FUZZ_ITERATIONS)
    set(FUZZ_ITERATIONS 20000)
  endif()
  add_executable(fuzz_${name} ${FUZZ_SOURCES})
  target_link_libraries(fuzz_${name} PRIVATE ${FUZZ_LIBRARIES} tether::testing)
  target_include_directories(fuzz_${name} SYSTEM PRIVATE ${TETHER_FUZZ_INCLUDE_DIR})
  tether_warnings(fuzz_${name})
  if(TETHER_FUZZ)
    target_compile_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
    target_link_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
  else()
    target_link_libraries(fuzz_${name} PRIVATE tether_fuzz_driver)
    add_test(NAME fuzz.${name} COMMAND fuzz_${name} --iterations ${FUZZ_ITERATIONS} ${FUZZ_CORPUS})
    tether_label_tests(fuzz fuzz.${name})
  endif()
endfunction()
