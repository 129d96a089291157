# tether_codec_plugin(NAME HEADER header SOURCES... [INCLUDE dir] [LIBRARIES...] [COMMANDS sources...]
#                     [SUBCOMMANDS sources...] [SUBCOMMAND_LIBRARIES libraries...] [TEXT_FUZZ source] [WORKLOADS sources...] [PYTHON sources...]
#                     [PYTHON_STUB file] [PYTHON_ROVER_CLIENT class] [PYTHON_MODULES files...]
#                     [PYTHON_REQUIRES debian-packages...] [PYTHON_FIXTURES file] [PYTHON_TESTS files...]):
#                     a codec's plugin, declared in its own folder
# (codecs/<codec>/plugin/CMakeLists.txt). This call is the codec's whole registration:
#  - SOURCES define the plugin's parts, their public declarations in HEADER (relative to INCLUDE, default
#    `include`): `std::vector<tether::devices::CodecRow> tether::<NAME>::codec_rows()`, the codec's rows of
#    the devices table (devices/codecs.hpp: configuration name, options, how a device opens);
#  - the sources are compiled against the devices API (`tether_devices_api`) and LIBRARIES, and become part of
#    `Tether::devices`, whose table lists every plugin registered this way (devices/CMakeLists.txt generates
#    the list); INCLUDE is installed with the other headers and public to `Tether::devices` users;
#  - COMMANDS define `std::vector<tether::cli::CodecCommands> tether::<NAME>::command_rows()`, the codec's rows
#    of the `tether` command (tools/tether/codec_commands.hpp: shell, monitor, stats, command-line defaults),
#    compiled against the command's own headers (`tether_cli_api`) into it, with what they print for the
#    codec's devices (shell lines, monitor decoders);
#  - SUBCOMMANDS define `std::vector<tether::cli::Command> tether::<NAME>::subcommands()`, subcommands of
#    `tether` that only this codec has (tools/tether/commands.hpp: `tether call` is the Romi plugin's),
#    compiled against the same headers into the command's subcommand library; SUBCOMMAND_LIBRARIES are
#    libraries only they use (rpc's generator for `tether generate`), which the command then links;
#  - TEXT_FUZZ is the fuzz target `<NAME>_text` of what the command rows print (tools/tether/text_fuzzing.hpp),
#    its corpus `corpus-<NAME>_text.tar.xz` beside it, built with the tests (the plugin's `src` on its
#    include path, for the rows' own headers);
#  - WORKLOADS define `std::vector<tether::demo::CodecWorkloads> tether::<NAME>::workload_rows()`, how its devices
#    do the operations `tether demo` and `tether bench` measure (tools/demo/include/tether/demo/workload.hpp),
#    compiled into the demo's library (`tether_workloads_api`);
#  - PYTHON define `void tether::<NAME>::register_python(pybind11::module_&)`, the codec's part of the Python
#    module (its submodule, its client's wrapper, its `Rover` getter), compiled into the module against the
#    binding's headers (python/src) when the module is built;
#  - PYTHON_STUB is the type stub of that submodule, shipped as `tether/<NAME>.pyi` (python/tests/test_stubs.py
#    checks it names exactly what the submodule has); PYTHON_ROVER_CLIENT is the class of the stub that the
#    `Rover.<NAME>(name)` getter returns, declared in the package's stub (tether/__init__.pyi, generated); the
#    stub's classes deriving from TetherError are the codec's exceptions (made by `register_errors`,
#    python/src/binding.hpp), re-exported by the package and its stub;
#  - PYTHON_MODULES are pure-Python modules the codec ships in the package (`compat.py` -> `tether.compat`,
#    imported by `import tether`), each with its stub beside it (`compat.pyi`); PYTHON_REQUIRES are the
#    Debian packages of the Python modules its part imports (`python3-protobuf`): python3-tether depends on them;
#  - PYTHON_TESTS are pytest files, run together as the ctest test `python.<NAME>` (label `python`);
#    PYTHON_FIXTURES is a pytest plugin module of the codec's fixtures (its boards, its clients), loaded with
#    `-p <module>` by every Python test (the binding's own tests use them too), as the generic fixtures are
#    (python/tests/generic_fixtures.py).
# docs/codecs.md, "Adding a codec".
include_guard(GLOBAL)

