# Writes a fuzz corpus archive from a folder of inputs:
#   cmake -DDIR=<folder> -DARCHIVE=<corpus-NAME.tar.xz> -P cmake/fuzz-corpus-pack.cmake
# (tools/fuzz pack/add call it; cmake/fuzz.cmake unpacks the archive in the build tree.)
#
# The archive holds the folder's files by bare name (no directory entry), so the tests replay exactly the
# folder's inputs. Its bytes depend on nothing but those names and contents, so re-packing an unchanged
# corpus leaves the file untouched and a changed corpus shows in git as a changed archive and nothing else:
# names sorted bytewise, mtime 0, uid/gid 0 without names, mode 0644, GNU format (no pax atime/ctime),
# single-threaded xz with a fixed preset and a dictionary bounded at 8 MiB (what unpacking must allocate;
# xz's -9 would ask every unpack for 65 MiB). Needs GNU tar and xz (Debian: tar, xz-utils).
cmake_minimum_required(VERSION 3.25)

if(NOT DIR OR NOT ARCHIVE)
  message(FATAL_ERROR "usage: cmake -DDIR=<folder> -DARCHIVE=<corpus-NAME.tar.xz> -P ${CMAKE_CURRENT_LIST_FILE}")
endif()
# Relative paths are the caller's: -P mode sets CMAKE_CURRENT_BINARY_DIR to the working directory.
cmake_path(ABSOLUTE_PATH DIR BASE_DIRECTORY "${CMAKE_CURRENT_BINARY_DIR}" NORMALIZE)
cmake_path(ABSOLUTE_PATH ARCHIVE BASE_DIRECTORY "${CMAKE_CURRENT_BINARY_DIR}" NORMALIZE)
if(NOT ARCHIVE MATCHES "\\.tar\\.xz$")
  message(FATAL_ERROR "fuzz-corpus-pack: ARCHIVE must end in .tar.xz: ${ARCHIVE}")
endif()
if(NOT IS_DIRECTORY "${DIR}")
  message(FATAL_ERROR "fuzz-corpus-pack: no folder ${DIR}")
endif()

# The inputs: regular files directly in DIR. A corpus is flat (libFuzzer writes it so, and the driver of the
# ordinary build reads one level), so anything else is a mistake worth stopping for.
file(GLOB entries LIST_DIRECTORIES true RELATIVE "${DIR}" "${DIR}/*" "${DIR}/.*")
set(names "")
foreach(entry IN LISTS entries)
  if(entry STREQUAL "." OR entry STREQUAL "..")
    continue()
  endif()
  if(IS_SYMLINK "${DIR}/${entry}" OR IS_DIRECTORY "${DIR}/${entry}")
    message(FATAL_ERROR "fuzz-corpus-pack: ${DIR}/${entry} is not a regular file (a corpus holds files only)")
  endif()
  # Names travel through CMake lists and tar's name list: keep them to characters neither reads specially.
  if(NOT entry MATCHES "^[A-Za-z0-9_.+=,@-]+$")
    message(FATAL_ERROR "fuzz-corpus-pack: rename ${DIR}/${entry}: an input's name uses letters, digits and _.+=,@- only")
  endif()
  list(APPEND names "${entry}")
endforeach()
list(REMOVE_DUPLICATES names)
if(NOT names)
  message(FATAL_ERROR "fuzz-corpus-pack: ${DIR} holds no inputs; refusing to write an empty corpus")
endif()
list(SORT names COMPARE STRING CASE SENSITIVE ORDER ASCENDING)  # bytewise, like LC_ALL=C sort

find_program(TETHER_GNU_TAR NAMES gtar tar REQUIRED)
find_program(TETHER_XZ xz REQUIRED)
execute_process(COMMAND ${TETHER_GNU_TAR} --version OUTPUT_VARIABLE tar_version)
if(NOT tar_version MATCHES "GNU tar")
  message(FATAL_ERROR "fuzz-corpus-pack: ${TETHER_GNU_TAR} is not GNU tar (its options make the archive reproducible)")
endif()

cmake_path(GET ARCHIVE PARENT_PATH archive_dir)
cmake_path(GET ARCHIVE FILENAME archive_name)
if(NOT IS_DIRECTORY "${archive_dir}")
  message(FATAL_ERROR "fuzz-corpus-pack: no folder for ${ARCHIVE}")
endif()
string(RANDOM LENGTH 8 token)
set(scratch "${archive_dir}/.${archive_name}.${token}")  # beside the archive: the final step is a rename
list(JOIN names "\n" name_lines)
file(WRITE "${scratch}.list" "${name_lines}\n")

execute_process(
  COMMAND ${TETHER_GNU_TAR} --create --file=${scratch}.tar --directory=${DIR} --format=gnu --no-recursion
          --mtime=@0 --owner=0 --group=0 --numeric-owner --mode=a=r,u+w --no-acls --no-xattrs --no-selinux
          --verbatim-files-from --files-from=${scratch}.list
  RESULT_VARIABLE tar_status)
if(tar_status EQUAL 0)
  # From the file, not a pipe: the output does not depend on how the input reached xz.
  execute_process(
    COMMAND ${TETHER_XZ} --format=xz --check=crc64 --lzma2=preset=9e,dict=8MiB --threads=1 --stdout ${scratch}.tar
    OUTPUT_FILE ${scratch}.xz RESULT_VARIABLE xz_status)
endif()
if(NOT tar_status EQUAL 0 OR NOT xz_status EQUAL 0)
  file(REMOVE ${scratch}.list ${scratch}.tar ${scratch}.xz)
  message(FATAL_ERROR "fuzz-corpus-pack: packing ${DIR} failed (tar: ${tar_status}, xz: ${xz_status})")
endif()

# What went in is what the folder holds: list the archive back.
execute_process(COMMAND ${TETHER_GNU_TAR} --list --file=${scratch}.xz OUTPUT_VARIABLE listed RESULT_VARIABLE list_status)
string(REGEX REPLACE "\n$" "" listed "${listed}")
string(REPLACE "\n" ";" listed "${listed}")
if(NOT list_status EQUAL 0 OR NOT listed STREQUAL names)
  file(REMOVE ${scratch}.list ${scratch}.tar ${scratch}.xz)
  message(FATAL_ERROR "fuzz-corpus-pack: the archive written from ${DIR} does not list its files back")
endif()

list(LENGTH names count)
if(EXISTS "${ARCHIVE}")
  file(SHA256 "${ARCHIVE}" before)
else()
  set(before "")
endif()
file(SHA256 "${scratch}.xz" after)
if(before STREQUAL after)
  file(REMOVE ${scratch}.xz)  # unchanged: keep the file's time, so builds do not unpack it again
  message(STATUS "fuzz corpus unchanged: ${ARCHIVE} (${count} inputs)")
else()
  file(RENAME ${scratch}.xz "${ARCHIVE}")
  file(SIZE "${ARCHIVE}" size)
  message(STATUS "fuzz corpus written: ${ARCHIVE} (${count} inputs, ${size} bytes)")
endif()
file(REMOVE ${scratch}.list ${scratch}.tar)
