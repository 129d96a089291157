# Assembles one Arduino library (1.5 format) from the tree and zips it (run with cmake -P by the
# `arduino-libraries` target of firmware/arduino/CMakeLists.txt, which writes SPEC):
#
#   <OUT_DIR>/<NAME>/library.properties, examples/, src/   and   <OUT_DIR>/<NAME>.zip (the folder, for the
#   IDE's Sketch > Include Library > Add .ZIP Library)
#
# SPEC sets:
#   NAME           library name (folder and zip)
#   ASSETS_DIR     firmware/arduino/<NAME>: library.properties, examples/, src/ (Arduino glue), copied as is
#   HEADER_DIRS    include roots (core/include, codecs/x/include, ...): their contents go to src/, so the
#                  project's include paths (tether/...) work unchanged from the src/ root the builder puts on
#                  the include path
#   SOURCES        .cpp files (absolute): copied to src/tether_sources/<path in the tree>, which the builder
#                  compiles recursively; the tree path keeps equal file names of different folders apart
#   TETHER_ROOT    the tree
#   NANOPB_SCHEMAS .proto files to generate with nanopb into src/ (empty: no nanopb)
#   NANOPB_GENERATOR, NANOPB_RUNTIME_DIR, NANOPB_DEFINES  (with NANOPB_SCHEMAS)
cmake_minimum_required(VERSION 3.25)
if(NOT SPEC)
  message(FATAL_ERROR "SPEC not set")
endif()
include(${SPEC})

set(library ${OUT_DIR}/${NAME})
file(REMOVE_RECURSE ${library} ${OUT_DIR}/${NAME}.zip)
file(MAKE_DIRECTORY ${library}/src)
file(COPY ${ASSETS_DIR}/ DESTINATION ${library})

foreach(dir IN LISTS HEADER_DIRS)
  file(COPY ${dir}/ DESTINATION ${library}/src FILES_MATCHING PATTERN "*.hpp" PATTERN "*.h")
endforeach()

foreach(source IN LISTS SOURCES)
  file(RELATIVE_PATH relative ${TETHER_ROOT} ${source})
  get_filename_component(folder ${relative} DIRECTORY)
  file(COPY ${source} DESTINATION ${library}/src/tether_sources/${folder})
endforeach()

if(NANOPB_SCHEMAS)
  # The runtime (Debian's source package of the installed nanopb) and the generated messages sit at the src/
  # root: the device code includes <pb.h>, <pb_encode.h> and "tether_proxy.pb.h" from the include path. The
  # Arduino builder has no per-library defines, so the runtime's configuration (the same as the AVR images')
  # is written at the top of this copy of pb.h, where every file that includes it sees it.
  foreach(file pb.h pb_common.h pb_encode.h pb_decode.h pb_common.c pb_encode.c pb_decode.c)
    file(COPY ${NANOPB_RUNTIME_DIR}/${file} DESTINATION ${library}/src)
  endforeach()
  file(READ ${library}/src/pb.h pb_header)
  set(config "/* Tether's nanopb configuration (generated library; see firmware/arduino/assemble-library.cmake). */\n")
  foreach(define IN LISTS NANOPB_DEFINES)
    string(APPEND config "#ifndef ${define}\n#define ${define} 1\n#endif\n")
  endforeach()
  file(WRITE ${library}/src/pb.h "${config}${pb_header}")
  foreach(schema IN LISTS NANOPB_SCHEMAS)
    get_filename_component(schema_dir ${schema} DIRECTORY)
    execute_process(COMMAND ${NANOPB_GENERATOR} -q -D ${library}/src -I ${schema_dir} ${schema}
                    RESULT_VARIABLE failed)
    if(failed)
      message(FATAL_ERROR "nanopb failed on ${schema}")
    endif()
  endforeach()
endif()

execute_process(COMMAND ${CMAKE_COMMAND} -E tar cf ${NAME}.zip --format=zip ${NAME}
                WORKING_DIRECTORY ${OUT_DIR} RESULT_VARIABLE failed)
if(failed)
  message(FATAL_ERROR "zipping ${NAME} failed")
endif()
