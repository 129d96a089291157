# cmake -DSOURCE=... -DBINARY=... -DFIRMWARE=... -DCXX=... -DPREFIX=... [-DCXX_FLAGS= -DLINKER_FLAGS=
# -DLAUNCHER=] -P rpc_consumer.cmake: the rpc codec's C++ example (examples/rpc: find_package(Tether
# COMPONENTS rpc) + tether_generate_rpc on arm.proto) built as its README says, against the install prefix
# PREFIX, and its program run on the example's image in FIRMWARE on a virtual Uno.
include(${CMAKE_CURRENT_LIST_DIR}/run-checked.cmake)

file(REMOVE_RECURSE ${BINARY})
set(source ${BINARY}/source)
file(COPY ${SOURCE}/examples/rpc/ DESTINATION ${source})

set(args -G "Unix Makefiles" -DCMAKE_CXX_COMPILER=${CXX} "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}"
  "-DCMAKE_EXE_LINKER_FLAGS=${LINKER_FLAGS}" -DCMAKE_PREFIX_PATH=${PREFIX})
if(LAUNCHER)
  list(APPEND args -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
endif()
run_checked(${CMAKE_COMMAND} -S ${source} -B ${BINARY}/build ${args})
run_checked(${CMAKE_COMMAND} --build ${BINARY}/build -j2)
foreach(generated arm.pb.h arm.tether.hpp arm.tether.cpp)
  if(NOT EXISTS ${BINARY}/build/arm_rpc-rpc/${generated})
    message(FATAL_ERROR "tether_generate_rpc wrote no ${generated} in ${BINARY}/build/arm_rpc-rpc")
  endif()
endforeach()

execute_process(COMMAND ${BINARY}/build/arm-client --virtual ${FIRMWARE}/rpc-example.elf
  RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
message(STATUS "arm-client: exit ${result}\n${out}${err}")
if(NOT result EQUAL 0 OR NOT out MATCHES "MoveJoint\\(2, -4500\\): reached -4500"
   OR NOT out MATCHES "MoveJoint\\(9, 0\\): device error 1: " OR NOT out MATCHES "Describe: [^\n]*-9000\\.\\.9000"
   OR NOT out MATCHES "Watch: [3-9][0-9]* states, joint 2 at -4500")
  message(FATAL_ERROR "arm-client did not get the example device's answers through its typed client")
endif()
