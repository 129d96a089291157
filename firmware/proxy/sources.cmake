# Sources of the proxy device library, shared by the AVR sub-build (CMakeLists.txt here) and the host
# tests (host-tests/). The AVR back ends (registers, EEPROM/SRAM/ADC entropy) are listed apart: the host
# tests link a fake of the pin drivers instead and never derive a boot id from the MCU.
set(TETHER_PROXY_DEVICE_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/src/outputs.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/text.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/session_id.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/io.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/proxy_device.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/compat_device.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/flash_descriptors.cpp)
set(TETHER_PROXY_DEVICE_AVR_SOURCES
  ${CMAKE_CURRENT_LIST_DIR}/src/hardware_avr.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/hardware_compat_avr.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/session_id_avr.cpp)
set(TETHER_PROXY_DEVICE_INCLUDE_DIR ${CMAKE_CURRENT_LIST_DIR}/include)
