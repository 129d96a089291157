# The nanopb runtime sources (tools/fetch-nanopb-source): tools/setup passes their folder as
# TETHER_NANOPB_SOURCE_DIR; a hand-run configure finds what a previous setup unpacked under .deps/.
# Included before the codecs: the rpc codec's kit for `tether generate` needs them as much as the AVR
# sub-build (which fails without them; the kit is only left out).
if(NOT TETHER_NANOPB_SOURCE_DIR)
  file(GLOB _nanopb_dirs LIST_DIRECTORIES true ${PROJECT_SOURCE_DIR}/.deps/nanopb-*)
  if(_nanopb_dirs)
    list(SORT _nanopb_dirs)
    list(GET _nanopb_dirs -1 _nanopb_dir)
    # FORCE: an empty entry (a configure before the sources were fetched) is replaced.
    set(TETHER_NANOPB_SOURCE_DIR ${_nanopb_dir} CACHE PATH "nanopb source tree (from tools/fetch-nanopb-source)" FORCE)
  endif()
endif()
