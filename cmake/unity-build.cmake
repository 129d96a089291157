# tether_unity_build(<target>...): with TETHER_UNITY_BUILD on, each <target> is compiled as one unity batch
# (UNITY_BUILD: all of its sources included into one translation unit).
#
# Why: in a Debug + sanitizer build most of a source's compile time is code generation for the templates it
# instantiates (asio's operations, GoogleTest's machinery, std::function managers, nlohmann::json), and the
# sources of one target instantiate mostly the same ones: 60 % of the code in tether_command_tests' objects
# was emitted more than once. A batch compiles each once. One batch per target, not batches of 8: the
# command's 19 sources took 79 s of CPU in three batches and 40 s in one, its tests 62 and 41 s, the Python
# module 75 and 55 s (the sanitized build, each pinned to one CPU).
#
# Off by default in Tether's own build: an edit recompiles the whole batch, and a per-source build is what
# checks that each source includes what it uses (a developer's build). On by default when Tether is a
# parent's subdirectory (FetchContent): compiled once, never edited there. `tools/setup test` (CI) turns it on. A target listed here must be unity-safe: no two of its sources
# define the same name inside an unnamed namespace or at file scope, and no source names `testing::...`
# relying on which `testing` namespaces happen to be visible (qualify: `::tether::testing::...`).
#
# The static libraries listed here are the heavy ones (asio and JSON in every unit): in the test build they
# also include its shared precompiled header (cmake/precompiled-header.cmake), batched or not.
include_guard(GLOBAL)

function(tether_unity_build)
  foreach(target IN LISTS ARGN)
    get_target_property(type ${target} TYPE)
    if(type STREQUAL "STATIC_LIBRARY")
      tether_use_precompiled_header(${target} tether_library_pch)
    endif()
    if(TETHER_UNITY_BUILD)
      set_target_properties(${target} PROPERTIES UNITY_BUILD ON UNITY_BUILD_BATCH_SIZE 0)
    endif()
  endforeach()
endfunction()
