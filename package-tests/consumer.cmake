# cmake -DSTEP=... -P consumer.cmake: the rover-service example (examples/rover-service) built and run as a
# user of Tether would.
#   STEP=build_installed  configure + build it against the install prefix PREFIX into BINARY
#   STEP=build_subdirectory  configure + build it with Tether as a subdirectory (SOURCE) into BINARY
#   STEP=run  run BINARY's rover-service-virtual on the virtual rover (CONFIG, FIRMWARE), and check that
#             rover-service links no libsimavr and refuses the virtual rover naming Tether::virtual_uno
include(${CMAKE_CURRENT_LIST_DIR}/run-checked.cmake)

set(common -G "Unix Makefiles" -DCMAKE_CXX_COMPILER=${CXX} "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}"
  "-DCMAKE_EXE_LINKER_FLAGS=${LINKER_FLAGS}")
if(LAUNCHER)
  list(APPEND common -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
endif()

if(STEP STREQUAL "build_installed")
  file(REMOVE_RECURSE ${BINARY})
  run_checked(${CMAKE_COMMAND} -S ${SOURCE}/examples/rover-service -B ${BINARY} ${common}
    -DCMAKE_PREFIX_PATH=${PREFIX})
  run_checked(${CMAKE_COMMAND} --build ${BINARY} -j2)
elseif(STEP STREQUAL "build_subdirectory")
  file(REMOVE_RECURSE ${BINARY})
  # No build type given: Tether must not force one on its parent; its tests, benchmarks, tools and AVR
  # images stay off (not the top-level project).
  # Tether is compiled again here, as a parent project would: plain flags (no sanitizers, no optimisation)
  # keep this, the suite's longest test, short; the prefix consumer above checks the sanitized build.
  set(plain -G "Unix Makefiles" -DCMAKE_CXX_COMPILER=${CXX} -DCMAKE_CXX_FLAGS=-O0)
  if(LAUNCHER)
    list(APPEND plain -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
  endif()
  run_checked(${CMAKE_COMMAND} -S ${SOURCE}/package-tests/add-subdirectory -B ${BINARY} ${plain}
    -DTETHER_SOURCE_DIR=${SOURCE} -DTETHER_SANITIZE=OFF)
  file(STRINGS ${BINARY}/CMakeCache.txt build_type REGEX "^CMAKE_BUILD_TYPE:")
  if(NOT build_type MATCHES "^CMAKE_BUILD_TYPE:[A-Z]*=$")
    message(FATAL_ERROR "Tether forced its parent's build type: ${build_type}")
  endif()
  foreach(off TETHER_BUILD_TESTS TETHER_BUILD_BENCHMARKS TETHER_BUILD_AVR TETHER_BUILD_TOOLS)
    file(STRINGS ${BINARY}/CMakeCache.txt value REGEX "^${off}:")
    if(NOT value MATCHES "=OFF$")
      message(FATAL_ERROR "${off} is not off by default for a subproject: ${value}")
    endif()
  endforeach()
  # A parent compiles Tether once: in unity batches unless it says otherwise.
  file(STRINGS ${BINARY}/CMakeCache.txt value REGEX "^TETHER_UNITY_BUILD:")
  if(NOT value MATCHES "=ON$")
    message(FATAL_ERROR "TETHER_UNITY_BUILD is not on by default for a subproject: ${value}")
  endif()
  run_checked(${CMAKE_COMMAND} --build ${BINARY} -j2 --target rover-service rover-service-virtual)
elseif(STEP STREQUAL "run")
  file(GLOB_RECURSE service LIST_DIRECTORIES false ${BINARY}/rover-service)
  file(GLOB_RECURSE service_virtual LIST_DIRECTORIES false ${BINARY}/rover-service-virtual)
  if(NOT service OR NOT service_virtual)
    message(FATAL_ERROR "rover-service binaries not found under ${BINARY}")
  endif()
  execute_process(COMMAND ${service_virtual} ${CONFIG} ${FIRMWARE} RESULT_VARIABLE result
    OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
  message(STATUS "rover-service-virtual: exit ${result}\n${out}${err}")
  if(NOT result EQUAL 0 OR NOT out MATCHES "arm \\(romi\\): \\[0\\]" OR NOT out MATCHES "\\(proxy\\): servo 9 at 90"
     OR NOT out MATCHES "ring \\(elcano\\): answered by sensor")
    message(FATAL_ERROR "rover-service-virtual did not drive one device of each codec")
  endif()
  # The hardware-only service: no libsimavr or libelf among its needed libraries, and a clear refusal.
  execute_process(COMMAND readelf -d ${service} OUTPUT_VARIABLE dynamic RESULT_VARIABLE result)
  if(NOT result EQUAL 0 OR NOT dynamic MATCHES "NEEDED")
    message(FATAL_ERROR "readelf -d ${service} failed: ${result}")
  endif()
  if(dynamic MATCHES "libsimavr|libelf")
    message(FATAL_ERROR "rover-service (no virtual boards) links the simulator:\n${dynamic}")
  endif()
  execute_process(COMMAND ${service} ${CONFIG} ${FIRMWARE} RESULT_VARIABLE result
    OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 60)
  if(NOT result EQUAL 2 OR NOT err MATCHES "devices\\[0\\]\\.transport\\.virtual.*link Tether::virtual_uno")
    message(FATAL_ERROR "rover-service on virtual boards: exit ${result}, '${out}${err}'")
  endif()
else()
  message(FATAL_ERROR "unknown STEP '${STEP}'")
endif()
