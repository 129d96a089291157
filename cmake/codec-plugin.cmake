# tether_codec_plugin(NAME HEADER header SOURCES... [INCLUDE dir] [LIBRARIES...]): a codec's plugin, declared in
# its own folder (codecs/<codec>/plugin/CMakeLists.txt). This call is the codec's whole registration:
#  - SOURCES define the plugin's parts, their public declarations in HEADER (relative to INCLUDE, default
#    `include`): `std::vector<tether::devices::CodecRow> tether::<NAME>::codec_rows()`, the codec's rows of
#    the devices table (devices/codecs.hpp: configuration name, options, how a device opens);
#  - the sources are compiled against the devices API (`tether_devices_api`) and LIBRARIES, and become part of
#    `Tether::devices`, whose table lists every plugin registered this way (devices/CMakeLists.txt generates
#    the list); INCLUDE is installed with the other headers and public to `Tether::devices` users.
# docs/codecs.md, "Adding a codec".
include_guard(GLOBAL)

function(tether_codec_plugin name)
  cmake_parse_arguments(PLUGIN "" "HEADER;INCLUDE" "SOURCES;LIBRARIES" ${ARGN})
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
endfunction()
