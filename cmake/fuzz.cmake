# tether_fuzz_target(NAME SOURCES... LIBRARIES... CORPUS DIR): one fuzz target per decoder.
#  - Normal builds: the target is linked with the corpus-and-random driver and registered as the ctest
#    test fuzz.NAME (a short, seeded run on every test command).
#  - TETHER_FUZZ=ON with clang (tools/fuzz): a real libFuzzer binary fuzz_NAME, run by tools/fuzz.
option(TETHER_FUZZ "Build fuzz targets with libFuzzer (needs clang)" OFF)
function(tether_fuzz_target name)
  cmake_parse_arguments(FUZZ "" "CORPUS" "SOURCES;LIBRARIES" ${ARGN})
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
    add_test(NAME fuzz.${name} COMMAND fuzz_${name} --iterations 20000 ${FUZZ_CORPUS})
  endif()
endfunction()
