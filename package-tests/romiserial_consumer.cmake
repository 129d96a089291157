# cmake -DSTEP=... -P romiserial_consumer.cmake: RomiSerial's C++ programs (examples/cpp-romiserial: Blink
# and AnalogRead, as a RomiSerial user has them) built against the install prefix with find_package(Tether)
# and no source change, then run on virtual boards of the prefix's `tether sim`.
#   STEP=build  configure + build SOURCE/examples/cpp-romiserial against PREFIX into BINARY (the compiler
#               and sanitizer flags of this build, CXX_FLAGS/LINKER_FLAGS: the installed libraries carry them)
#   STEP=run    each program on `tether sim <image>` (PREFIX's command and images), a bounded loop
include(${CMAKE_CURRENT_LIST_DIR}/run-checked.cmake)

if(STEP STREQUAL "build")
  file(REMOVE_RECURSE ${BINARY})
  set(configure ${CMAKE_COMMAND} -S ${SOURCE}/examples/cpp-romiserial -B ${BINARY} -G "Unix Makefiles"
    -DCMAKE_CXX_COMPILER=${CXX} "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${LINKER_FLAGS}"
    -DCMAKE_PREFIX_PATH=${PREFIX})
  if(LAUNCHER)
    list(APPEND configure -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER})
  endif()
  run_checked(${configure})
  run_checked(${CMAKE_COMMAND} --build ${BINARY} -j2)
elseif(STEP STREQUAL "run")
  # The board runs in the background for the program's time: `tether sim` prints `PTY <path>` once its
  # port is ready; the shell waits for that (30 s at most), runs the program, then stops the board.
  set(run_on_board [[
image=$1; shift
"$TETHER" sim "$image" > "$SIM_OUTPUT" 2>&1 &
sim=$!
port=
for i in $(seq 300); do
  port=$(sed -n 's/^PTY //p' "$SIM_OUTPUT")
  [ -n "$port" ] && break
  kill -0 $sim 2>/dev/null || break
  sleep 0.1
done
if [ -z "$port" ]; then
  echo "tether sim $image gave no port:"; cat "$SIM_OUTPUT"; kill $sim 2>/dev/null; exit 3
fi
"$@" "$port"
status=$?
kill $sim; wait $sim
exit $status
]])
  set(ENV{TETHER} ${PREFIX}/bin/tether)
  set(ENV{TETHER_FIRMWARE_DIR} "")  # the prefix's images
  foreach(example blink:romi-blink analogread:romi-analogread)
    string(REPLACE ":" ";" example ${example})
    list(GET example 0 program)
    list(GET example 1 image)
    set(ENV{SIM_OUTPUT} ${BINARY}/${image}.sim)
    # Programs take <port> [iterations [delay-ms]]: the port comes last from the shell, so a small wrapper
    # puts the bounded loop after it.
    file(WRITE ${BINARY}/${program}-bounded.sh "exec \"${BINARY}/${program}_app\" \"$1\" 3 20\n")
    execute_process(COMMAND sh -c "${run_on_board}" run_on_board ${image} sh ${BINARY}/${program}-bounded.sh
      RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 120)
    message(STATUS "${program}_app on ${image}: exit ${result}\n${out}${err}")
    if(NOT result EQUAL 0)
      message(SEND_ERROR "${program}_app failed on the virtual ${image}")
    endif()
    set(run_${program} "${out}")
  endforeach()
  string(REGEX MATCHALL "Sensor value: [0-9]+\n" values "${run_analogread}")
  list(LENGTH values count)
  if(NOT count EQUAL 3)
    message(SEND_ERROR "analogread_app printed ${count} sensor values, not 3: '${run_analogread}'")
  endif()
else()
  message(FATAL_ERROR "unknown STEP '${STEP}'")
endif()
