# Portable sources of the Elcano codec, shared by the host build and the AVR sub-build.
set(TETHER_ELCANO_PORTABLE_SOURCES ${CMAKE_CURRENT_LIST_DIR}/src/message.cpp ${CMAKE_CURRENT_LIST_DIR}/src/ring_node.cpp)
set(TETHER_ELCANO_INCLUDE_DIR ${CMAKE_CURRENT_LIST_DIR}/include)