# One optional part of a plugin: an interface library whose sources (INTERFACE_SOURCES, absolute) the library
# that collects the part compiles as its own, against `api` and the plugin. So the parts of every codec share
# the collector's unity batches (TETHER_UNITY_BUILD): compiled alone, each of these small sources spent most
# of its time instantiating the same asio, JSON and std::function templates as the others.
function(_tether_codec_plugin_part name part api)
  set(_sources "")
  foreach(_source IN LISTS ARGN)
    cmake_path(ABSOLUTE_PATH _source BASE_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR} NORMALIZE)
    list(APPEND _sources ${_source})
  endforeach()
  add_library(tether_${name}_${part} INTERFACE)
  target_sources(tether_${name}_${part} INTERFACE ${_sources})
  target_link_libraries(tether_${name}_${part} INTERFACE ${api} tether_${name}_plugin)
  set_property(GLOBAL APPEND PROPERTY TETHER_CODEC_PLUGIN_PARTS_${part} ${name})
endfunction()

# tether_codec_plugin_collect(PART part ROW_TYPE type FUNCTION function TEMPLATE file OUTPUT file
#                             LIBRARIES var): for the library that holds one part (commands, subcommands,
# workloads) of every plugin: OUTPUT is TEMPLATE configured with @TETHER_PLUGIN_DECLARATIONS@ (each plugin's
# `std::vector<ROW_TYPE> tether::<plugin>::FUNCTION();`) and @TETHER_PLUGIN_CALLS@ (an `add(...)` of each),
# and VAR lists the plugins' part libraries, to link PRIVATE: their sources become the collector's.
function(tether_codec_plugin_collect)
  cmake_parse_arguments(COLLECT "" "PART;ROW_TYPE;FUNCTION;TEMPLATE;OUTPUT;LIBRARIES" "" ${ARGN})
  get_property(_plugins GLOBAL PROPERTY TETHER_CODEC_PLUGIN_PARTS_${COLLECT_PART})
  set(TETHER_PLUGIN_DECLARATIONS "")
  set(TETHER_PLUGIN_CALLS "")
  set(_libraries "")
  foreach(_plugin IN LISTS _plugins)
    string(APPEND TETHER_PLUGIN_DECLARATIONS "namespace tether::${_plugin} {\nstd::vector<${COLLECT_ROW_TYPE}> "
      "${COLLECT_FUNCTION}();\n}  // namespace tether::${_plugin}\n")
    string(APPEND TETHER_PLUGIN_CALLS "  add(tether::${_plugin}::${COLLECT_FUNCTION}());\n")
    list(APPEND _libraries tether_${_plugin}_${COLLECT_PART})
  endforeach()
  configure_file(${COLLECT_TEMPLATE} ${COLLECT_OUTPUT} @ONLY)
  set(${COLLECT_LIBRARIES} ${_libraries} PARENT_SCOPE)
endfunction()

