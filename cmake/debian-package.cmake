# Debian packages of Tether: `cpack -G DEB` in a build directory (configured with
# -DCMAKE_INSTALL_PREFIX=/usr, the multiarch library folder follows) writes three packages:
#   tether           the `tether` command, its man page, docs and example configurations
#   tether-firmware  the AVR images (.elf + .hex) for the ATmega328P: Architecture all, as Debian ships AVR
#                    code (avr-libc, arduino-core-avr): lintian accepts another architecture's ELF only in
#                    an arch-independent package, and the images are the same whatever the host's
#   libtether-dev    the static libraries, headers, CMake package and pkg-config files, the consumer example
#   python3-tether   the Python package `tether` (the pybind11 module and its .py/.pyi files) for Debian's
#                    python3 in /usr/lib/python3/dist-packages, when the build made the module
# The libraries are static only (0.x: the API still changes between minor versions, so no shared library
# with a stable SONAME yet); Debian ships static libraries and headers in a -dev package, and a runtime
# library package would be empty: `tether` links them in.
#
# Install rules choose their package with COMPONENT: `tether`, `firmware`, `python` or `dev` (the default,
# for headers and libraries). Tests check that every installed file is in one of the packages (package-tests/deb.cmake).
include_guard(GLOBAL)

# The man page of `tether`, generated from its own help at build time (cmake/man-page.cmake).
function(tether_man_page)
  if(CMAKE_CROSSCOMPILING)
    return()  # the help comes from running the binary
  endif()
  find_program(TETHER_HELP2MAN help2man)
  find_program(TETHER_GZIP gzip)
  if(NOT TETHER_HELP2MAN OR NOT TETHER_GZIP)
    message(WARNING "help2man or gzip not found (tools/setup installs them): no man page for `tether`")
    return()
  endif()
  set(_page ${PROJECT_BINARY_DIR}/man/tether.1.gz)
  add_custom_command(OUTPUT ${_page}
    COMMAND ${CMAKE_COMMAND} -DTETHER=$<TARGET_FILE:tether> -DHELP2MAN=${TETHER_HELP2MAN} -DGZIP=${TETHER_GZIP}
            -DFIRMWARE_DIR=${CMAKE_INSTALL_PREFIX}/${TETHER_INSTALL_FIRMWAREDIR} -DDOC_DIR=${CMAKE_INSTALL_FULL_DOCDIR}
            -DOUTPUT=${_page} -P ${PROJECT_SOURCE_DIR}/cmake/man-page.cmake
    DEPENDS tether ${PROJECT_SOURCE_DIR}/cmake/man-page.cmake
    COMMENT "man page of tether (help2man)")
  add_custom_target(tether-man-page ALL DEPENDS ${_page})
  install(FILES ${_page} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1 COMPONENT tether)
endfunction()

# Copyright and changelog: Debian wants them in every package's doc folder.
function(tether_debian_docs)
  configure_file(${PROJECT_SOURCE_DIR}/cmake/debian/changelog.in ${PROJECT_BINARY_DIR}/debian/changelog @ONLY)
  find_program(TETHER_GZIP gzip)
  set(_changelog ${PROJECT_BINARY_DIR}/debian/changelog.gz)
  add_custom_command(OUTPUT ${_changelog}
    COMMAND ${TETHER_GZIP} -9nc ${PROJECT_BINARY_DIR}/debian/changelog > ${_changelog}
    DEPENDS ${PROJECT_BINARY_DIR}/debian/changelog)
  add_custom_target(tether-debian-changelog ALL DEPENDS ${_changelog})
  set(_component_packages tether:tether firmware:tether-firmware dev:libtether-dev)
  if(TARGET _tether)
    list(APPEND _component_packages python:python3-tether)
  endif()
  foreach(_component_package IN LISTS _component_packages)
    string(REPLACE ":" ";" _component_package ${_component_package})
    list(GET _component_package 0 _component)
    list(GET _component_package 1 _package)
    install(FILES ${PROJECT_SOURCE_DIR}/cmake/debian/copyright ${_changelog}
      DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/doc/${_package} COMPONENT ${_component})
  endforeach()
  # AVR code in /usr/share of an Architecture: all package: what lintian asks to override, with the reason.
  install(FILES ${PROJECT_SOURCE_DIR}/cmake/debian/tether-firmware.lintian-overrides
    DESTINATION ${CMAKE_INSTALL_DATAROOTDIR}/lintian/overrides RENAME tether-firmware COMPONENT firmware)
