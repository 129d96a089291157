# run_checked(command args...): runs the command; its exit status other than 0 fails the script, with the
# command line and everything it printed. Included by the package tests' scripts.
function(run_checked)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT result EQUAL 0)
    list(JOIN ARGN " " command)
    message(FATAL_ERROR "${command}: exit ${result}\n${out}")
  endif()
endfunction()
