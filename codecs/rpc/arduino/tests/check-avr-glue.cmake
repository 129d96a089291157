# The Arduino glue of a library `tether generate` wrote under the project's AVR warnings (-Wall -Wextra -Werror
# -Wconversion -Wsign-conversion; the IDE compiles with milder ones), as firmware/arduino/tests/check-avr-glue.cmake
# does for the other libraries: the glue's source, the generated service code and a file instantiating the
# library's header (avr_glue.cpp), compiled by avr-g++ against the Arduino core's headers for the Uno (run
# with cmake -P by rpc.arduino.glue_avr_warnings):
#   AVR_GXX, LIBRARY (the generated library's folder), CORE_LIBRARY (TetherCore's folder, which it includes), CORE (arduino-core-avr's hardware/arduino/avr), GLUE_TEST
cmake_minimum_required(VERSION 3.25)
foreach(var AVR_GXX LIBRARY CORE_LIBRARY CORE GLUE_TEST)
  if(NOT ${var})
    message(FATAL_ERROR "${var} not set")
  endif()
endforeach()
get_filename_component(name ${LIBRARY} NAME)
set(flags -std=gnu++11 -mmcu=atmega328p -DF_CPU=16000000L -DARDUINO=10807 -DARDUINO_AVR_UNO -DARDUINO_ARCH_AVR
    -Os -fsyntax-only -Wall -Wextra -Werror -Wconversion -Wsign-conversion
    -I${CORE}/cores/arduino -I${CORE}/variants/standard -I${LIBRARY}/src -I${CORE_LIBRARY}/src)
set(failed "")
foreach(file ${GLUE_TEST} ${LIBRARY}/src/tether_rpc_arduino.cpp ${LIBRARY}/src/${name}_service.cpp)
  execute_process(COMMAND ${AVR_GXX} ${flags} ${file} RESULT_VARIABLE result)
  if(result)
    list(APPEND failed ${file})
  endif()
endforeach()
if(failed)
  message(FATAL_ERROR "warnings or errors in: ${failed}")
endif()
