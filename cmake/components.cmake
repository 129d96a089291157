# Which parts of Tether this build makes. A parent project (add_subdirectory, FetchContent) that drives real
# ports names what it links, and only those parts' dependencies are looked for:
#   set(TETHER_COMPONENTS romi)         # Tether::romi: Boost and nlohmann-json, no protobuf, no simulator
#   add_subdirectory(tether)
# The names are find_package(Tether COMPONENTS ...)'s. A component brings the ones it is built on (romi,
# proxy and elcano bring client, transports and core; client brings transports; devices brings every codec;
# virtual_uno brings devices and simulator). simulator and virtual_uno are built only with
# TETHER_BUILD_SIMULATOR (libsimavr, libelf).
# Sets TETHER_BUILT_COMPONENTS (the closed list) and TETHER_WITH_<COMPONENT> (ON/OFF) for each name.
include_guard(GLOBAL)

# The codecs: one folder each under codecs/ (docs/codecs.md), each a component built on the client runtime.
# A new codec is its folder and its name here.
set(TETHER_CODECS romi proxy elcano rpc)
set(TETHER_ALL_COMPONENTS core transports client ${TETHER_CODECS} devices simulator virtual_uno)
set(TETHER_COMPONENTS "${TETHER_ALL_COMPONENTS}" CACHE STRING
  "Tether components to build (find_package names: ${TETHER_ALL_COMPONENTS}); what they are built on comes too")

# What each component is built on.
set(_tether_needs_transports core)
set(_tether_needs_client transports core)
foreach(_tether_codec IN LISTS TETHER_CODECS)
  set(_tether_needs_${_tether_codec} client)
endforeach()
set(_tether_needs_rpc client proxy)  # the proxy's framing and its host client's message parsing
set(_tether_needs_devices ${TETHER_CODECS})
set(_tether_needs_simulator client)  # a virtual board's clock is a link clock
set(_tether_needs_virtual_uno devices simulator)

set(_tether_pending "")
foreach(_tether_component IN LISTS TETHER_COMPONENTS)
  if(NOT _tether_component IN_LIST TETHER_ALL_COMPONENTS)
    message(FATAL_ERROR "TETHER_COMPONENTS: no component '${_tether_component}' (components: ${TETHER_ALL_COMPONENTS})")
  endif()
  if(_tether_component MATCHES "^(simulator|virtual_uno)$" AND NOT TETHER_BUILD_SIMULATOR)
    continue()  # the simulator is opted into as a whole (TETHER_BUILD_SIMULATOR)
  endif()
  list(APPEND _tether_pending ${_tether_component})
endforeach()

set(TETHER_BUILT_COMPONENTS "")
while(_tether_pending)
  list(POP_FRONT _tether_pending _tether_component)
  if(NOT _tether_component IN_LIST TETHER_BUILT_COMPONENTS)
    list(APPEND TETHER_BUILT_COMPONENTS ${_tether_component})
    list(APPEND _tether_pending ${_tether_needs_${_tether_component}})
  endif()
endwhile()

foreach(_tether_component IN LISTS TETHER_ALL_COMPONENTS)
  string(TOUPPER ${_tether_component} _tether_upper)
  if(_tether_component IN_LIST TETHER_BUILT_COMPONENTS)
    set(TETHER_WITH_${_tether_upper} ON)
  else()
    set(TETHER_WITH_${_tether_upper} OFF)
  endif()
endforeach()
# In the package's order, for messages and TetherConfig.cmake.
set(_tether_ordered "")
foreach(_tether_component IN LISTS TETHER_ALL_COMPONENTS)
  if(_tether_component IN_LIST TETHER_BUILT_COMPONENTS)
    list(APPEND _tether_ordered ${_tether_component})
  endif()
endforeach()
set(TETHER_BUILT_COMPONENTS ${_tether_ordered})
message(STATUS "Tether components: ${TETHER_BUILT_COMPONENTS}")

# tether_require_components(OPTION component...): OPTION (a TETHER_BUILD_* switch that is ON) builds code that
# links these components; stop with what to change when one is not built.
function(tether_require_components option)
  set(_missing "")
  foreach(_component IN LISTS ARGN)
    if(NOT _component IN_LIST TETHER_BUILT_COMPONENTS)
      list(APPEND _missing ${_component})
    endif()
  endforeach()
  if(_missing)
    set(_how "add them to TETHER_COMPONENTS")
    if(NOT TETHER_BUILD_SIMULATOR AND ("simulator" IN_LIST _missing OR "virtual_uno" IN_LIST _missing))
      set(_how "set TETHER_BUILD_SIMULATOR=ON (libsimavr, libelf) and have them in TETHER_COMPONENTS")
    endif()
    list(JOIN _missing " " _missing)
    message(FATAL_ERROR "${option}=ON needs the Tether components ${_missing}: ${_how}, or set ${option}=OFF")
  endif()
endfunction()

unset(_tether_pending)
unset(_tether_ordered)
unset(_tether_component)
unset(_tether_upper)
