# tether_generate_rpc(TARGET <lib> PROTOS <a.proto>... [IMPORT_DIRS <dir>...] [OUT_DIR <dir>])
#
# The rpc codec's typed C++ clients of a user's schemas: a static library <lib> with protoc's classes of
# each .proto (`<stem>.pb.h`) and, for each service, a typed client (`<stem>.tether.hpp`: `arm::ArmClient`
# for `service Arm` in `package arm`), linking Tether::rpc and protobuf. Loaded by
# `find_package(Tether COMPONENTS rpc)`; in Tether's own tree by codecs/rpc.
#
#   find_package(Tether CONFIG REQUIRED COMPONENTS rpc)
#   tether_generate_rpc(TARGET arm_rpc PROTOS arm.proto)
#   target_link_libraries(my_robot PRIVATE arm_rpc)        # #include "arm.tether.hpp"
#
# Each .proto is named as protoc and the device's generator name it: relative to the first of IMPORT_DIRS
# that holds it, else to its own folder (`arm.proto`). Imports are searched in that folder, IMPORT_DIRS,
# protobuf's well-known types and nanopb's folder: a schema with nanopb's field options
# (`import "nanopb.proto"`) builds as it is (protoc's classes of nanopb.proto join the library; the options
# shape the device's code only, not the wire or the schema hash). List in PROTOS every imported file that is
# not a well-known type or nanopb.proto. OUT_DIR (default: <binary dir>/<lib>-rpc) receives the generated
# files; it is on <lib>'s include path.
include_guard(GLOBAL)

# Where nanopb.proto is (Debian's nanopb package: /usr/lib/python3/dist-packages/proto).
find_path(TETHER_NANOPB_PROTO_DIR nanopb.proto PATHS /usr/lib/python3/dist-packages/proto
  DOC "Directory of nanopb.proto (nanopb's field options in schemas)")

