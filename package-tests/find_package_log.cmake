# Included by a consumer's first project() (-DCMAKE_PROJECT_TOP_LEVEL_INCLUDES=<this file>): every
# find_package call of its configure, Tether's and the config files' find_dependency included, is appended
# to <build>/find_package.log (one name a line), then handled as usual (the provider fulfils nothing).
function(tether_log_find_package method name)
  file(APPEND ${CMAKE_BINARY_DIR}/find_package.log "${name}\n")
endfunction()
file(REMOVE ${CMAKE_BINARY_DIR}/find_package.log)
cmake_language(SET_DEPENDENCY_PROVIDER tether_log_find_package SUPPORTED_METHODS FIND_PACKAGE)
