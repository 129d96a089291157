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

# tether_add_gtests(<target> PREFIX <prefix> LABEL <label> [FILTER <gtest filter>] [NO_PRECOMPILED_HEADER]
#                   [PROPERTIES <name> <value>...]):
# registers every GoogleTest case of <target> (or those FILTER selects) as <prefix><Suite>.<Case> with <label>
# (and the further test properties). A program that gathers several folders' or tiers' cases is registered
# once per FILTER, so each case keeps its name and tier. Its C++ units include the shared precompiled header
# (cmake/precompiled-header.cmake) unless NO_PRECOMPILED_HEADER: for a program of many small units that do
# not include what the header holds (loading it costs about 1.5 s of CPU per unit).
function(tether_add_gtests target)
  cmake_parse_arguments(TESTS "NO_PRECOMPILED_HEADER" "PREFIX;LABEL;FILTER" "PROPERTIES" ${ARGN})
  if(NOT TESTS_PREFIX OR NOT TESTS_LABEL)
    message(FATAL_ERROR "tether_add_gtests(${target}) needs PREFIX and LABEL")
  endif()
  _tether_check_label(${TESTS_LABEL})
  set(filter "")
  if(TESTS_FILTER)
    set(filter TEST_FILTER "${TESTS_FILTER}")
  endif()
  target_compile_options(${target} PRIVATE ${TETHER_TEST_SANITIZE_FLAGS})  # see the top-level CMakeLists.txt
  if(NOT TESTS_NO_PRECOMPILED_HEADER)
    tether_use_precompiled_header(${target} tether_test_pch)
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
