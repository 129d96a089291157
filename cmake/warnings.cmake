# The project's own warning set; applied to every target of ours, host and AVR alike.
set(TETHER_WARNING_FLAGS -Wall -Wextra -Werror -Wconversion -Wsign-conversion -Wshadow)
function(tether_warnings target)
  target_compile_options(${target} PRIVATE ${TETHER_WARNING_FLAGS})
endfunction()
