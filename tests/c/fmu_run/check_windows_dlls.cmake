# Checks the Windows binaries of the FMUs with mingw-w64 objdump -p:
#   - the export table equals exactly the set of functions the FMI headers of that version declare
#     (FMI2_Export ... fmi2Xxx; / FMI3_Export ... fmi3Xxx;): nothing missing, nothing more (no
#     librrr or glue symbol), every export named;
#   - the DLL imports only system DLLs: KERNEL32.dll, msvcrt.dll, api-ms-win-crt-*.dll (no
#     libgcc_s, libwinpthread or other toolchain runtime).
# Run as: cmake -DOBJDUMP=<x86_64-w64-mingw32-objdump> -DFMI_HEADERS_DIR=<dir>
#               -DFMI2_DLLS=<a.dll>|<b.dll> -DFMI3_DLLS=<c.dll>|<d.dll> -P <this>
# (lists separated by |, so that they pass through a test command line unsplit)

foreach(v OBJDUMP FMI_HEADERS_DIR FMI2_DLLS FMI3_DLLS)
  if(NOT DEFINED ${v} OR "${${v}}" STREQUAL "")
    message(FATAL_ERROR "check_windows_dlls.cmake: -D${v}=... is required")
  endif()
endforeach()

include("${CMAKE_CURRENT_LIST_DIR}/fmi_exports.cmake")

declared_functions("${FMI_HEADERS_DIR}/fmi2Functions.h" 2 expected_2)
declared_functions("${FMI_HEADERS_DIR}/fmi3Functions.h" 3 expected_3)

set(failures "")
foreach(V 2 3)
  string(REPLACE "|" ";" dlls "${FMI${V}_DLLS}")
  list(LENGTH expected_${V} n_expected)
  foreach(dll IN LISTS dlls)
    if(NOT EXISTS "${dll}")
      list(APPEND failures "${dll}: missing")
      continue()
    endif()
    execute_process(COMMAND "${OBJDUMP}" -p "${dll}" OUTPUT_VARIABLE dump ERROR_VARIABLE err
                    RESULT_VARIABLE rc)
    if(NOT rc EQUAL 0)
      list(APPEND failures "${dll}: objdump -p failed (${rc}): ${err}")
      continue()
    endif()

    # exports: the name table ("[Ordinal/Name Pointer] Table", one "[ i] name" per line, up to a
    # blank line) and the number of entries of the address table
    string(FIND "${dump}" "[Ordinal/Name Pointer] Table" at)
    if(at EQUAL -1)
      list(APPEND failures "${dll}: no export name table")
      continue()
    endif()
    string(SUBSTRING "${dump}" ${at} -1 table)
    string(FIND "${table}" "\n\n" stop)
    if(NOT stop EQUAL -1)
      string(SUBSTRING "${table}" 0 ${stop} table)
    endif()
    string(FIND "${table}" "\n" eol)
    if(eol EQUAL -1)
      set(table "")
    else()
      string(SUBSTRING "${table}" ${eol} -1 table) # drop the title line
    endif()
    string(REGEX MATCHALL "\n[ \t]*\\[[ 0-9]+\\][^\n]*" entries "${table}")
    set(exported "")
    foreach(e IN LISTS entries)
      string(REGEX REPLACE "^.*[] \t]([^] \t\r\n]+)[ \t\r]*$" "\\1" n "${e}")
      list(APPEND exported "${n}")
    endforeach()
    list(SORT exported)
    list(LENGTH exported n_exported)
    set(n_address "")
    if(dump MATCHES "Export Address Table[ \t]+([0-9a-fA-F]+)")
      math(EXPR n_address "0x${CMAKE_MATCH_1}")
    endif()

    compare_exports("${dll}" ${V} "${exported}" "${expected_${V}}" failures)
    if(NOT n_exported EQUAL n_expected)
      list(APPEND failures "${dll}: ${n_exported} named exports, ${n_expected} FMI ${V} functions")
    endif()
    if(NOT "${n_address}" STREQUAL "${n_exported}")
      list(APPEND failures
           "${dll}: export address table of '${n_address}' entries for ${n_exported} names")
    endif()

    # imports: system DLLs only
    string(REGEX MATCHALL "DLL Name:[ \t]*[^\r\n]+" imports "${dump}")
    set(imported "")
    set(bad_imports "")
    foreach(i IN LISTS imports)
      string(REGEX REPLACE "DLL Name:[ \t]*([^ \t\r\n]+).*" "\\1" name "${i}")
      list(APPEND imported "${name}")
      string(TOLOWER "${name}" lname)
      if(NOT lname MATCHES "^(kernel32\\.dll|msvcrt\\.dll|api-ms-win-crt-[a-z0-9-]+\\.dll)$")
        list(APPEND bad_imports "${name}")
      endif()
    endforeach()
    if(NOT imported)
      list(APPEND failures "${dll}: no import table found")
    endif()
    if(bad_imports)
      list(APPEND failures "${dll}: imports non-system DLLs: ${bad_imports}")
    endif()
    message(STATUS "${dll}: ${n_exported} exports (FMI ${V}: ${n_expected} functions); "
                   "imports ${imported}")
  endforeach()
endforeach()

if(failures)
  string(REPLACE ";" "\n  " failures "${failures}")
  message(FATAL_ERROR "Windows binaries of the FMUs:\n  ${failures}")
endif()
message(STATUS "Windows binaries: exports = the FMI functions of the headers, system imports only")
