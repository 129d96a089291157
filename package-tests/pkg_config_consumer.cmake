# cmake -DSOURCE=... -DPREFIX=... -DLIBDIR=... -DFIRMWARE=... -DBINARY=... -P pkg_config_consumer.cmake:
# builds package-tests/pkg-config-consumer with make against PREFIX's .pc files (the compiler and sanitizer
# flags of this build, CXX_FLAGS/LINKER_FLAGS, as the installed libraries carry them) and runs it.
find_program(make make)
find_program(pkg_config pkg-config)
if(NOT make OR NOT pkg_config)
  message(FATAL_ERROR "make and pkg-config are needed (tools/setup installs them)")
endif()
file(REMOVE_RECURSE ${BINARY})
file(MAKE_DIRECTORY ${BINARY})
# Only the prefix's .pc files and the system's (simavr, libelf, protobuf, nlohmann_json).
set(ENV{PKG_CONFIG_PATH} ${PREFIX}/${LIBDIR}/pkgconfig)
execute_process(COMMAND ${make} -f ${SOURCE}/Makefile SOURCE_DIR=${SOURCE} CXX=${CXX} "CXXFLAGS=${CXX_FLAGS}"
  "LDFLAGS=${LINKER_FLAGS}" WORKING_DIRECTORY ${BINARY} RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE out)
message(STATUS "make: exit ${result}\n${out}")
if(NOT result EQUAL 0)
  message(FATAL_ERROR "the pkg-config consumer did not build")
endif()
execute_process(COMMAND ${BINARY}/pkg-config-consumer ${FIRMWARE} RESULT_VARIABLE result
  OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
message(STATUS "pkg-config-consumer: exit ${result}\n${out}${err}")
if(NOT result EQUAL 0 OR NOT out MATCHES "romi: e -> \\[0,1,2\\]" OR NOT out MATCHES "proxy: servo 9 to 120, acked"
   OR NOT out MATCHES "elcano: D\\{s50\\}\\{a25\\}[0-9]+ read back as drive speed 50 angle 25")
  message(FATAL_ERROR "the pkg-config consumer did not talk to every codec")
endif()
