# cmake -DGENERATED=<xml> -DCOMMITTED=<xml> [-DSTRICT=ON] -P check_xml.cmake
# Warns (or fails with STRICT) when the committed modelDescription.xml differs from the one the
# variable table generates. The FMU always ships the generated one.
if(NOT EXISTS "${COMMITTED}")
  set(_diff TRUE)
else()
  file(READ "${GENERATED}" _gen)
  file(READ "${COMMITTED}" _com)
  string(COMPARE NOTEQUAL "${_gen}" "${_com}" _diff)
endif()
if(_diff)
  set(_msg "${COMMITTED} is out of date with the variable table (generated: ${GENERATED}). "
           "Run: cmake --build <build> --target rrr_fmu_update_xml")
  if(STRICT)
    message(FATAL_ERROR ${_msg})
  else()
    message(WARNING ${_msg})
  endif()
endif()