endfunction()

function(tether_debian_package)
  tether_man_page()
  tether_debian_docs()

  set(CPACK_GENERATOR DEB)
  set(CPACK_PACKAGE_NAME tether)
  set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})  # native package: the packaging lives in Tether's tree
  set(CPACK_PACKAGE_VENDOR "Tether developers")
  set(CPACK_PACKAGE_CONTACT "Tether developers <dev@tether.invalid>")
  set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${CPACK_PACKAGE_CONTACT}")
  set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
  set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)  # tether_0.2.0_amd64.deb
  set(CPACK_DEBIAN_COMPRESSION_TYPE xz)
  set(CPACK_STRIP_FILES ON)
  set(CPACK_PACKAGE_DIRECTORY ${PROJECT_BINARY_DIR}/packages)
  set(CPACK_DEB_COMPONENT_INSTALL ON)
  set(CPACK_COMPONENTS_ALL tether firmware dev)
  if(TARGET _tether)  # python/CMakeLists.txt made the module (pybind11-dev and python3-dev were found)
    list(APPEND CPACK_COMPONENTS_ALL python)
  endif()

  set(CPACK_DEBIAN_TETHER_PACKAGE_NAME tether)
  set(CPACK_DEBIAN_TETHER_PACKAGE_SECTION electronics)
  set(CPACK_DEBIAN_TETHER_PACKAGE_SHLIBDEPS ON)  # dpkg-shlibdeps: libprotobuf, libsimavr, libelf, libedit
  set(CPACK_DEBIAN_TETHER_PACKAGE_DEPENDS "tether-firmware (= ${PROJECT_VERSION})")  # demo, --virtual, sim
  set(CPACK_DEBIAN_TETHER_PACKAGE_RECOMMENDS "avrdude, python3-matplotlib, nanopb")  # tether flash; tether bench's plots; tether generate
  set(CPACK_DEBIAN_TETHER_PACKAGE_SUGGESTS "libtether-dev, wireshark | tshark")  # captures read by tether.lua
  set(CPACK_DEBIAN_TETHER_DESCRIPTION "messages between a robot's computer and its AVR boards
Tether carries messages between a robot's host computer and its AVR
Arduinos over serial links, in three protocols: the Romi text protocol,
COBS + CRC-16 protobuf (proxy) and the Elcano ring.
.
This package has the tether command (call, send, shell, monitor, stats,
demo on a virtual rover of simulated Unos, sim, flash through optiboot
with avrdude).")

  set(CPACK_DEBIAN_FIRMWARE_PACKAGE_NAME tether-firmware)
  set(CPACK_DEBIAN_FIRMWARE_PACKAGE_ARCHITECTURE all)
  set(CPACK_DEBIAN_FIRMWARE_PACKAGE_SECTION electronics)
  set(CPACK_DEBIAN_FIRMWARE_DESCRIPTION "AVR images of Tether for the ATmega328P (Arduino Uno)
Tether carries messages between a robot's host computer and its AVR
Arduinos over serial links, in three protocols: the Romi text protocol,
COBS + CRC-16 protobuf (proxy) and the Elcano ring.
.
This package has the firmware images (.elf and .hex) of each protocol's
device side, test and benchmark images and an optiboot bootloader, for
tether flash, tether sim and the virtual boards of a rover configuration.")

  set(CPACK_DEBIAN_DEV_PACKAGE_NAME libtether-dev)
  set(CPACK_DEBIAN_DEV_PACKAGE_SECTION libdevel)
  # What the installed CMake package and .pc files ask for (cmake/TetherConfig.cmake.in); the simulator's
  # libraries only for Tether::virtual_uno, the images only for virtual boards.
  # tether_generate_rpc runs protoc and the rpc codec's generator (libexec/tether/tether-rpc-cpp, whose
  # libraries dpkg-shlibdeps finds); nanopb.proto for schemas with nanopb's options.
  set(CPACK_DEBIAN_DEV_PACKAGE_DEPENDS
    "libboost-dev (>= 1.74), libprotobuf-dev, libprotoc-dev, protobuf-compiler, nlohmann-json3-dev, pkg-config")
  set(CPACK_DEBIAN_DEV_PACKAGE_SHLIBDEPS ON)
  set(CPACK_DEBIAN_DEV_PACKAGE_RECOMMENDS
    "libsimavr-dev, libelf-dev, tether-firmware (= ${PROJECT_VERSION}), nanopb")
  set(CPACK_DEBIAN_DEV_DESCRIPTION "static libraries and headers of Tether (robot host to AVR messaging)
Tether carries messages between a robot's host computer and its AVR
Arduinos over serial links, in three protocols: the Romi text protocol,
COBS + CRC-16 protobuf (proxy) and the Elcano ring.
.
This package has the C++20 client libraries (static), their headers, the
CMake package (find_package(Tether)) and pkg-config files, and an example
rover service. Virtual boards (Tether::virtual_uno) need libsimavr-dev,
libelf-dev and the images of tether-firmware.")

  if(TARGET _tether)  # the module was built: package it
    set(CPACK_DEBIAN_PYTHON_PACKAGE_NAME python3-tether)
    set(CPACK_DEBIAN_PYTHON_PACKAGE_SECTION python)
    set(CPACK_DEBIAN_PYTHON_PACKAGE_SHLIBDEPS ON)  # dpkg-shlibdeps: libprotobuf, libsimavr, libelf, libstdc++
    # An extension module loads in the one Python version it was built for (what dh-python's
    # ${python3:Depends} says for a module of Debian's default python3).
    string(REGEX MATCH "^([0-9]+)\\.([0-9]+)$" _python_version "${TETHER_PYTHON_VERSION}")
    math(EXPR _next_minor "${CMAKE_MATCH_2} + 1")
    # ... and the Python modules the codecs' parts import (tether_codec_plugin's PYTHON_REQUIRES).
    get_property(_python_requires GLOBAL PROPERTY TETHER_PYTHON_DEBIAN_DEPENDS)
    list(REMOVE_DUPLICATES _python_requires)
    list(PREPEND _python_requires "python3 (>= ${TETHER_PYTHON_VERSION}~)" "python3 (<< ${CMAKE_MATCH_1}.${_next_minor})")
    list(JOIN _python_requires ", " CPACK_DEBIAN_PYTHON_PACKAGE_DEPENDS)
    # Virtual boards (tether.VirtualUno, virtual devices of a rover file) run the images; real boards do not.
    set(CPACK_DEBIAN_PYTHON_PACKAGE_RECOMMENDS "tether-firmware (= ${PROJECT_VERSION})")
    set(CPACK_DEBIAN_PYTHON_DESCRIPTION "Python package of Tether (robot host to AVR messaging)
Tether carries messages between a robot's host computer and its AVR
Arduinos over serial links, in three protocols: the Romi text protocol,
COBS + CRC-16 protobuf (proxy) and the Elcano ring.
.
This package has the Python 3 module tether: the library's clients of
each protocol (blocking and asyncio), rover configurations, transports,
virtual boards (with tether-firmware) and tether.compat, RomiSerial's
ControlSerial on Tether.")
  endif()

  include(CPack)
endfunction()
