# Test registration: every test carries exactly one tier label, so `ctest -L unit` is the edit loop.
#   unit    portable logic on the host: no threads, no I/O, no simulator (seconds)
#   client  host clients and transports on in-memory streams, ptys and local processes
#   sim     firmware images on the simulated Uno (interop tests, virtual rovers, the demo)
#   cli     the `tether` command and its subcommands
#   fuzz    the fuzz targets' corpus replays
#   package install, consumers, public headers
#   python  the pytest suite over the Python package (python/tests, codecs/*/plugin/python)
set(TETHER_TEST_LABELS unit client sim cli fuzz package python)

function(_tether_check_label label)
  if(NOT label IN_LIST TETHER_TEST_LABELS)
    message(FATAL_ERROR "test label '${label}' is not one of: ${TETHER_TEST_LABELS}")
  endif()
endfunction()

# One precompiled header for the test programs' C++ units: GoogleTest, asio and nlohmann::json, which nearly
# every test program includes and which took the largest share of a typical unit's parsing (a sanitized test
# unit: 23.7 -> 20.4 s of CPU with it; docs/building.md). Built once, by a target of its own with the test
# programs' flags; each program includes it first (`-include`, ahead of the asio workaround's forced
# <utility>, which a precompiled header must precede to be used; the header holds <utility> itself), and
# -Winvalid-pch with -Werror makes a header built with other flags an error, never a silently slow build.
option(TETHER_TEST_PCH "Compile the test programs with one shared precompiled header (GCC)" ON)
set(TETHER_TEST_PCH_HEADER "")
if(TETHER_TEST_PCH AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
  find_package(nlohmann_json 3 REQUIRED)
  set(_tether_test_pch_main ${PROJECT_BINARY_DIR}/CMakeFiles/tether_test_pch_main.cpp)
  file(CONFIGURE OUTPUT ${_tether_test_pch_main}
    CONTENT "// Builds the test programs' precompiled header (cmake/testing.cmake).\nint main() { return 0; }\n")
  # An executable, as the test programs are: the header records -fPIE (a library's -fPIC would not match).
  add_executable(tether_test_pch EXCLUDE_FROM_ALL ${_tether_test_pch_main})
  target_link_libraries(tether_test_pch PRIVATE GTest::gtest Boost::headers nlohmann_json::nlohmann_json)
  target_compile_definitions(tether_test_pch PRIVATE BOOST_ASIO_NO_DEPRECATED)
  target_compile_options(tether_test_pch PRIVATE ${TETHER_TEST_SANITIZE_FLAGS})
  target_precompile_headers(tether_test_pch PRIVATE <utility> <gtest/gtest.h> <boost/asio.hpp> <nlohmann/json.hpp>)
  set(TETHER_TEST_PCH_HEADER ${PROJECT_BINARY_DIR}/CMakeFiles/tether_test_pch.dir/cmake_pch.hxx)
endif()

# tether_add_gtests(<target> PREFIX <prefix> LABEL <label> [FILTER <gtest filter>] [PROPERTIES <name> <value>...]):
# registers every GoogleTest case of <target> (or those FILTER selects) as <prefix><Suite>.<Case> with <label>
# (and the further test properties). A program that gathers several folders' or tiers' cases is registered
# once per FILTER, so each case keeps its name and tier.
function(tether_add_gtests target)
  cmake_parse_arguments(TESTS "" "PREFIX;LABEL;FILTER" "PROPERTIES" ${ARGN})
  if(NOT TESTS_PREFIX OR NOT TESTS_LABEL)
    message(FATAL_ERROR "tether_add_gtests(${target}) needs PREFIX and LABEL")
  endif()
  _tether_check_label(${TESTS_LABEL})
  set(filter "")
  if(TESTS_FILTER)
    set(filter TEST_FILTER "${TESTS_FILTER}")
  endif()
  target_compile_options(${target} PRIVATE ${TETHER_TEST_SANITIZE_FLAGS})  # see the top-level CMakeLists.txt
  if(TETHER_TEST_PCH_HEADER)
    # First on the command line (BEFORE): the header's definitions as the header was built with them.
    target_compile_options(${target} BEFORE PRIVATE
      "$<$<COMPILE_LANGUAGE:CXX>:-Winvalid-pch;-include${TETHER_TEST_PCH_HEADER}>")
    target_compile_definitions(${target} PRIVATE BOOST_ALL_NO_LIB BOOST_ASIO_NO_DEPRECATED)
    add_dependencies(${target} tether_test_pch)
  endif()
  gtest_discover_tests(${target} TEST_PREFIX "${TESTS_PREFIX}" DISCOVERY_TIMEOUT 60 ${filter}
    PROPERTIES LABELS ${TESTS_LABEL} ${TESTS_PROPERTIES})
endfunction()

# tether_label_tests(<label> <test>...): labels tests registered with add_test.
function(tether_label_tests label)
  _tether_check_label(${label})
  set_tests_properties(${ARGN} PROPERTIES LABELS ${label})
endfunction()

# tether_label_directory_tests(<label>): labels every add_test of the calling directory (call it last).
function(tether_label_directory_tests label)
  get_property(tests DIRECTORY PROPERTY TESTS)
  if(tests)
    tether_label_tests(${label} ${tests})
  endif()
endfunction()
