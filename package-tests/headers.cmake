# cmake -DPREFIX=... -DCXX=... -DSCRATCH=... -DMODE=alone|after_asio -P headers.cmake
# Compiles every installed public header in a translation unit of its own: alone (it includes what it
# uses), or after <boost/asio.hpp> (include order does not matter; <utility> goes first because Boost 1.74's
# asio.hpp misses it under C++20 on g++ 12), with the project's warnings as errors.
file(GLOB_RECURSE headers RELATIVE ${PREFIX}/include ${PREFIX}/include/tether/*.hpp)
# *_impl.hpp hold template definitions their header includes at its end; they are not included alone.
list(FILTER headers EXCLUDE REGEX "^tether/proxy_messages/|_impl\\.hpp$")
file(REMOVE_RECURSE ${SCRATCH})
file(MAKE_DIRECTORY ${SCRATCH})
set(failed "")
foreach(header IN LISTS headers)
  if(MODE STREQUAL "after_asio")
    set(text "#include <utility>\n#include <boost/asio.hpp>\n#include <${header}>\n")
  else()
    set(text "#include <${header}>\n")
  endif()
  file(WRITE ${SCRATCH}/tu.cpp "${text}")
  execute_process(COMMAND ${CXX} -std=c++20 -fsyntax-only -Wall -Wextra -Wconversion -Wsign-conversion -Wshadow
    -Werror -DBOOST_ASIO_NO_DEPRECATED -I${PREFIX}/include -isystem ${PREFIX}/include/tether/proxy_messages
    ${SCRATCH}/tu.cpp RESULT_VARIABLE result ERROR_VARIABLE err)
  if(NOT result EQUAL 0)
    string(SUBSTRING "${err}" 0 1500 err)
    message(SEND_ERROR "${header} (${MODE}) does not compile:\n${err}")
    list(APPEND failed ${header})
  endif()
endforeach()
list(LENGTH headers count)
list(LENGTH failed failures)
message(STATUS "${count} headers, ${failures} failed (${MODE})")
file(REMOVE_RECURSE ${SCRATCH})
