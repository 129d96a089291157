# cmake -DSTEP=... -P deb.cmake: Tether's Debian packages, made and used as a packager and a user would.
#   STEP=build     configure SOURCE into BINARY as a packager does (Release, prefix /usr, Debian's -O2 and
#                  hardening flags from dpkg-buildflags, no tests or benchmarks), build it, `cpack -G DEB` (CPACK)
#   STEP=lintian   lintian on each package: no errors; its warnings are printed
#   STEP=unpacked  `dpkg -x` the packages into SCRATCH (never dpkg -i: installed headers would shadow the
#                  tree's) and check: they hold exactly what `cmake --install` installs, the man page covers
#                  every command, the unpacked `tether` runs `--version` and `demo --iterations 20`, and
#                  Debian's python3 imports the unpacked `tether` module and calls a virtual board with it,
#                  from another folder with the build's images hidden, opening nothing in the build or
#                  source tree
# Skipped (the message says why) when dpkg-deb or lintian is missing: tools/setup installs both.
foreach(tool dpkg-deb lintian)
  find_program(found_${tool} ${tool})
  if(NOT found_${tool})
    message("package test skipped: ${tool} not found (Debian package ${tool}; tools/setup installs it)")
    return()
  endif()
endforeach()

function(run_checked)
  cmake_parse_arguments(RUN "" "WORKING_DIRECTORY;OUTPUT" "" ${ARGN})
  if(NOT RUN_WORKING_DIRECTORY)
    set(RUN_WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR})
  endif()
  execute_process(COMMAND ${RUN_UNPARSED_ARGUMENTS} WORKING_DIRECTORY ${RUN_WORKING_DIRECTORY}
    RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE out)
  if(NOT result EQUAL 0)
    list(JOIN RUN_UNPARSED_ARGUMENTS " " command)
    message(FATAL_ERROR "${command}: exit ${result}\n${out}")
  endif()
  if(RUN_OUTPUT)
    set(${RUN_OUTPUT} "${out}" PARENT_SCOPE)
  endif()
endfunction()

set(packages_dir ${BINARY}/packages)
set(expected_packages tether tether-firmware libtether-dev python3-tether)

