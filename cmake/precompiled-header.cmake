# Shared precompiled headers for the test build (`tools/setup test`; TETHER_PRECOMPILED_HEADERS, on by default
# with GCC when the tests are built in unity batches, as there). A developer's source-by-source build stays
# the one that checks each source includes what it uses, which a forced header would hide; packagers' and
# parent projects' builds (no tests) compile plainly: at -O2, GCC 12 does not keep the system-header status
# of the headers inside a precompiled header, so libstdc++'s known false -Warray-bounds in string
# concatenation is reported and -Werror fails the build (docs/building.md).
# Nearly every heavy unit of the test build parses asio and nlohmann::json (and the test programs
# GoogleTest) before its own code: a sanitized test unit took 23.7 s of CPU, 20.4 s with a precompiled
# header of them (docs/building.md). A header is built once per flag set, by a target of its own, and a unit
# includes it first: `-include`, ahead of the asio workaround's forced <utility> (a precompiled header must
# come before anything else to be used; the headers hold <utility> themselves). -Winvalid-pch with -Werror
# makes a header built with other flags an error, never a silently slow build.
#
#   tether_test_pch     the test programs (tether_add_gtests): GoogleTest, asio, JSON, the test programs' flags
#   tether_library_pch  the heavy static libraries (those tether_unity_build lists, the codec plugins): asio,
#                       JSON, all of UBSan
#
# Not the fuzz targets nor the benchmarks: half of them are small units that include neither, where loading
# a header (about 1.5 s of CPU) costs more than it saves. The top-level CMakeLists.txt includes this file
# before the targets (after CMAKE_POSITION_INDEPENDENT_CODE: a header records -fPIC or -fPIE); without the
# headers, tether_use_precompiled_header does nothing.
include_guard(GLOBAL)
if(TETHER_BUILD_TESTS AND TETHER_UNITY_BUILD)
  set(_tether_pch_default ON)
else()
  set(_tether_pch_default OFF)
endif()
option(TETHER_PRECOMPILED_HEADERS "Compile the test build's heavy units with shared precompiled headers (GCC)"
  ${_tether_pch_default})

# _tether_define_pch(<name> EXECUTABLE|LIBRARY OPTIONS <flags>... HEADERS <header>... LIBRARIES <lib>...)
function(_tether_define_pch name kind)
  cmake_parse_arguments(PCH "" "" "OPTIONS;HEADERS;LIBRARIES" ${ARGN})
  set(source ${PROJECT_BINARY_DIR}/CMakeFiles/${name}_source.cpp)
  file(CONFIGURE OUTPUT ${source} CONTENT "// Builds a shared precompiled header (cmake/precompiled-header.cmake).\nint main() { return 0; }\n")
  # The kind of target that uses it: the header records -fPIE or -fPIC, which must match.
  if(kind STREQUAL "EXECUTABLE")
    add_executable(${name} EXCLUDE_FROM_ALL ${source})
  else()
    add_library(${name} STATIC EXCLUDE_FROM_ALL ${source})
  endif()
  target_link_libraries(${name} PRIVATE ${PCH_LIBRARIES})
  target_compile_definitions(${name} PRIVATE BOOST_ALL_NO_LIB BOOST_ASIO_NO_DEPRECATED)
  target_compile_options(${name} PRIVATE ${PCH_OPTIONS})
  target_precompile_headers(${name} PRIVATE ${PCH_HEADERS})
  # Where CMake writes the header it precompiles (the .gch beside it).
  set_target_properties(${name} PROPERTIES TETHER_PCH_HEADER ${CMAKE_CURRENT_BINARY_DIR}/CMakeFiles/${name}.dir/cmake_pch.hxx)
endfunction()

# tether_use_precompiled_header(<target> <pch>): <target>'s C++ units include <pch>'s header first, with the
# definitions it was built with (GoogleTest's come with GTest::gtest, which every test program links).
function(tether_use_precompiled_header target pch)
  if(NOT TARGET ${pch})
    return()
  endif()
  get_target_property(header ${pch} TETHER_PCH_HEADER)
  target_compile_options(${target} BEFORE PRIVATE "$<$<COMPILE_LANGUAGE:CXX>:-Winvalid-pch;-include${header}>")
  target_compile_definitions(${target} PRIVATE BOOST_ALL_NO_LIB BOOST_ASIO_NO_DEPRECATED)
  add_dependencies(${target} ${pch})
endfunction()

if(TETHER_PRECOMPILED_HEADERS AND CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND NOT TETHER_FUZZ)
  find_package(nlohmann_json 3 REQUIRED)
  if(TETHER_BUILD_TESTS)
    _tether_define_pch(tether_test_pch EXECUTABLE OPTIONS ${TETHER_TEST_SANITIZE_FLAGS}
      HEADERS <utility> <gtest/gtest.h> <boost/asio.hpp> <nlohmann/json.hpp>
      LIBRARIES GTest::gtest Boost::headers nlohmann_json::nlohmann_json)
  endif()
  _tether_define_pch(tether_library_pch LIBRARY
    HEADERS <utility> <boost/asio.hpp> <nlohmann/json.hpp>
    LIBRARIES Boost::headers nlohmann_json::nlohmann_json)
endif()
