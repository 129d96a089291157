# cmake -DPREFIX=... -DCXX=... -DSCRATCH=... -DMODE=alone|after_asio [-DUSAGE_FLAGS="..."] [-DJOBS=N] -P headers.cmake
# Compiles every installed public header: alone, in a translation unit of its own (it includes what it
# uses), or after <boost/asio.hpp> on a unit's first line, as users write it (include order does not
# matter), with the project's warnings as errors. USAGE_FLAGS: the compile options the package gives its users
# (cmake/asio-cxx20.cmake), as a consumer gets them.
#
# Cost: alone needs a unit per header (nothing may come before it). after_asio checks what asio-first users
# compile, so its units are what they write: <boost/asio.hpp> on the first line, then Tether headers; JOBS
# units (a share of the headers each) instead of a unit per header, which parsed asio once per header
# (about 100 s of CPU of the suite's). A unit that fails is split into one unit per header (asio, then that
# header) so the message names each header that does not compile. JOBS compilers run at once (default 2).
file(GLOB_RECURSE headers RELATIVE ${PREFIX}/include ${PREFIX}/include/tether/*.hpp)
# *_impl.hpp hold template definitions their header includes at its end; they are not included alone.
list(FILTER headers EXCLUDE REGEX "^tether/proxy_messages/|_impl\\.hpp$")
if(NOT JOBS)
  set(JOBS 2)
endif()
file(REMOVE_RECURSE ${SCRATCH})
file(MAKE_DIRECTORY ${SCRATCH})
separate_arguments(usage_flags UNIX_COMMAND "${USAGE_FLAGS}")
set(flags -std=c++20 -Wall -Wextra -Wconversion -Wsign-conversion -Wshadow -Werror -DBOOST_ASIO_NO_DEPRECATED
  -I${PREFIX}/include -isystem ${PREFIX}/include/tether/proxy_messages)
if(NOT MODE MATCHES "^(alone|after_asio)$")
  message(FATAL_ERROR "MODE must be alone or after_asio, not '${MODE}'")
endif()
list(APPEND flags ${usage_flags})

# The units: unit_<n>.cpp, whose headers are unit_<n>_headers. alone: one header each; after_asio: JOBS
# units, asio first, the headers dealt round.
list(LENGTH headers header_count)
set(prefix "")
set(unit_count ${header_count})
if(MODE STREQUAL "after_asio")
  set(prefix "#include <boost/asio.hpp>\n")
  if(unit_count GREATER JOBS)
    set(unit_count ${JOBS})
  endif()
endif()
set(units "")
if(unit_count GREATER 0)
  math(EXPR last "${unit_count} - 1")
  foreach(unit RANGE ${last})
    list(APPEND units ${unit})
    set(unit_${unit}_text "${prefix}")
    set(unit_${unit}_headers "")
  endforeach()
endif()
set(index 0)
foreach(header IN LISTS headers)
  math(EXPR unit "${index} % ${unit_count}")
  string(APPEND unit_${unit}_text "#include <${header}>\n")
  list(APPEND unit_${unit}_headers ${header})
  math(EXPR index "${index} + 1")
endforeach()
foreach(unit IN LISTS units)
  file(WRITE ${SCRATCH}/unit_${unit}.cpp "${unit_${unit}_text}")
endforeach()

# compile_alone(<header>): its own unit (after asio in after_asio mode); a failure is reported with g++'s
# message and the header added to `failed`.
function(compile_alone header)
  file(WRITE ${SCRATCH}/single.cpp "${prefix}#include <${header}>\n")
  execute_process(COMMAND ${CXX} ${flags} -fsyntax-only ${SCRATCH}/single.cpp RESULT_VARIABLE result
    ERROR_VARIABLE err)
  if(NOT result EQUAL 0)
    string(SUBSTRING "${err}" 0 1500 err)
    message(SEND_ERROR "${header} (${MODE}) does not compile:\n${err}")
    set(failed ${failed} ${header} PARENT_SCOPE)
  endif()
endfunction()

# JOBS units at a time: execute_process runs its COMMANDs concurrently (as a pipeline whose stages read and
# write nothing: -fsyntax-only). A unit that fails is compiled again header by header for the messages.
set(failed "")
list(LENGTH units count)
set(start 0)
while(start LESS count)
  set(commands "")
  set(batch "")
  foreach(offset RANGE 1 ${JOBS})
    math(EXPR at "${start} + ${offset} - 1")
    if(at LESS count)
      list(GET units ${at} unit)
      list(APPEND batch ${unit})
      list(APPEND commands COMMAND ${CXX} ${flags} -fsyntax-only ${SCRATCH}/unit_${unit}.cpp)
    endif()
  endforeach()
  execute_process(${commands} RESULTS_VARIABLE results OUTPUT_QUIET ERROR_QUIET)
  foreach(unit result IN ZIP_LISTS batch results)
    if(NOT result EQUAL 0)
      list(LENGTH failed failed_before)
      foreach(header IN LISTS unit_${unit}_headers)
        compile_alone(${header})
      endforeach()
      list(LENGTH failed failed_after)
      if(failed_after EQUAL failed_before)  # each compiles after asio; together they do not
        execute_process(COMMAND ${CXX} ${flags} -fsyntax-only ${SCRATCH}/unit_${unit}.cpp ERROR_VARIABLE err)
        string(SUBSTRING "${err}" 0 1500 err)
        message(SEND_ERROR "${unit_${unit}_headers} (${MODE}) do not compile together:\n${err}")
        list(APPEND failed ${unit_${unit}_headers})
      endif()
    endif()
  endforeach()
  math(EXPR start "${start} + ${JOBS}")
endwhile()
list(LENGTH failed failures)
message(STATUS "${header_count} headers in ${count} units, ${failures} failed (${MODE})")
file(REMOVE_RECURSE ${SCRATCH})
