# CTest aarch64_cross_build: the project cross-built for aarch64 Linux with the toolchain file
# cmake/aarch64-linux-gnu.cmake by the commands of docs/aarch64.md (no Python extension, no
# tests, no Windows binaries): librrr (static and shared), the plant FMU it needs and the nodes
# rrr_hil_plant and rrr_hil_controller. Checks that each is AArch64 code and prints the glibc
# symbol versions the nodes need. The nodes then run the lockstep bench under qemu-aarch64
# (CTest hil_lockstep_aarch64, tests/c/hil_bench_compare.py).
# Arguments: -DSOURCE=<source tree> -DWORK=<cross build dir> -DGENERATOR=<generator>
#            -DREADELF=<readelf> -DFMI_HEADERS_DIR=<dir> -DPYTHON=<python>
cmake_minimum_required(VERSION 3.16)
foreach(v SOURCE WORK GENERATOR READELF FMI_HEADERS_DIR PYTHON)
  if(NOT DEFINED ${v} OR "${${v}}" STREQUAL "")
    message(FATAL_ERROR "test_aarch64_cross.cmake: -D${v}=... missing")
  endif()
endforeach()

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "failed (${rc}): ${cmd}\n${out}\n${err}")
  endif()
  set(run_out "${out}" PARENT_SCOPE)
endfunction()

# the two commands of docs/aarch64.md ("cmake -S . -B build-aarch64 ..." and the next line),
# run in the source tree with build-aarch64 -> WORK, plus this build's generator, FMI headers
# and Python
file(READ "${SOURCE}/docs/aarch64.md" doc)
string(FIND "${doc}" "cmake -S . -B build-aarch64" at)
if(at EQUAL -1)
  message(FATAL_ERROR "docs/aarch64.md: no 'cmake -S . -B build-aarch64' command")
endif()
string(SUBSTRING "${doc}" ${at} -1 block)
string(FIND "${block}" "```" stop)
string(SUBSTRING "${block}" 0 ${stop} block)
string(REPLACE "\\\n" " " block "${block}")
# a console block: the commands are the lines after "$ " (the first one's is before "cmake -S")
string(REPLACE "\n$ " "\n" block "${block}")
string(STRIP "${block}" block)
string(REPLACE "\n" ";" commands "${block}")
list(LENGTH commands n)
if(NOT n EQUAL 2)
  message(FATAL_ERROR "docs/aarch64.md: expected 2 commands (configure, build), found ${n}")
endif()
list(GET commands 0 configure)
list(GET commands 1 build)
foreach(c configure build)
  message(STATUS "docs/aarch64.md: ${${c}}")
  separate_arguments(${c} UNIX_COMMAND "${${c}}")
  list(TRANSFORM ${c} REPLACE "^build-aarch64$" "${WORK}")
  list(POP_FRONT ${c} exe)
  if(NOT exe STREQUAL "cmake")
    message(FATAL_ERROR "docs/aarch64.md: '${exe}' is not cmake")
  endif()
endforeach()
string(TIMESTAMP t0 "%s")
execute_process(COMMAND ${CMAKE_COMMAND} ${configure} -G "${GENERATOR}"
                "-DFMI_HEADERS_DIR=${FMI_HEADERS_DIR}" "-DPython3_EXECUTABLE=${PYTHON}"
                WORKING_DIRECTORY "${SOURCE}" RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configure failed (${rc}):\n${out}\n${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} ${build} WORKING_DIRECTORY "${SOURCE}"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "build failed (${rc}):\n${out}\n${err}")
endif()
string(TIMESTAMP t1 "%s")
math(EXPR seconds "${t1} - ${t0}")

foreach(f c_src/rrr/librrr.a c_src/rrr/librrr.so c_src/hil/rrr_hil_plant
          c_src/hil/rrr_hil_controller fmu/fmi2/rrr_plant/binaries/linux64/rrr_plant.so)
  if(NOT EXISTS "${WORK}/${f}")
    message(FATAL_ERROR "the cross build made no ${f}")
  endif()
  run(${READELF} -h "${WORK}/${f}")
  string(REGEX MATCHALL "Machine:[^\n]*" machines "${run_out}")
  list(REMOVE_DUPLICATES machines)
  list(LENGTH machines n)
  if(NOT n EQUAL 1 OR NOT machines MATCHES "^Machine:[ \t]+AArch64$")
    message(FATAL_ERROR "${f}: ${machines}, expected AArch64 only")
  endif()
endforeach()
foreach(node rrr_hil_plant rrr_hil_controller)
  run(${READELF} --dyn-syms -W "${WORK}/c_src/hil/${node}")
  string(REGEX MATCHALL "@GLIBC_[0-9.]+" vs "${run_out}")
  list(REMOVE_DUPLICATES vs)
  list(SORT vs)
  string(REPLACE "@GLIBC_" "" vs "${vs}")
  message(STATUS "${node} (aarch64) needs GLIBC ${vs}")
endforeach()
message(STATUS "aarch64 cross build (librrr, plant FMU, bench nodes) in ${seconds} s: ${WORK}")
