# The Arduino libraries' glue under the project's AVR warnings (-Wall -Wextra -Werror -Wconversion
# -Wsign-conversion; the IDE compiles sketches with its own, milder ones): each generated library's glue
# sources and a file instantiating its headers' paths (avr-glue/<Library>.cpp), compiled with avr-g++
# against the Arduino core's headers for the Uno (run with cmake -P by the arduino.glue.avr_warnings test):
# Every library's with TetherCore's src/ beside its own on the include path, as the Arduino builder has them.
#   AVR_GXX, LIBRARIES (build/arduino), CORE (arduino-core-avr's hardware/arduino/avr), SOURCE_DIR (tests/)
cmake_minimum_required(VERSION 3.25)
foreach(var AVR_GXX LIBRARIES CORE SOURCE_DIR)
  if(NOT ${var})
    message(FATAL_ERROR "${var} not set")
  endif()
endforeach()
set(flags -std=gnu++11 -mmcu=atmega328p -DF_CPU=16000000L -DARDUINO=10807 -DARDUINO_AVR_UNO -DARDUINO_ARCH_AVR
    -Os -fsyntax-only -Wall -Wextra -Werror -Wconversion -Wsign-conversion
    # -I, not -isystem: avr-gcc wraps system headers in extern "C", which the core's C++ headers break
    -I${CORE}/cores/arduino -I${CORE}/variants/standard)
set(TetherCore_sources TetherArduinoPorts.cpp)
set(TetherRomi_sources)
set(TetherProxy_sources tether_arduino_proxy.cpp)
set(TetherElcano_sources elcano_serial.cpp)
set(failed "")
foreach(library TetherCore TetherRomi TetherProxy TetherElcano)
  set(files)
  if(EXISTS ${SOURCE_DIR}/avr-glue/${library}.cpp)
    list(APPEND files ${SOURCE_DIR}/avr-glue/${library}.cpp)
  endif()
  foreach(source IN LISTS ${library}_sources)
    list(APPEND files ${LIBRARIES}/${library}/src/${source})
  endforeach()
  foreach(file IN LISTS files)
    execute_process(COMMAND ${AVR_GXX} ${flags} -I${LIBRARIES}/${library}/src -I${LIBRARIES}/TetherCore/src ${file}
                    RESULT_VARIABLE result)
    if(result)
      list(APPEND failed ${file})
    endif()
  endforeach()
endforeach()
if(failed)
  message(FATAL_ERROR "warnings or errors in: ${failed}")
endif()