if(STEP STREQUAL "build")
  # What Debian's packaging helpers pass: -O2 and the hardening flags (stack protector, fortify, relro,
  # bindnow), less -g (cpack strips, and there is no -dbgsym package). The Release build type adds only
  # -DNDEBUG here, not its -O3: Debian builds its packages at -O2, and this build, the suite's longest
  # test, takes a fifth less CPU at -O2.
  set(ENV{DEB_BUILD_MAINT_OPTIONS} "hardening=+all")
  foreach(kind CFLAGS CXXFLAGS CPPFLAGS LDFLAGS)
    set(ENV{DEB_${kind}_STRIP} "-g")
    execute_process(COMMAND dpkg-buildflags --get ${kind} OUTPUT_VARIABLE flags_${kind}
      OUTPUT_STRIP_TRAILING_WHITESPACE WORKING_DIRECTORY ${SOURCE})
  endforeach()
  # Unity batches (TETHER_UNITY_BUILD, as tools/setup test's build): the same code compiled in about a
  # third less CPU time; this build is the suite's longest test.
  set(configure ${CMAKE_COMMAND} -S ${SOURCE} -B ${BINARY} -G "Unix Makefiles" -DCMAKE_BUILD_TYPE=Release
    -DCMAKE_C_FLAGS_RELEASE=-DNDEBUG -DCMAKE_CXX_FLAGS_RELEASE=-DNDEBUG
    -DCMAKE_INSTALL_PREFIX=/usr -DTETHER_BUILD_TESTS=OFF -DTETHER_BUILD_BENCHMARKS=OFF -DTETHER_SANITIZE=OFF
    -DTETHER_UNITY_BUILD=ON
    -DCMAKE_CXX_COMPILER=${CXX} -DTETHER_NANOPB_SOURCE_DIR=${NANOPB}
    "-DCMAKE_C_FLAGS=${flags_CFLAGS} ${flags_CPPFLAGS}" "-DCMAKE_CXX_FLAGS=${flags_CXXFLAGS} ${flags_CPPFLAGS}"
    "-DCMAKE_EXE_LINKER_FLAGS=${flags_LDFLAGS}" "-DCMAKE_MODULE_LINKER_FLAGS=${flags_LDFLAGS}"
    "-DCMAKE_SHARED_LINKER_FLAGS=${flags_LDFLAGS}")
  if(LAUNCHER)
    list(APPEND configure -DCMAKE_CXX_COMPILER_LAUNCHER=${LAUNCHER} -DCMAKE_C_COMPILER_LAUNCHER=${LAUNCHER})
  endif()
  run_checked(${configure})
  run_checked(${CMAKE_COMMAND} --build ${BINARY} -j2)
  file(REMOVE_RECURSE ${packages_dir})
  run_checked(${CPACK} -G DEB WORKING_DIRECTORY ${BINARY} OUTPUT out)
  message(STATUS "${out}")
  foreach(package IN LISTS expected_packages)
    file(GLOB deb ${packages_dir}/${package}_*.deb)
    if(NOT deb)
      message(FATAL_ERROR "cpack made no ${package}_*.deb in ${packages_dir} (python3-tether needs pybind11-dev "
        "and python3-dev: tools/setup installs them)")
    endif()
    execute_process(COMMAND dpkg-deb --info ${deb} OUTPUT_VARIABLE info)
    message(STATUS "${deb}:\n${info}")
  endforeach()
  file(GLOB deb ${packages_dir}/tether-firmware_*_all.deb)
  if(NOT deb)
    message(SEND_ERROR "tether-firmware is not an Architecture: all package")
  endif()
  # The command's runtime libraries come from dpkg-shlibdeps; its images from tether-firmware.
  file(GLOB deb ${packages_dir}/tether_*.deb)
  execute_process(COMMAND dpkg-deb --field ${deb} Depends OUTPUT_VARIABLE depends)
  foreach(library libprotobuf libedit libelf libsimavr libstdc "tether-firmware \\(= ${VERSION}\\)")
    if(NOT depends MATCHES "${library}")
      message(SEND_ERROR "tether's Depends names no ${library} package: ${depends}")
    endif()
  endforeach()
  # The module loads in the one Python version it was built for: Depends pins Debian's python3 to it.
  execute_process(COMMAND /usr/bin/python3 -c "import sys; print('%d.%d' % sys.version_info[:2])"
    OUTPUT_VARIABLE python_version OUTPUT_STRIP_TRAILING_WHITESPACE)
  file(GLOB deb ${packages_dir}/python3-tether_*.deb)
  execute_process(COMMAND dpkg-deb --field ${deb} Depends OUTPUT_VARIABLE depends)
  foreach(library libprotobuf libelf libsimavr libstdc "python3 \\(>= ${python_version}~\\)" "python3 \\(<< ")
    if(NOT depends MATCHES "${library}")
      message(SEND_ERROR "python3-tether's Depends names no ${library}: ${depends}")
    endif()
  endforeach()
