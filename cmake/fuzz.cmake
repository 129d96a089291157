# tether_fuzz_target(NAME SOURCES... LIBRARIES... CORPUS DIR [ITERATIONS N]): one fuzz target per decoder.
#  - Normal builds: the target is linked with the corpus-and-random driver and registered as the ctest
#    test fuzz.NAME (a short, seeded run on every test command: N generated inputs, default 20000; fewer
#    for a target whose inputs are costly, so the test stays around ten seconds in the sanitizer build).
#  - TETHER_FUZZ=ON with clang (tools/fuzz): a real libFuzzer binary fuzz_NAME, run by tools/fuzz.
option(TETHER_FUZZ "Build fuzz targets with libFuzzer (needs clang)" OFF)
function(tether_fuzz_target name)
  cmake_parse_arguments(FUZZ "" "CORPUS;ITERATIONS" "SOURCES;LIBRARIES" ${ARGN})
  if(NOT FUZZ_ITERATIONS)
    set(FUZZ_ITERATIONS 20000)
  endif()
  add_executable(fuzz_${name} ${FUZZ_SOURCES})
  target_link_libraries(fuzz_${name} PRIVATE ${FUZZ_LIBRARIES} tether::testing)
  tether_warnings(fuzz_${name})
  if(TETHER_FUZZ)
    if(NOT CMAKE_CXX_COMPILER_ID MATCHES "Clang")
      message(FATAL_ERROR "TETHER_FUZZ=ON needs clang (tools/fuzz configures it)")
    endif()
    target_compile_options(fuzz_${name} PRIVATE -fsanitize=fuzzer,address,undefined)
    target_link_options(fuzz_${name} PRIVATE -fsanitize=fuzzer,address,undefined)
  else()
    target_link_libraries(fuzz_${name} PRIVATE tether_fuzz_driver)
    add_test(NAME fuzz.${name} COMMAND fuzz_${name} --iterations ${FUZZ_ITERATIONS} ${FUZZ_CORPUS})
  endif()
endfunction()