function(tether_codec_plugin name)
  cmake_parse_arguments(PLUGIN "" "HEADER;INCLUDE;TEXT_FUZZ;PYTHON_STUB;PYTHON_ROVER_CLIENT;PYTHON_FIXTURES"
    "SOURCES;LIBRARIES;COMMANDS;SUBCOMMANDS;SUBCOMMAND_LIBRARIES;WORKLOADS;PYTHON;PYTHON_TESTS;PYTHON_MODULES;PYTHON_REQUIRES" ${ARGN})
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
  tether_use_precompiled_header(${target} tether_library_pch)  # the test build's (cmake/precompiled-header.cmake)
  install(DIRECTORY ${PLUGIN_INCLUDE}/ DESTINATION ${CMAKE_INSTALL_INCLUDEDIR})
  set_property(GLOBAL APPEND PROPERTY TETHER_CODEC_PLUGINS ${name})
  set_property(GLOBAL PROPERTY TETHER_CODEC_PLUGIN_${name}_HEADER ${PLUGIN_HEADER})
  set_property(GLOBAL PROPERTY TETHER_CODEC_PLUGIN_${name}_INCLUDE ${PLUGIN_INCLUDE})
  set_property(GLOBAL PROPERTY TETHER_CODEC_PLUGIN_${name}_LIBRARIES "${PLUGIN_LIBRARIES}")
  # The parts for the tools (the command, the demo, the bench) only when they are built (TETHER_BUILD_TOOLS:
  # a parent project does not build them).
  if(NOT TETHER_BUILD_TOOLS)
    set(PLUGIN_COMMANDS "")
    set(PLUGIN_SUBCOMMANDS "")
    set(PLUGIN_WORKLOADS "")
  endif()
  if(PLUGIN_COMMANDS)
    _tether_codec_plugin_part(${name} commands tether_cli_api ${PLUGIN_COMMANDS})
  endif()
  if(PLUGIN_SUBCOMMANDS)
    _tether_codec_plugin_part(${name} subcommands tether_cli_api ${PLUGIN_SUBCOMMANDS})
    if(PLUGIN_SUBCOMMAND_LIBRARIES)
      target_link_libraries(tether_${name}_subcommands INTERFACE ${PLUGIN_SUBCOMMAND_LIBRARIES})
      set_property(GLOBAL APPEND PROPERTY TETHER_CODEC_PLUGIN_SUBCOMMAND_LIBRARIES ${PLUGIN_SUBCOMMAND_LIBRARIES})
    endif()
  endif()
  if(PLUGIN_TEXT_FUZZ AND PLUGIN_COMMANDS AND TETHER_BUILD_TESTS)
    include(fuzz)
    cmake_path(GET PLUGIN_TEXT_FUZZ PARENT_PATH _fuzz_dir)
    # Fewer generated inputs than a decoder's target: each runs a whole monitor decoder or shell line.
    tether_fuzz_target(${name}_text
      SOURCES ${PLUGIN_TEXT_FUZZ}
      LIBRARIES tether_cli_text
      CORPUS ${_fuzz_dir}/corpus-${name}_text.tar.xz
      ITERATIONS 10000)
    target_include_directories(fuzz_${name}_text PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  endif()
  if(PLUGIN_WORKLOADS)
    _tether_codec_plugin_part(${name} workloads tether_workloads_api ${PLUGIN_WORKLOADS})
  endif()
  if(PLUGIN_PYTHON)
    # Compiled by the module itself (python/CMakeLists.txt), which may be skipped (no pybind11).
    list(TRANSFORM PLUGIN_PYTHON PREPEND ${CMAKE_CURRENT_SOURCE_DIR}/)
    set_property(GLOBAL APPEND PROPERTY TETHER_CODEC_PLUGIN_PARTS_python ${name})
    set_property(GLOBAL PROPERTY TETHER_CODEC_PLUGIN_${name}_PYTHON ${PLUGIN_PYTHON})
    foreach(_file IN ITEMS PYTHON_STUB PYTHON_FIXTURES)
      if(PLUGIN_${_file})
        cmake_path(ABSOLUTE_PATH PLUGIN_${_file} BASE_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR} NORMALIZE)
      endif()
    endforeach()
    list(TRANSFORM PLUGIN_PYTHON_TESTS PREPEND ${CMAKE_CURRENT_SOURCE_DIR}/)
    list(TRANSFORM PLUGIN_PYTHON_MODULES PREPEND ${CMAKE_CURRENT_SOURCE_DIR}/)
    foreach(_module IN LISTS PLUGIN_PYTHON_MODULES)
      string(REGEX REPLACE "\\.py$" ".pyi" _module_stub ${_module})
      if(NOT _module MATCHES "\\.py$" OR NOT EXISTS ${_module_stub})
        message(FATAL_ERROR "tether_codec_plugin(${name}): PYTHON_MODULES ${_module}: a .py file with its .pyi beside it")
      endif()
    endforeach()
    set_property(GLOBAL APPEND PROPERTY TETHER_PYTHON_DEBIAN_DEPENDS ${PLUGIN_PYTHON_REQUIRES})
    foreach(_part IN ITEMS PYTHON_STUB PYTHON_ROVER_CLIENT PYTHON_FIXTURES PYTHON_TESTS PYTHON_MODULES)
      set_property(GLOBAL PROPERTY TETHER_CODEC_PLUGIN_${name}_${_part} "${PLUGIN_${_part}}")
    endforeach()
  elseif(PLUGIN_PYTHON_STUB OR PLUGIN_PYTHON_ROVER_CLIENT OR PLUGIN_PYTHON_FIXTURES OR PLUGIN_PYTHON_TESTS OR
         PLUGIN_PYTHON_MODULES OR PLUGIN_PYTHON_REQUIRES)
    message(FATAL_ERROR "tether_codec_plugin(${name}): PYTHON_... parts need the PYTHON sources")
  endif()
endfunction()
