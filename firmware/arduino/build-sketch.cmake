# Builds one example sketch of a generated Arduino library with Debian's arduino-builder, as the Arduino IDE
# does, for the Uno (run with cmake -P by the arduino.build.* tests):
#   ARDUINO_BUILDER, SKETCH (.ino), LIBRARIES (build/arduino: the generated libraries), OTHER_LIBRARIES
#   (optional: a second libraries folder, the installed Tether libraries beside a generated one), BUILD_PATH (kept
#   between runs: incremental), CORE_CACHE (core.a shared by every sketch: the core is compiled once),
#   OUTPUT (<dir>/<Library>.<Example>: .elf and .hex are copied there, beside the bare-metal images' report)
#
# The hardware folders: arduino-builder's own platform.txt (its ctags recipe; the IDE package would bring
# another) and arduino-core-avr's. Debian's arduino-core-avr 1.8.7 compiles WString.cpp only with DECIMAL_DIG defined (its avr-libc lacks
# it): -DDECIMAL_DIG=9 (a float's round-trip digits) goes in as compiler.cpp.extra_flags, the build
# property meant for such additions, so nothing of the system is patched.
cmake_minimum_required(VERSION 3.25)
foreach(var ARDUINO_BUILDER SKETCH LIBRARIES BUILD_PATH CORE_CACHE OUTPUT)
  if(NOT ${var})
    message(FATAL_ERROR "${var} not set")
  endif()
endforeach()
if(NOT EXISTS ${SKETCH})
  message(FATAL_ERROR "no sketch ${SKETCH}: build the arduino-libraries target first")
endif()
file(MAKE_DIRECTORY ${BUILD_PATH} ${CORE_CACHE})
set(library_folders -libraries ${LIBRARIES})
if(OTHER_LIBRARIES)
  list(APPEND library_folders -libraries ${OTHER_LIBRARIES})
endif()
execute_process(
  COMMAND ${ARDUINO_BUILDER} -compile -hardware /usr/share/arduino-builder -hardware /usr/share/arduino/hardware
          -tools /usr/bin -fqbn arduino:avr:uno
          ${library_folders} -build-path ${BUILD_PATH} -build-cache ${CORE_CACHE}
          -prefs=compiler.cpp.extra_flags=-DDECIMAL_DIG=9 -warnings default ${SKETCH}
  RESULT_VARIABLE failed)
if(failed)
  message(FATAL_ERROR "arduino-builder failed on ${SKETCH}")
endif()
get_filename_component(name ${SKETCH} NAME)
foreach(ext elf hex)
  file(COPY_FILE ${BUILD_PATH}/${name}.${ext} ${OUTPUT}.${ext})
endforeach()
