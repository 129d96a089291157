# cmake -DPREFIX=... -DCXX=... -DSCRATCH=... -DMODE=alone|after_asio [-DUSAGE_FLAGS="..."] [-DJOBS=N] -P headers.cmake
# Compiles every installed public header in a translation unit of its own: alone (it includes what it
# uses), or after <boost/asio.hpp> and nothing else, as users write it (include order does not matter), with
# the project's warnings as errors. USAGE_FLAGS: the compile options the package gives its users
# (cmake/asio-cxx20.cmake), as a consumer gets them.
#
# Cost: parsing <boost/asio.hpp> is most of each after_asio unit (about 2.5 s of CPU), so that prefix is
# compiled once into a precompiled header that every unit starts from (-Winvalid-pch -Werror: a PCH g++
# cannot use fails the test instead of silently parsing again). JOBS compilers run at once (default 2).
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

if(MODE STREQUAL "after_asio")
  # The unit is <boost/asio.hpp> and then the header; the first comes precompiled (with the usage flags, as a
  # user's first line is compiled) through -include, which g++ takes from the .gch only when it comes before
  # any other -include.
  file(WRITE ${SCRATCH}/asio_first.hpp "#include <boost/asio.hpp>\n")
  execute_process(COMMAND ${CXX} ${flags} ${usage_flags} -x c++-header ${SCRATCH}/asio_first.hpp
    -o ${SCRATCH}/asio_first.hpp.gch RESULT_VARIABLE result ERROR_VARIABLE err)
  if(NOT result EQUAL 0)
    message(FATAL_ERROR "<boost/asio.hpp> does not compile as a precompiled header:\n${err}")
  endif()
  list(APPEND flags -Winvalid-pch -include ${SCRATCH}/asio_first.hpp)
elseif(NOT MODE STREQUAL "alone")
  message(FATAL_ERROR "MODE must be alone or after_asio, not '${MODE}'")
endif()
list(APPEND flags ${usage_flags})

# One unit per header: unit_<n>.cpp.
set(units "")
set(index 0)
foreach(header IN LISTS headers)
  file(WRITE ${SCRATCH}/unit_${index}.cpp "#include <${header}>\n")
  list(APPEND units ${index})
  math(EXPR index "${index} + 1")
endforeach()

# JOBS units at a time: execute_process runs its COMMANDs concurrently (as a pipeline whose stages read and
# write nothing: -fsyntax-only). A unit that fails is compiled again alone for its own message.
set(failed "")
list(LENGTH units count)
set(start 0)
while(start LESS count)
  set(commands "")
  set(batch "")
  foreach(offset RANGE 1 ${JOBS})
    math(EXPR at "${start} + ${offset} - 1")
    if(at LESS count)
      list(APPEND batch ${at})
      list(APPEND commands COMMAND ${CXX} ${flags} -fsyntax-only ${SCRATCH}/unit_${at}.cpp)
    endif()
  endforeach()
  execute_process(${commands} RESULTS_VARIABLE results OUTPUT_QUIET ERROR_QUIET)
  foreach(at result IN ZIP_LISTS batch results)
    if(NOT result EQUAL 0)
      list(GET headers ${at} header)
      execute_process(COMMAND ${CXX} ${flags} -fsyntax-only ${SCRATCH}/unit_${at}.cpp ERROR_VARIABLE err)
      string(SUBSTRING "${err}" 0 1500 err)
      message(SEND_ERROR "${header} (${MODE}) does not compile:\n${err}")
      list(APPEND failed ${header})
    endif()
  endforeach()
  math(EXPR start "${start} + ${JOBS}")
endwhile()
list(LENGTH failed failures)
message(STATUS "${count} headers, ${failures} failed (${MODE})")
file(REMOVE_RECURSE ${SCRATCH})
