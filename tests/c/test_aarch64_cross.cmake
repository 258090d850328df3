# CTest aarch64_cross_build: the project cross-built for aarch64 Linux with the toolchain file
# cmake/aarch64-linux-gnu.cmake, as docs/aarch64.md shows it (no Python extension, no tests, no
# Windows binaries): librrr (static and shared), the plant FMU it needs and the CAN bench nodes
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

string(TIMESTAMP t0 "%s")
run(${CMAKE_COMMAND} -S "${SOURCE}" -B "${WORK}" -G "${GENERATOR}"
    "-DCMAKE_TOOLCHAIN_FILE=${SOURCE}/cmake/aarch64-linux-gnu.cmake" -DCMAKE_BUILD_TYPE=Release
    -DRRR_BUILD_PYEXT=OFF -DRRR_BUILD_TESTS=OFF -DRRR_FMU_WINDOWS=OFF
    "-DFMI_HEADERS_DIR=${FMI_HEADERS_DIR}" "-DPython3_EXECUTABLE=${PYTHON}")
run(${CMAKE_COMMAND} --build "${WORK}" -j 2 --target rrr rrr_shared rrr_hil_plant
    rrr_hil_controller)
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
