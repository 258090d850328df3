# CTest: both bench nodes over the socketcand transport in lockstep, 300 periods holding a pose
# (run under ASan/UBSan with the rest of the C tests). Python's tests/python/can/test_hil_bench.py
# compares a full writing task with the FMPy co-simulation.
# -DPLANT=... -DCONTROLLER=... -DFMU_DIR=<unzipped plant FMU> -DWORK=<scratch dir>
file(MAKE_DIRECTORY "${WORK}")
set(ref "${WORK}/hold.csv")
file(WRITE "${ref}" "t,q_ref[1],q_ref[2],q_ref[3],qd_ref[1],qd_ref[2],qd_ref[3],qdd_ref[1],qdd_ref[2],qdd_ref[3]\n")
foreach(k RANGE 0 299)
  math(EXPR ms "${k}")
  if(ms LESS 10)
    set(t "0.00${ms}")
  elseif(ms LESS 100)
    set(t "0.0${ms}")
  else()
    set(t "0.${ms}")
  endif()
  file(APPEND "${ref}" "${t},0.2,0.8,-1.2,0,0,0,0,0,0\n")
endforeach()
string(RANDOM LENGTH 4 ALPHABET 0123456789 r)
math(EXPR port "20000 + ${r}")
execute_process(
  COMMAND "${PLANT}" --fmu "${FMU_DIR}" --listen 127.0.0.1:${port} --q0 0.25,0.75,-1.15
          --log "${WORK}/plant.csv"
  COMMAND "${CONTROLLER}" --reference "${ref}" --connect 127.0.0.1:${port}
          --log "${WORK}/controller.csv"
  RESULTS_VARIABLE rcs OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 60)
message("${out}\n${err}")
if(NOT rcs STREQUAL "0;0")
  message(FATAL_ERROR "lockstep bench failed: exit codes (plant;controller) '${rcs}'")
endif()
# each node says how it ended, in one line (tests/c/test_hil_nodes.c: the other endings)
foreach(line "rrr_hil_plant: exit 0 (completed) at period 299: the controller's StopCmd: end of run"
             "rrr_hil_controller: exit 0 (completed) at period 300: all 300 periods of the reference")
  string(FIND "${err}" "${line}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "missing on stderr: '${line}'")
  endif()
endforeach()
file(STRINGS "${WORK}/plant.csv" rows)
list(LENGTH rows n)
if(NOT n EQUAL 301)
  message(FATAL_ERROR "plant log has ${n} lines, expected 301 (header + 300 periods)")
endif()
list(GET rows 300 last)
string(REPLACE "," ";" last "${last}")
list(GET last 2 q1)
list(GET last 12 faults)
if(NOT faults EQUAL 0)
  message(FATAL_ERROR "plant latched faults ${faults}")
endif()
# the PD + feedforward law pulls q1 from 0.25 to 0.2 within 0.3 s
if(q1 GREATER 0.21 OR q1 LESS 0.19)
  message(FATAL_ERROR "q1 = ${q1} after 0.3 s, expected 0.2 +/- 0.01")
endif()
message("lockstep bench: 300 periods, q1 = ${q1}, no faults")
