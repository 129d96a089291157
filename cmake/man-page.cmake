# cmake -DTETHER=<tether binary> -DHELP2MAN=<help2man> -DGZIP=<gzip> -DFIRMWARE_DIR=<installed images>
#       -DDOC_DIR=<installed docs> -DOUTPUT=<tether.1.gz> -P man-page.cmake
# The man page of `tether`, made at build time from the binary's own help, so it cannot drift from it:
# help2man turns `tether --help` and `--version` into NAME, SYNOPSIS and DESCRIPTION; every command of that
# list gets its `tether COMMAND --help` text in a COMMANDS section.
function(run_checked output_variable)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT result EQUAL 0)
    list(JOIN ARGN " " command)
    message(FATAL_ERROR "man page: '${command}' failed (${result}): ${err}")
  endif()
  set(${output_variable} "${out}" PARENT_SCOPE)
endfunction()

# Plain text as roff that prints it unchanged: backslashes escaped, no line read as a request.
function(roff_literal text output_variable)
  string(REPLACE "\\" "\\e" text "${text}")
  string(REGEX REPLACE "(^|\n)([.'])" "\\1\\\\&\\2" text "${text}")
  set(${output_variable} "${text}" PARENT_SCOPE)
endfunction()

# The commands: the lines "  NAME  summary" after "commands:" in `tether --help`.
run_checked(usage ${TETHER} --help)
string(FIND "${usage}" "\ncommands:\n" at)
if(at EQUAL -1)
  message(FATAL_ERROR "man page: `tether --help` lists no commands:\n${usage}")
endif()
string(SUBSTRING "${usage}" ${at} -1 listing)
string(REGEX MATCHALL "\n  [a-z][a-z-]*  " names "${listing}")
if(NOT names)
  message(FATAL_ERROR "man page: no command names in `tether --help`:\n${usage}")
endif()

set(include "[COMMANDS]\nEach command's options, as `tether COMMAND --help` prints them.\n")
foreach(name IN LISTS names)
  string(STRIP "${name}" name)
  run_checked(help ${TETHER} ${name} --help)
  if(help STREQUAL "")
    message(FATAL_ERROR "man page: `tether ${name} --help` printed nothing on stdout")
  endif()
  roff_literal("${help}" help)
  string(APPEND include ".SS ${name}\n.nf\n${help}.fi\n")
endforeach()
string(APPEND include "[FILES]\n.TP\n.I ${FIRMWARE_DIR}\n"
  "The AVR images (.elf and .hex) that \\fB\\-\\-virtual\\fR, \\fBsim\\fR and \\fBflash\\fR name without a path.\n"
  "[SEE ALSO]\n\\fBavrdude\\fR(1). ${DOC_DIR}/README.md, and the protocols and configuration schema in ${DOC_DIR}.\n")

get_filename_component(scratch ${OUTPUT} DIRECTORY)
file(WRITE ${scratch}/tether.h2m "${include}")
run_checked(ignored ${HELP2MAN} --no-info --section 1
  "--name=messages between a robot's computer and its AVR boards (Romi, proxy, Elcano)"
  --include ${scratch}/tether.h2m --output ${scratch}/tether.1 ${TETHER})
# Debian's man pages are gzip -9 without a timestamp (reproducible).
file(REMOVE ${OUTPUT})
run_checked(ignored ${GZIP} -9nf ${scratch}/tether.1)
