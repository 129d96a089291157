# tether_codec_plugin(NAME HEADER header SOURCES... [INCLUDE dir] [LIBRARIES...] [COMMANDS sources...]
#                     [WORKLOADS sources...]): a codec's plugin, declared in its own folder
# (codecs/<codec>/plugin/CMakeLists.txt). This call is the codec's whole registration:
#  - SOURCES define the plugin's parts, their public declarations in HEADER (relative to INCLUDE, default
#    `include`): `std::vector<tether::devices::CodecRow> tether::<NAME>::codec_rows()`, the codec's rows of
#    the devices table (devices/codecs.hpp: configuration name, options, how a device opens);
#  - the sources are compiled against the devices API (`tether_devices_api`) and LIBRARIES, and become part of
#    `Tether::devices`, whose table lists every plugin registered this way (devices/CMakeLists.txt generates
#    the list); INCLUDE is installed with the other headers and public to `Tether::devices` users;
#  - COMMANDS define `std::vector<tether::cli::CodecCommands> tether::<NAME>::command_rows()`, the codec's rows
#    of the `tether` command (tools/tether/codec_commands.hpp: shell, monitor, stats, command-line defaults),
#    compiled against the command's own headers (`tether_cli_api`) into it;
#  - WORKLOADS define `std::vector<tether::demo::CodecWorkloads> tether::<NAME>::workload_rows()`, how its devices
#    do the operations `tether demo` and `tether bench` measure (tools/demo/include/tether/demo/workload.hpp),
#    compiled into the demo's library (`tether_workloads_api`).
# docs/codecs.md, "Adding a codec".
include_guard(GLOBAL)

function(tether_codec_plugin name)
  cmake_parse_arguments(PLUGIN "" "HEADER;INCLUDE" "SOURCES;LIBRARIES;COMMANDS;WORKLOADS" ${ARGN})
  if(NOT PLUGIN_HEADER OR NOT PLUGIN_SOURCES)
    message(FATAL_ERROR "tether_codec_plugin(${name}): HEADER and SOURCES are required")
  endif()
  if(NOT PLUGIN_INCLUDE)
    set(PLUGIN_INCLUDE include)
  endif()
  cmake_path(ABSOLUTE_PATH PLUGIN_INCLUDE BASE_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR} NORMALIZE)
  set(target tether_${name}_plugin)
  add_library(${target} OBJECT ${PLUGIN_SOURCES})
  target_include_directories(${target} PUBLIC $<BUILD_INTERFACE:${PLUGIN_INCLUDE}>)
  target_link_libraries(${target} PUBLIC tether_devices_api ${PLUGIN_LIBRARIES})
  target_compile_features(${target} PUBLIC cxx_std_20)
  tether_warnings(${target})
  install(DIRECTORY ${PLUGIN_INCLUDE}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  set_property(GLOBAL APPEND PROPERTY TETHER_CODEC_PLUGINS ${name})
  set_property(GLOBAL PROPERTY TETHER_CODEC_PLUGIN_${name}_HEADER ${PLUGIN_HEADER})
  set_property(GLOBAL PROPERTY TETHER_CODEC_PLUGIN_${name}_INCLUDE ${PLUGIN_INCLUDE})
  set_property(GLOBAL PROPERTY TETHER_CODEC_PLUGIN_${name}_LIBRARIES "${PLUGIN_LIBRARIES}")
  if(PLUGIN_COMMANDS)
    add_library(tether_${name}_commands OBJECT ${PLUGIN_COMMANDS})
    target_link_libraries(tether_${name}_commands PUBLIC tether_cli_api ${target})
    tether_warnings(tether_${name}_commands)
    set_property(GLOBAL APPEND PROPERTY TETHER_CODEC_PLUGIN_COMMANDS ${name})
  endif()
  if(PLUGIN_WORKLOADS)
    add_library(tether_${name}_workloads OBJECT ${PLUGIN_WORKLOADS})
    target_link_libraries(tether_${name}_workloads PUBLIC tether_workloads_api ${target})
    tether_warnings(tether_${name}_workloads)
    set_property(GLOBAL APPEND PROPERTY TETHER_CODEC_PLUGIN_WORKLOADS ${name})
  endif()
endfunction()