elseif(STEP STREQUAL "lintian")
  file(GLOB debs ${packages_dir}/*.deb)
  if(NOT debs)
    message(FATAL_ERROR "no packages in ${packages_dir} (package.deb_build makes them)")
  endif()
  execute_process(COMMAND lintian --fail-on error ${debs} RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE out)
  message(STATUS "lintian ${debs}: exit ${result}\n${out}")
  if(NOT result EQUAL 0 OR out MATCHES "(^|\n)E: ")
    message(SEND_ERROR "lintian reports errors")
  endif()
elseif(STEP STREQUAL "unpacked")
  file(REMOVE_RECURSE ${SCRATCH})
  set(root ${SCRATCH}/root)
  file(MAKE_DIRECTORY ${root})
  foreach(package IN LISTS expected_packages)
    file(GLOB deb ${packages_dir}/${package}_*.deb)
    if(NOT deb)
      message(FATAL_ERROR "no ${package}_*.deb in ${packages_dir} (package.deb_build makes it)")
    endif()
    run_checked(dpkg-deb -x ${deb} ${root})
  endforeach()

  # Nothing installed is left out of the packages, and they hold nothing else.
  foreach(component tether firmware dev python)
    run_checked(${CMAKE_COMMAND} --install ${BINARY} --prefix ${SCRATCH}/installed/usr --component ${component})
  endforeach()
  file(GLOB_RECURSE packaged RELATIVE ${root} LIST_DIRECTORIES false ${root}/*)
  file(GLOB_RECURSE installed RELATIVE ${SCRATCH}/installed LIST_DIRECTORIES false ${SCRATCH}/installed/*)
  list(SORT packaged)
  list(SORT installed)
  if(NOT packaged STREQUAL installed)
    set(only_packaged ${packaged})
    list(REMOVE_ITEM only_packaged ${installed})
    set(only_installed ${installed})
    list(REMOVE_ITEM only_installed ${packaged})
    message(SEND_ERROR "the packages differ from `cmake --install`:\nonly packaged: ${only_packaged}\n"
      "only installed: ${only_installed}")
  endif()
  foreach(file usr/bin/tether usr/share/man/man1/tether.1.gz usr/share/tether/firmware/romi-test.hex
      usr/share/tether/firmware/proxy.elf usr/share/doc/tether/copyright usr/share/doc/tether/changelog.gz
      usr/share/doc/libtether-dev/copyright usr/share/doc/tether-firmware/changelog.gz
      usr/include/tether/romi/client.hpp usr/include/tether/client/client_link.hpp
      usr/share/tether/examples/rover-service/CMakeLists.txt
      usr/lib/python3/dist-packages/tether/__init__.py usr/lib/python3/dist-packages/tether/py.typed
      usr/lib/python3/dist-packages/tether/__init__.pyi usr/lib/python3/dist-packages/tether/romi.pyi
      usr/share/doc/python3-tether/copyright)
    if(NOT EXISTS ${root}/${file})
      message(SEND_ERROR "not in the packages: /${file}")
    endif()
  endforeach()
  file(GLOB_RECURSE pc_files ${root}/usr/lib/*/tether-romi.pc)
  if(NOT pc_files)
    message(SEND_ERROR "tether-romi.pc is not in the multiarch library folder (/usr/lib/<triplet>/pkgconfig)")
  endif()

  # The man page: every command of `tether --help` with its own help.
  set(tether ${root}/usr/bin/tether)
  run_checked(gzip -dc ${root}/usr/share/man/man1/tether.1.gz OUTPUT page)
  run_checked(${tether} --help OUTPUT usage)
  string(REGEX MATCHALL "\n  [a-z][a-z-]*  " names "${usage}")
  foreach(name IN LISTS names)
    string(STRIP "${name}" name)
    if(NOT page MATCHES "\n\\.SS ${name}\n")
      message(SEND_ERROR "the man page has no section for `tether ${name}`")
    endif()
  endforeach()

  # The unpacked command, run from elsewhere, with the build's images out of the way: it must use its own.
  set(ENV{TETHER_FIRMWARE_DIR} "")
  set(elsewhere ${SCRATCH}/elsewhere)
  file(MAKE_DIRECTORY ${elsewhere})
  run_checked(${tether} --version WORKING_DIRECTORY ${elsewhere} OUTPUT out)
  if(NOT out STREQUAL "tether ${VERSION}\n")
    message(SEND_ERROR "unpacked tether --version: '${out}' (expected 'tether ${VERSION}')")
  endif()
  execute_process(COMMAND ${tether} call --virtual no-such-image e WORKING_DIRECTORY ${elsewhere}
    OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE result)
  if(NOT err MATCHES "${root}/usr/share/tether/firmware/no-such-image\\.elf")
    message(SEND_ERROR "the unpacked tether looks for its images elsewhere: exit ${result}, '${err}'")
  endif()

  # The unpacked Python package, imported by Debian's python3 from the unpacked dist-packages, calls a
  # virtual board running the unpacked romi-test image.
  set(dist_packages ${root}/usr/lib/python3/dist-packages)
  file(WRITE ${elsewhere}/romi_call.py [[
import sys
import tether
module = tether.__file__
if not module.startswith(sys.argv[1]):
    sys.exit("tether imported from %s, not from the unpacked package %s" % (module, sys.argv[1]))
with tether.VirtualUno("romi-test") as board:
    # What is checked is the package (its module, its images), not timing: the run is under strace, on a
    # real-time board whose simulated time goes on while a loaded machine holds this process, so the call
    # gets windows no stall of the host reaches.
    with tether.romi.Client(board.port, boot_wait=0, attempt_timeout=10.0, call_budget=30.0) as client:
        print("romi-test e ->", client.call("e"))
        print("firmware", tether.firmware_dir())
]])

  # Each run happens with the build's images out of the way (it must use its own), under strace when
  # there is one: every path it names (opened, stat'ed, executed, ...) outside its unpacked files must be
  # in neither the build nor the source tree, and it must open an image of the package.
  find_program(strace strace)
  if(NOT strace)
    message(STATUS "strace not found: files opened by the unpacked programs not checked")
  endif()
  set(hidden ${BINARY}/firmware.hidden-by-package-test)
  function(run_unpacked id name)  # id: the strace file's name
    set(command ${ARGN})
    set(trace ${SCRATCH}/${id}.strace)
    if(strace)
      set(command ${strace} -f --seccomp-bpf -qq -s 4096 -e trace=%file -o ${trace} ${command})
    endif()
    file(RENAME ${BINARY}/firmware ${hidden})
    execute_process(COMMAND ${command} WORKING_DIRECTORY ${elsewhere} RESULT_VARIABLE result
      OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 300)
    file(RENAME ${hidden} ${BINARY}/firmware)
    message(STATUS "unpacked ${name}: exit ${result}\n${out}${err}")
    if(NOT result EQUAL 0)
      message(FATAL_ERROR "the unpacked ${name} failed")
    endif()
    set(run_output "${out}" PARENT_SCOPE)
    if(NOT strace)
      return()
    endif()
    # (grep: strace's lines hold brackets, which CMake lists do not take apart reliably.)
    run_checked(grep -o "\"/[^\"]*\"" ${trace} OUTPUT paths)
    string(REPLACE "\"" "" paths "${paths}")
    string(REPLACE "\n" ";" paths "${paths}")
    set(touched)
    foreach(path IN LISTS paths)
      cmake_path(IS_PREFIX SCRATCH "${path}" NORMALIZE in_scratch)
      cmake_path(IS_PREFIX SOURCE "${path}" NORMALIZE in_source)
      cmake_path(IS_PREFIX BINARY "${path}" NORMALIZE in_binary)
      # The folders on the way to the scratch folder (Python looks at each part of its paths) hold nothing.
      cmake_path(IS_PREFIX path "${SCRATCH}" NORMALIZE above_scratch)
      if(NOT in_scratch AND NOT above_scratch AND (in_source OR in_binary))
        list(APPEND touched "${path}")
      endif()
    endforeach()
    if(touched)
      list(REMOVE_DUPLICATES touched)
      list(JOIN touched "\n" touched)
      message(SEND_ERROR "the unpacked ${name} touched the build or source tree:\n${touched}")
    endif()
    file(STRINGS ${trace} images REGEX "${root}/usr/share/tether/firmware/[a-z-]+\\.elf")
    if(NOT images)
      message(SEND_ERROR "the unpacked ${name} opened no image of the package (strace: ${trace})")
    endif()
  endfunction()

  run_unpacked(demo "tether demo --iterations 20" ${tether} demo --iterations 20)
  set(ENV{PYTHONPATH} ${dist_packages})
  run_unpacked(python "Python package (romi call on a virtual board)"
    /usr/bin/python3 ${elsewhere}/romi_call.py ${dist_packages})
  unset(ENV{PYTHONPATH})
  if(NOT run_output MATCHES "romi-test e -> \\[0, 1, 2\\]\nfirmware ${root}/usr/share/tether/firmware\n")
    message(SEND_ERROR "the unpacked Python package's romi call answered: ${run_output}")
  endif()
else()
  message(FATAL_ERROR "unknown STEP '${STEP}'")
endif()
