# cmake -DPREFIX=... -DVERSION=... -DLIBDIR=... -DLIBEXECDIR=... -DSCRATCH=... -P installed_layout.cmake
set(expected
  bin/tether
  ${LIBDIR}/cmake/Tether/TetherConfig.cmake
  ${LIBDIR}/cmake/Tether/TetherConfigVersion.cmake
  ${LIBDIR}/cmake/Tether/TetherTargets.cmake
  ${LIBDIR}/cmake/Tether/TetherGenerateRpc.cmake
  ${LIBEXECDIR}/tether/tether-rpc-cpp
  ${LIBDIR}/libtether_core.a
  ${LIBDIR}/libtether_romi_client.a
  ${LIBDIR}/libtether_proxy_client.a
  ${LIBDIR}/libtether_elcano_client.a
  ${LIBDIR}/libtether_devices.a
  ${LIBDIR}/libtether_transports.a
  ${LIBDIR}/libtether_client.a
  ${LIBDIR}/libtether_virtual_uno.a
  ${LIBDIR}/pkgconfig/tether-client.pc
  ${LIBDIR}/pkgconfig/tether-romi.pc
  ${LIBDIR}/pkgconfig/tether-proxy.pc
  ${LIBDIR}/pkgconfig/tether-elcano.pc
  ${LIBDIR}/pkgconfig/tether-devices.pc
  ${LIBDIR}/pkgconfig/tether-virtual-uno.pc
  include/tether/core/status.hpp
  include/tether/romi/client.hpp
  include/tether/romi/encoder.hpp
  include/tether/proxy/client.hpp
  include/tether/proxy_messages/tether_proxy.pb.h
  include/tether/elcano/client.hpp
  include/tether/devices/rover.hpp
  include/tether/transports/serial_port_stream.hpp
  include/tether/client/client_link.hpp
  include/tether/client/link_clock.hpp
  include/tether/transports/virtual_uno.hpp
  share/tether/firmware/romi-test.elf
  share/tether/firmware/proxy.elf
  share/tether/firmware/elcano-node.elf
  share/tether/firmware/rpc-example.elf
  share/tether/firmware/rpc-example.proto
  share/tether/rpc-arduino/src/TetherRpcArduino.h
  ${LIBDIR}/wireshark/plugins/tether.lua
  share/tether/proto/tether_proxy.proto
  share/tether/proto/rocketry.proto
  share/tether/proto/tether_rpc.proto
  share/tether/examples/rover-virtual.json
  share/man/man1/tether.1.gz
  share/doc/tether/README.md
  share/doc/tether/config.md)
foreach(file IN LISTS expected)
  if(NOT EXISTS ${PREFIX}/${file})
    message(SEND_ERROR "not installed: ${PREFIX}/${file}")
  endif()
endforeach()
# The Python package, when this build has it, with its stubs: the package's (made by the build) and each
# codec's (from its plugin's folder).
file(GLOB python_package LIST_DIRECTORIES true ${PREFIX}/lib/python3*/*-packages/tether)
if(python_package)
  foreach(file __init__.py __init__.pyi romi.pyi proxy.pyi elcano.pyi rpc.pyi transports.pyi compat.py compat.pyi py.typed)
    if(NOT EXISTS ${python_package}/${file})
      message(SEND_ERROR "not installed: ${python_package}/${file}")
    endif()
  endforeach()
endif()

execute_process(COMMAND ${PREFIX}/bin/tether --version OUTPUT_VARIABLE out RESULT_VARIABLE result)
if(NOT result EQUAL 0 OR NOT out MATCHES "${VERSION}")
  message(SEND_ERROR "tether --version: exit ${result}, '${out}' (expected ${VERSION})")
endif()

# A prefix copied elsewhere (an unpacked package) still finds its own images, not the build's.
file(REMOVE_RECURSE ${SCRATCH})
file(COPY ${PREFIX}/bin ${PREFIX}/share DESTINATION ${SCRATCH})
set(ENV{TETHER_FIRMWARE_DIR} "")
execute_process(COMMAND ${SCRATCH}/bin/tether call --virtual no-such-image e
  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE result)
if(NOT err MATCHES "${SCRATCH}/share/tether/firmware/no-such-image.elf")
  message(SEND_ERROR "a moved prefix's tether looked elsewhere for its images: exit ${result}, '${err}'")
endif()
execute_process(COMMAND ${SCRATCH}/bin/tether call --virtual romi-test e
  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE result TIMEOUT 60)
if(NOT result EQUAL 0 OR NOT out MATCHES "\\[0,1,2\\]")
  message(SEND_ERROR "moved prefix: tether call --virtual romi-test e: exit ${result}, '${out}' '${err}'")
endif()
file(REMOVE_RECURSE ${SCRATCH})
