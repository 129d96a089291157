# tether_fuzz_target(NAME SOURCES... LIBRARIES... CORPUS ARCHIVE [ITERATIONS N]): one fuzz target per decoder.
#  - CORPUS is the target's seed corpus as one archive, fuzz/corpus-NAME.tar.xz beside the target (one file
#    in git instead of one per input). The build unpacks it into <build>/<dir>/fuzz-corpus/NAME/inputs/
#    before building fuzz_NAME, and again whenever the archive changes; `tools/fuzz pack NAME` and
#    `tools/fuzz add NAME FILE...` write it (cmake/fuzz-corpus-pack.cmake: reproducible bytes).
#  - Normal builds: the target is linked with the corpus-and-random driver and registered as the ctest
#    test fuzz.NAME, which replays every input of the unpacked corpus and then runs N generated inputs
#    (default 20000; fewer for a target whose inputs are costly, so the test stays around ten seconds in
#    the sanitizer build).
#  - TETHER_FUZZ=ON with clang (tools/fuzz): a real libFuzzer binary fuzz_NAME, run by tools/fuzz on the
#    unpacked corpus. Every target of the project is then compiled with coverage feedback and ASan/UBSan
#    (the top-level CMakeLists.txt includes this file before its subdirectories), so the fuzzer sees and
#    checks the codec libraries, CRCs, clients and device loops a target calls, not only the target's own
#    file.
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
  cmake_path(ABSOLUTE_PATH FUZZ_CORPUS BASE_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR} NORMALIZE)
  if(NOT FUZZ_CORPUS MATCHES "/corpus-${name}\\.tar\\.xz$" OR NOT EXISTS ${FUZZ_CORPUS}
     OR IS_DIRECTORY ${FUZZ_CORPUS})
    message(FATAL_ERROR "tether_fuzz_target(${name}): CORPUS must be an existing archive named corpus-${name}.tar.xz, "
      "not ${FUZZ_CORPUS} (a folder of inputs becomes one with "
      "cmake -DDIR=<folder> -DARCHIVE=<.../corpus-${name}.tar.xz> -P cmake/fuzz-corpus-pack.cmake)")
  endif()

  # Unpacked at build time into a fresh folder, so the inputs are exactly the archive's (none left over
  # from an earlier version of it). The stamp sits beside the folder, not in it: everything in the folder
  # is an input.
  set(corpus_dir ${CMAKE_CURRENT_BINARY_DIR}/fuzz-corpus/${name})
  cmake_path(RELATIVE_PATH FUZZ_CORPUS BASE_DIRECTORY ${PROJECT_SOURCE_DIR} OUTPUT_VARIABLE corpus_shown)
  add_custom_command(OUTPUT ${corpus_dir}/unpacked.stamp
    COMMAND ${CMAKE_COMMAND} -E rm -rf ${corpus_dir}/inputs
    COMMAND ${CMAKE_COMMAND} -E make_directory ${corpus_dir}/inputs
    COMMAND ${CMAKE_COMMAND} -E chdir ${corpus_dir}/inputs ${CMAKE_COMMAND} -E tar xf ${FUZZ_CORPUS}
    COMMAND ${CMAKE_COMMAND} -E touch ${corpus_dir}/unpacked.stamp
    DEPENDS ${FUZZ_CORPUS}
    COMMENT "Unpacking the fuzz corpus ${corpus_shown}"
    VERBATIM)
  add_custom_target(fuzz-corpus-${name} DEPENDS ${corpus_dir}/unpacked.stamp)

  add_executable(fuzz_${name} ${FUZZ_SOURCES})
  add_dependencies(fuzz_${name} fuzz-corpus-${name})
  target_link_libraries(fuzz_${name} PRIVATE ${FUZZ_LIBRARIES} tether::testing)
  target_include_directories(fuzz_${name} SYSTEM PRIVATE ${TETHER_FUZZ_INCLUDE_DIR})
  tether_warnings(fuzz_${name})
  if(TETHER_FUZZ)
    target_compile_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
    target_link_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
  else()
    target_link_libraries(fuzz_${name} PRIVATE tether_fuzz_driver)
    tether_unity_build(fuzz_${name})
    add_test(NAME fuzz.${name} COMMAND fuzz_${name} --iterations ${FUZZ_ITERATIONS} ${corpus_dir}/inputs)
    tether_label_tests(fuzz fuzz.${name})
  endif()
endfunction()
