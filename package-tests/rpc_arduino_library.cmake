# cmake -DSOURCE=... -DPREFIX=... -DBINARY=... -DARDUINO_BUILDER=... -DCORE_CACHE=... -P rpc_arduino_library.cmake:
# the installed `tether generate` (PREFIX/bin/tether: its kit found relative to itself, share/tether/rpc-arduino,
# with no variable pointing at the build tree) writes the ArmRpc library of the example's schema, the installed
# TetherCore.zip (which the generated library uses) is unzipped beside it, and the example sketch builds
# against that folder with arduino-builder as docs/arduino.md tells users.
include(${CMAKE_CURRENT_LIST_DIR}/run-checked.cmake)

file(REMOVE_RECURSE ${BINARY})
set(libraries ${BINARY}/libraries)
run_checked(${CMAKE_COMMAND} -E env --unset=TETHER_RPC_ARDUINO_DIR
  ${PREFIX}/bin/tether generate ${SOURCE}/examples/rpc/arm.proto --out ${libraries})
foreach(file library.properties src/ArmRpc.h src/ArmRpc_service.cpp src/arm.pb.c src/TetherRpcArduino.h src/pb.h)
  if(NOT EXISTS ${libraries}/ArmRpc/${file})
    message(FATAL_ERROR "the installed tether generate wrote no ${file} in ${libraries}/ArmRpc")
  endif()
endforeach()
# As a user installs it: the zip unzipped into the sketchbook's libraries folder.
set(core_zip ${PREFIX}/share/tether/arduino/TetherCore.zip)
if(NOT EXISTS ${core_zip})
  message(FATAL_ERROR "no ${core_zip}: the generated library needs the installed TetherCore")
endif()
run_checked(${CMAKE_COMMAND} -E chdir ${libraries} ${CMAKE_COMMAND} -E tar xf ${core_zip})
if(NOT EXISTS ${libraries}/TetherCore/src/TetherCore.h)
  message(FATAL_ERROR "TetherCore.zip did not unzip to TetherCore/src/TetherCore.h")
endif()
if(NOT ARDUINO_BUILDER)
  message(STATUS "package test skipped: no arduino-builder; the library was written")
  return()
endif()
file(MAKE_DIRECTORY ${BINARY}/sketch ${CORE_CACHE})
run_checked(${ARDUINO_BUILDER} -compile -hardware /usr/share/arduino-builder -hardware /usr/share/arduino/hardware
  -tools /usr/bin -fqbn arduino:avr:uno -libraries ${libraries} -build-path ${BINARY}/sketch -build-cache ${CORE_CACHE}
  -prefs=compiler.cpp.extra_flags=-DDECIMAL_DIG=9 ${SOURCE}/examples/rpc/ArmSketch/ArmSketch.ino)
if(NOT EXISTS ${BINARY}/sketch/ArmSketch.ino.elf)
  message(FATAL_ERROR "arduino-builder made no ArmSketch.ino.elf")
endif()
