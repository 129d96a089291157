# Sources of the rpc device runtime, shared by the AVR sub-build and the host tests. It is built on the proxy's
# frame codec and device I/O (TETHER_PROXY_PORTABLE_SOURCES; io.cpp and text.cpp of the proxy device library).
set(TETHER_RPC_DEVICE_SOURCES ${CMAKE_CURRENT_LIST_DIR}/src/rpc_device.cpp ${CMAKE_CURRENT_LIST_DIR}/src/message_codec.cpp
  ${CMAKE_CURRENT_LIST_DIR}/src/envelope.cpp)
set(TETHER_RPC_DEVICE_INCLUDE_DIRS ${CMAKE_CURRENT_LIST_DIR}/include ${CMAKE_CURRENT_LIST_DIR}/../include)
set(TETHER_RPC_PROTO_DIR ${CMAKE_CURRENT_LIST_DIR}/../proto)
