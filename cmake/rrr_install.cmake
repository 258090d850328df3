# cmake --install: librrr as a CMake package and a pkg-config module.
#
# The targets install themselves where they are defined (c_src/rrr: headers, librrr.so with its
# SONAME and librrr.a; fmu/: every FMU rrr_add_fmu builds, under share/rrr/fmus; c_src/hil: the
# CAN bench nodes and the DBC). This file adds what describes them to a consumer:
#   <libdir>/cmake/rrr/rrrConfig.cmake, rrrConfigVersion.cmake, rrrTargets*.cmake
#       find_package(rrr CONFIG REQUIRED): rrr::rrr (shared), rrr::rrr_static, and the variables
#       rrr_INCLUDE_DIR, rrr_FMU_DIR, rrr_DBC, rrr_HIL_PLANT, rrr_HIL_CONTROLLER
#   <libdir>/pkgconfig/rrr.pc (relocatable: paths relative to the .pc file)
include(CMakePackageConfigHelpers)

set(RRR_INSTALL_CMAKEDIR "${CMAKE_INSTALL_LIBDIR}/cmake/rrr")
set(RRR_INSTALL_FMUDIR "${CMAKE_INSTALL_DATADIR}/rrr/fmus")
set(RRR_INSTALL_DBC "${CMAKE_INSTALL_DATADIR}/rrr/rrr_bench.dbc")
set(RRR_INSTALL_HIL_PLANT "${CMAKE_INSTALL_BINDIR}/rrr_hil_plant")
set(RRR_INSTALL_HIL_CONTROLLER "${CMAKE_INSTALL_BINDIR}/rrr_hil_controller")
# what this build installs (the config sets only the variables of what is there)
set(RRR_HAVE_FMUS ${RRR_BUILD_FMUS})
if(RRR_BUILD_HIL AND RRR_BUILD_FMUS)
  set(RRR_HAVE_HIL ON)
else()
  set(RRR_HAVE_HIL OFF)
endif()

install(EXPORT rrrTargets NAMESPACE rrr:: DESTINATION "${RRR_INSTALL_CMAKEDIR}")
configure_package_config_file(
  "${CMAKE_CURRENT_LIST_DIR}/rrrConfig.cmake.in" "${CMAKE_CURRENT_BINARY_DIR}/rrrConfig.cmake"
  INSTALL_DESTINATION "${RRR_INSTALL_CMAKEDIR}"
  PATH_VARS CMAKE_INSTALL_INCLUDEDIR RRR_INSTALL_FMUDIR RRR_INSTALL_DBC RRR_INSTALL_HIL_PLANT
            RRR_INSTALL_HIL_CONTROLLER)
# 0.x.y: the SONAME is librrr.so.0, and a consumer asking for 0.1 accepts any 0.y >= 0.1
write_basic_package_version_file("${CMAKE_CURRENT_BINARY_DIR}/rrrConfigVersion.cmake"
  VERSION ${PROJECT_VERSION} COMPATIBILITY SameMajorVersion)
install(FILES "${CMAKE_CURRENT_BINARY_DIR}/rrrConfig.cmake"
              "${CMAKE_CURRENT_BINARY_DIR}/rrrConfigVersion.cmake"
        DESTINATION "${RRR_INSTALL_CMAKEDIR}")

# rrr.pc: prefix relative to the installed .pc file, so a tree installed with
# cmake --install --prefix anywhere (or moved) stays right
file(RELATIVE_PATH RRR_PC_TO_PREFIX "/prefix/${CMAKE_INSTALL_LIBDIR}/pkgconfig" "/prefix")
string(REGEX REPLACE "/$" "" RRR_PC_TO_PREFIX "${RRR_PC_TO_PREFIX}")
# Libs: -Wl,-rpath,${libdir} unless RRR_PC_RPATH is OFF, so a program linked with `pkg-config
# --libs rrr` finds librrr.so.0 where it was installed, with no LD_LIBRARY_PATH (a distribution
# that installs into the loader's own path turns it off); and -lm, as the CMake package's
# rrr::rrr links m for its consumers: librrr.so records its own libm (DT_NEEDED) and the headers
# inline nothing, but librrr.a needs it, and so do the consumers that call <math.h> beside
# librrr, as nearly every user of an angle-based API does (examples/c_consumer/main.c: fmax).
option(RRR_PC_RPATH "rrr.pc links consumers with an rpath to the installed librrr" ON)
set(RRR_PC_RPATH_FLAG "")
if(RRR_PC_RPATH)
  set(RRR_PC_RPATH_FLAG " -Wl,-rpath,\${libdir}")
endif()
set(RRR_PC_LIBS_EXTRA "")
if(RRR_SANITIZE)
  set(RRR_PC_LIBS_EXTRA " -fsanitize=address,undefined")
endif()
# Libs.private: what a static link of librrr.a needs beyond -lm (glibc's libmvec under the
# vector kernels of rrr_batch.h; librrr.so records it itself)
get_property(_rrr_simd GLOBAL PROPERTY RRR_SIMD_X86)
set(RRR_PC_LIBS_PRIVATE "")
if(_rrr_simd)
  set(RRR_PC_LIBS_PRIVATE " -lmvec")
endif()
configure_file("${CMAKE_CURRENT_LIST_DIR}/rrr.pc.in" "${CMAKE_CURRENT_BINARY_DIR}/rrr.pc" @ONLY)
install(FILES "${CMAKE_CURRENT_BINARY_DIR}/rrr.pc" DESTINATION "${CMAKE_INSTALL_LIBDIR}/pkgconfig")