function(tether_generate_rpc)
  cmake_parse_arguments(RPC "" "TARGET;OUT_DIR" "PROTOS;IMPORT_DIRS" ${ARGN})
  if(NOT RPC_TARGET OR NOT RPC_PROTOS)
    message(FATAL_ERROR "tether_generate_rpc: TARGET and PROTOS are required")
  endif()
  if(RPC_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "tether_generate_rpc: unknown arguments ${RPC_UNPARSED_ARGUMENTS}")
  endif()
  if(NOT TARGET protobuf::protoc OR NOT TARGET protobuf::libprotobuf)
    find_package(Protobuf REQUIRED)
  endif()
  if(NOT TARGET protobuf::protoc)
    message(FATAL_ERROR "tether_generate_rpc: protoc not found (Debian: protobuf-compiler)")
  endif()
  if(TARGET Tether::rpc_cpp)
    set(_generator Tether::rpc_cpp)
  else()
    message(FATAL_ERROR "tether_generate_rpc: the generator Tether::rpc_cpp is missing: "
      "find_package(Tether COMPONENTS rpc) first")
  endif()
  get_target_property(_generator_depends ${_generator} ALIASED_TARGET)  # in Tether's tree: the real target
  if(NOT _generator_depends)
    set(_generator_depends ${_generator})
  endif()
  if(RPC_OUT_DIR)
    cmake_path(ABSOLUTE_PATH RPC_OUT_DIR BASE_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR} NORMALIZE)
  else()
    set(RPC_OUT_DIR ${CMAKE_CURRENT_BINARY_DIR}/${RPC_TARGET}-rpc)
  endif()
  file(MAKE_DIRECTORY ${RPC_OUT_DIR})

  set(_import_dirs "")
  foreach(_dir IN LISTS RPC_IMPORT_DIRS)
    cmake_path(ABSOLUTE_PATH _dir BASE_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR} NORMALIZE)
    list(APPEND _import_dirs ${_dir})
  endforeach()
  set(_system_dirs "")
  if(TETHER_NANOPB_PROTO_DIR)
    list(APPEND _system_dirs ${TETHER_NANOPB_PROTO_DIR})
  endif()
  set(_well_known "")
  if(Protobuf_INCLUDE_DIR)
    list(APPEND _system_dirs ${Protobuf_INCLUDE_DIR})
    set(_well_known -I ${Protobuf_INCLUDE_DIR})
  endif()

  set(_sources "")
  set(_needs_nanopb FALSE)
  foreach(_proto IN LISTS RPC_PROTOS)
    cmake_path(ABSOLUTE_PATH _proto BASE_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR} NORMALIZE)
    if(NOT EXISTS ${_proto})
      message(FATAL_ERROR "tether_generate_rpc: ${_proto} does not exist")
    endif()
    # Its import root: the first import directory that holds it, else its folder.
    cmake_path(GET _proto PARENT_PATH _root)
    foreach(_dir IN LISTS _import_dirs)
      cmake_path(IS_PREFIX _dir ${_proto} NORMALIZE _inside)
      if(_inside)
        set(_root ${_dir})
        break()
      endif()
    endforeach()
    cmake_path(RELATIVE_PATH _proto BASE_DIRECTORY ${_root} OUTPUT_VARIABLE _name)
    cmake_path(REMOVE_EXTENSION _name LAST_ONLY OUTPUT_VARIABLE _base)
    cmake_path(GET _name PARENT_PATH _subdir)
    set(_out ${RPC_OUT_DIR})
    if(_subdir)
      set(_out ${RPC_OUT_DIR}/${_subdir})
    endif()
    set(_includes -I ${_root})
    cmake_path(GET _proto PARENT_PATH _own)
    if(NOT _own STREQUAL _root)
      list(APPEND _includes -I ${_own})
    endif()
    foreach(_dir IN LISTS _import_dirs _system_dirs)
      list(APPEND _includes -I ${_dir})
    endforeach()
    set(_generator_includes "")
    foreach(_dir IN LISTS _import_dirs)
      list(APPEND _generator_includes -I ${_dir})
    endforeach()
    file(STRINGS ${_proto} _nanopb_imports REGEX "^[ \t]*import[ \t]+(public[ \t]+)?\"nanopb\\.proto\"")
    if(_nanopb_imports)
      set(_needs_nanopb TRUE)
    endif()
    set(_outputs ${RPC_OUT_DIR}/${_base}.pb.cc ${RPC_OUT_DIR}/${_base}.pb.h ${RPC_OUT_DIR}/${_base}.tether.cpp
      ${RPC_OUT_DIR}/${_base}.tether.hpp)
    add_custom_command(
      OUTPUT ${_outputs}
      COMMAND protobuf::protoc --cpp_out=${RPC_OUT_DIR} ${_includes} ${_proto}
      COMMAND $<TARGET_FILE:${_generator}> ${_proto} --out ${_out} ${_generator_includes}
      DEPENDS ${_proto} protobuf::protoc ${_generator_depends}
      COMMENT "tether_generate_rpc: ${_name}"
      VERBATIM)
    list(APPEND _sources ${RPC_OUT_DIR}/${_base}.pb.cc ${RPC_OUT_DIR}/${_base}.tether.cpp)
  endforeach()

  if(_needs_nanopb)
    if(NOT TETHER_NANOPB_PROTO_DIR)
      message(FATAL_ERROR "tether_generate_rpc: a schema imports nanopb.proto, which was not found "
        "(Debian: nanopb; or set TETHER_NANOPB_PROTO_DIR)")
    endif()
    # Its classes: the schema's generated code registers nanopb's options with it.
    add_custom_command(
      OUTPUT ${RPC_OUT_DIR}/nanopb.pb.cc ${RPC_OUT_DIR}/nanopb.pb.h
      COMMAND protobuf::protoc --cpp_out=${RPC_OUT_DIR} -I ${TETHER_NANOPB_PROTO_DIR} ${_well_known}
              ${TETHER_NANOPB_PROTO_DIR}/nanopb.proto
      DEPENDS ${TETHER_NANOPB_PROTO_DIR}/nanopb.proto protobuf::protoc
      COMMENT "tether_generate_rpc: nanopb.proto"
      VERBATIM)
    list(APPEND _sources ${RPC_OUT_DIR}/nanopb.pb.cc)
  endif()

  add_library(${RPC_TARGET} STATIC ${_sources})
  # protoc's code is not the user's: its warnings stay out of the user's flags.
  target_include_directories(${RPC_TARGET} SYSTEM PUBLIC ${RPC_OUT_DIR})
  target_link_libraries(${RPC_TARGET} PUBLIC Tether::rpc protobuf::libprotobuf)
  target_compile_features(${RPC_TARGET} PUBLIC cxx_std_20)
endfunction()
