# Tether as an installable package: `cmake --install build --prefix P` puts the host libraries, their
# headers, the `tether` command, the AVR images, docs and examples under P; consumers use
# `find_package(Tether CONFIG REQUIRED COMPONENTS ...)` (cmake/TetherConfig.cmake.in) or pkg-config.
include_guard(GLOBAL)
include(GNUInstallDirs)
include(CMakePackageConfigHelpers)

set(TETHER_INSTALL_CMAKEDIR ${CMAKE_INSTALL_LIBDIR}/cmake/Tether)
set(TETHER_INSTALL_FIRMWAREDIR ${CMAKE_INSTALL_DATADIR}/tether/firmware)
set(TETHER_INSTALL_ARDUINODIR ${CMAKE_INSTALL_DATADIR}/tether/arduino)  # the Arduino libraries (.zip)
set(TETHER_INSTALL_EXAMPLESDIR ${CMAKE_INSTALL_DATADIR}/tether/examples)
# Install rules without a COMPONENT (libraries, headers, CMake and pkg-config files) go to the Debian
# package libtether-dev (cmake/debian-package.cmake); the command and its data say COMPONENT tether.
set(CMAKE_INSTALL_DEFAULT_COMPONENT_NAME dev)
# Folders 0755 whatever the umask (Debian packages; lintian checks).
set(CMAKE_INSTALL_DEFAULT_DIRECTORY_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE
  WORLD_READ WORLD_EXECUTE)

# tether_library(TARGET NAME <exported name> [HEADERS <dir>]): makes TARGET a public library of the package:
# exported as Tether::<name> (also the in-tree alias, so add_subdirectory users write the same names), C++20
# as a usage requirement, HEADERS (its one include root) on the include path in the build tree and
# installed under include/.
function(tether_library target)
  cmake_parse_arguments(LIB "" "NAME;HEADERS" "" ${ARGN})
  set_target_properties(${target} PROPERTIES EXPORT_NAME ${LIB_NAME})
  get_target_property(_type ${target} TYPE)
  set(_scope PUBLIC)
  if(_type STREQUAL "INTERFACE_LIBRARY")
    set(_scope INTERFACE)
  endif()
  target_compile_features(${target} ${_scope} cxx_std_20)
  if(LIB_HEADERS)
    cmake_path(ABSOLUTE_PATH LIB_HEADERS BASE_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR} NORMALIZE)
    target_include_directories(${target} ${_scope} $<BUILD_INTERFACE:${LIB_HEADERS}>
      $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>)
    install(DIRECTORY ${LIB_HEADERS}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  endif()
  install(TARGETS ${target} EXPORT TetherTargets
    ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR}
    LIBRARY DESTINATION ${CMAKE_INSTALL_LIBDIR}
    RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR})
  add_library(Tether::${LIB_NAME} ALIAS ${target})
endfunction()

# tether_pkg_config(NAME DESCRIPTION text LIBS -l... [CFLAGS ...] [REQUIRES ...]): lib/pkgconfig/NAME.pc for
# non-CMake users, relocatable (paths relative to the .pc file, so an unpacked prefix works too).
function(tether_pkg_config name)
  cmake_parse_arguments(PC "" "DESCRIPTION" "LIBS;CFLAGS;REQUIRES" ${ARGN})
  file(RELATIVE_PATH _up /root/${CMAKE_INSTALL_LIBDIR}/pkgconfig /root)
  list(JOIN PC_LIBS " " _libs)
  list(JOIN PC_CFLAGS " " _cflags)
  list(JOIN PC_REQUIRES ", " _requires)
  set(_pc ${PROJECT_BINARY_DIR}/pkgconfig/${name}.pc)
  file(CONFIGURE OUTPUT ${_pc} @ONLY CONTENT [[
prefix=${pcfiledir}/@_up@
includedir=${prefix}/@CMAKE_INSTALL_INCLUDEDIR@
libdir=${prefix}/@CMAKE_INSTALL_LIBDIR@

Name: @name@
Description: @PC_DESCRIPTION@
Version: @PROJECT_VERSION@
Requires: @_requires@
Cflags: -std=c++20 -I${includedir} @_cflags@
Libs: -L${libdir} @_libs@
]])
  install(FILES ${_pc} DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig)
endfunction()

# tether_package_dependency(component package [args...]): find_package(Tether COMPONENTS ...) looks for
# `package args` (find_dependency) when the package holds `component`; for the component's own folder.
function(tether_package_dependency component)
  list(JOIN ARGN " " _arguments)
  set_property(GLOBAL APPEND_STRING PROPERTY TETHER_PACKAGE_DEPENDENCIES
    "if(\"${component}\" IN_LIST _tether_built_components)\n  find_dependency(${_arguments})\nendif()\n")
endfunction()

# tether_package_module(component file): a CMake module of the component's folder (functions for the
# package's users, such as a codec's code generators) installed beside TetherConfig.cmake and included by
# find_package(Tether) when the package holds the component and the caller asked for it (or for nothing).
function(tether_package_module component file)
  cmake_path(GET file FILENAME _name)
  install(FILES ${file} DESTINATION ${TETHER_INSTALL_CMAKEDIR})
  set_property(GLOBAL APPEND_STRING PROPERTY TETHER_PACKAGE_MODULES
    "if(\"${component}\" IN_LIST _tether_built_components AND (NOT _tether_components OR \"${component}\" IN_LIST _tether_components))\n  include(\${CMAKE_CURRENT_LIST_DIR}/${_name})\nendif()\n")
endfunction()

# The export set, TetherConfig.cmake and TetherConfigVersion.cmake. Called once every library is defined.
function(tether_install_package)
  install(EXPORT TetherTargets NAMESPACE Tether:: DESTINATION ${TETHER_INSTALL_CMAKEDIR})
  get_property(TETHER_PACKAGE_DEPENDENCIES GLOBAL PROPERTY TETHER_PACKAGE_DEPENDENCIES)
  get_property(TETHER_PACKAGE_MODULES GLOBAL PROPERTY TETHER_PACKAGE_MODULES)
  configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/TetherConfig.cmake.in
    ${PROJECT_BINARY_DIR}/TetherConfig.cmake INSTALL_DESTINATION ${TETHER_INSTALL_CMAKEDIR}
    PATH_VARS TETHER_INSTALL_FIRMWAREDIR)
  # 0.x: minor versions may break the API, so a consumer asking for 0.1 accepts 0.1.* only.
  write_basic_package_version_file(${PROJECT_BINARY_DIR}/TetherConfigVersion.cmake
    COMPATIBILITY SameMinorVersion)
  install(FILES ${PROJECT_BINARY_DIR}/TetherConfig.cmake ${PROJECT_BINARY_DIR}/TetherConfigVersion.cmake
    DESTINATION ${TETHER_INSTALL_CMAKEDIR})
endfunction()
