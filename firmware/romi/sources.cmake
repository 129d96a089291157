# Sources of the Romi device library, shared by the AVR sub-build (CMakeLists.txt here) and the host
# tests (host-tests/). The platform clocks (src/clock_*.cpp) are listed apart: each build picks its own.
set(TETHER_ROMI_DEVICE_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/src/romi_serial.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/array_text.cpp)
set(TETHER_ROMI_DEVICE_RUNTIME_CLOCK_SOURCE ${CMAKE_CURRENT_LIST_DIR}/src/clock_tether_runtime.cpp)
# The Arduino core's millis() (the TetherRomi Arduino library, firmware/arduino).
set(TETHER_ROMI_DEVICE_ARDUINO_CLOCK_SOURCE ${CMAKE_CURRENT_LIST_DIR}/src/clock_arduino.cpp)
set(TETHER_ROMI_DEVICE_INCLUDE_DIR ${CMAKE_CURRENT_LIST_DIR}/include)
