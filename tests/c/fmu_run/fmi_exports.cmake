# declared_functions(<header> <2|3> <out var>): the functions an FMI header declares for export
# (FMI2_Export ... fmi2Xxx; / FMI3_Export ... fmi3Xxx;), sorted. Included by the checks of the
# Windows and the aarch64 binaries. Comments in the header are removed first.
function(declared_functions header prefix out)
  if(NOT EXISTS "${header}")
    message(FATAL_ERROR "no FMI header ${header}")
  endif()
  file(READ "${header}" text)
  string(REGEX REPLACE "/\\*([^*]|\\*+[^*/])*\\*+/" "" text "${text}")
  string(REPLACE ";" "<semicolon>" text "${text}") # a ';' in a match would split the list
  string(REGEX MATCHALL "FMI${prefix}_Export[ \t\r\n]+fmi${prefix}[A-Za-z0-9_]+TYPE[ \t\r\n]+fmi${prefix}[A-Za-z0-9_]+[ \t\r\n]*<semicolon>"
         decls "${text}")
  set(names "")
  foreach(d IN LISTS decls)
    string(REGEX REPLACE "^.*[ \t\r\n](fmi${prefix}[A-Za-z0-9_]+)[ \t\r\n]*<semicolon>$" "\\1" n "${d}")
    list(APPEND names "${n}")
  endforeach()
  list(REMOVE_DUPLICATES names)
  list(LENGTH names count)
  if(count LESS 10)
    message(FATAL_ERROR "found only ${count} FMI${prefix}_Export declarations in ${header}")
  endif()
  list(SORT names)
  set(${out} "${names}" PARENT_SCOPE)
endfunction()
