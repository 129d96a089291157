# cmake -P romi_only_consumer.cmake: Tether added as a subdirectory by projects that name the components
# they link (TETHER_COMPONENTS), and what their configure looked for (find_package_log.cmake logs every
# find_package call; the cache shows pkg-config modules and find modules' results):
#   romi-only (package-tests/romi-only): links Tether::romi; its configure must look for none of simavr,
#     libelf, libedit, pkg-config, protobuf, GoogleTest, pybind11, Python; it builds, and its program gets an
#     answer through romi::Client from a device on an in-memory stream. nlohmann-json is allowed: the Romi
#     client's headers include it.
#   the same project with TETHER_COMPONENTS=elcano (configure only): not nlohmann-json either.
# SOURCE: Tether's source tree; BINARY: scratch folder; CXX, LAUNCHER: the compiler and its launcher.
cmake_minimum_required(VERSION 3.25)  # policies of a script: IN_LIST
include(${CMAKE_CURRENT_LIST_DIR}/run-checked.cmake)

# Configures the consumer into `binary` with TETHER_COMPONENTS=`components`; fails when it looked for one of
# `forbidden` (lower case, matched in find_package names and cache entry names).
function(configure_consumer binary components forbidden)
  file(REMOVE_RECURSE ${binary})
  set(args -G "Unix Makefiles" -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_CXX_FLAGS=-O0
    -DCMAKE_PROJECT_TOP_LEVEL_INCLUDES=${CMAKE_CURRENT_LIST_DIR}/find_package_log.cmake
    -DTETHER_SOURCE_DIR=${SOURCE} "-DCONSUMER_COMPONENTS=${components}")
  if(LAUNCHER)
    list(APPEND args -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
  endif()
  run_checked(${CMAKE_COMMAND} -S ${CMAKE_CURRENT_LIST_DIR}/romi-only -B ${binary} ${args})

  file(STRINGS ${binary}/find_package.log looked_for)
  if(NOT "Boost" IN_LIST looked_for)
    message(FATAL_ERROR "the find_package log of ${binary} misses Boost (Tether's first dependency): "
      "the logging provider did not run (${looked_for})")
  endif()
  file(STRINGS ${binary}/CMakeCache.txt cache_lines REGEX "^[A-Za-z_][^:=]*:")
  set(names ${looked_for})
  foreach(line IN LISTS cache_lines)
    string(REGEX REPLACE ":.*" "" name "${line}")
    if(NOT name MATCHES "^TETHER_")  # Tether's own switches (TETHER_BUILD_PYTHON) name what they build
      list(APPEND names ${name})
    endif()
  endforeach()
  foreach(name IN LISTS names)
    string(TOLOWER "${name}" lower)
    foreach(word IN LISTS forbidden)
      if(lower MATCHES "${word}")
        message(FATAL_ERROR "configuring a consumer of Tether's ${components} looked for ${word} ('${name}'):\n"
          "find_package calls: ${looked_for}")
      endif()
    endforeach()
  endforeach()
  foreach(off TETHER_BUILD_SIMULATOR TETHER_BUILD_TOOLS TETHER_BUILD_TESTS TETHER_BUILD_PYTHON)
    file(STRINGS ${binary}/CMakeCache.txt value REGEX "^${off}:")
    if(NOT value MATCHES "=OFF$")
      message(FATAL_ERROR "${off} is not off by default for a subproject: ${value}")
    endif()
  endforeach()
  message(STATUS "${components}: find_package calls: ${looked_for}")
endfunction()

set(heavy simavr libelf libedit pkg_?config protobuf gtest pybind11 python benchmark libcrypto)

configure_consumer(${BINARY}/romi romi "${heavy}")
run_checked(${CMAKE_COMMAND} --build ${BINARY}/romi -j2 --target romi-only)
execute_process(COMMAND ${BINARY}/romi/romi-only RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err
  TIMEOUT 60)
if(NOT result EQUAL 0 OR NOT out MATCHES "romi-only: \\[0,7\\]")
  message(FATAL_ERROR "romi-only: exit ${result}, '${out}${err}'")
endif()
execute_process(COMMAND readelf -d ${BINARY}/romi/romi-only OUTPUT_VARIABLE dynamic RESULT_VARIABLE result)
if(NOT result EQUAL 0 OR dynamic MATCHES "libsimavr|libelf|libprotobuf|libedit")
  message(FATAL_ERROR "romi-only links more than it needs (readelf exit ${result}):\n${dynamic}")
endif()

configure_consumer(${BINARY}/elcano elcano "${heavy};nlohmann")
