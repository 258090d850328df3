# CTest install_tree: cmake --install of this build into a fresh prefix, then what a downstream
# user does with it: examples/c_consumer configured with find_package(rrr CONFIG REQUIRED)
# (CMAKE_PREFIX_PATH), built against rrr::rrr and rrr::rrr_static and run; the same program
# compiled with the flags of `pkg-config --cflags --libs rrr` (PKG_CONFIG_PATH) and run.
# Arguments: -DBUILD=<this build> -DSOURCE=<source tree> -DWORK=<scratch folder> -DCC=<compiler>
#            -DGENERATOR=<generator> -DPKG_CONFIG=<pkg-config> -DREADELF=<readelf>
#            -DVERSION=<x.y.z> -DSOVERSION=<x> -DFMU_NAMES=<name>|<name>|... (RRR_FMU_NAMES)
cmake_minimum_required(VERSION 3.16)
foreach(v BUILD SOURCE WORK CC GENERATOR VERSION SOVERSION FMU_NAMES)
  if(NOT DEFINED ${v})
    message(FATAL_ERROR "test_install_tree.cmake: -D${v}=... missing")
  endif()
endforeach()
set(prefix "${WORK}/prefix")
file(REMOVE_RECURSE "${WORK}")
file(MAKE_DIRECTORY "${WORK}")

function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    string(REPLACE ";" " " cmd "${ARGN}")
    message(FATAL_ERROR "failed (${rc}): ${cmd}\n${out}\n${err}")
  endif()
  set(run_out "${out}" PARENT_SCOPE)
endfunction()

run(${CMAKE_COMMAND} --install "${BUILD}" --prefix "${prefix}")

# what the prefix holds; the library's libdir is lib (GNUInstallDirs below /usr/local or another
# prefix that is not /usr)
set(libdir "${prefix}/lib")
string(REPLACE "|" ";" fmu_names "${FMU_NAMES}")
set(fmus share/rrr/fmus/fmu_names.txt)
foreach(name IN LISTS fmu_names)
  list(APPEND fmus share/rrr/fmus/rrr_${name}.fmu share/rrr/fmus/fmi3/rrr_${name}.fmu)
endforeach()
list(LENGTH fmu_names n_fmus)
foreach(f include/rrr/rrr.h include/rrr/rrr_kinematics.h
          lib/librrr.a lib/librrr.so lib/librrr.so.${SOVERSION} lib/librrr.so.${VERSION}
          lib/cmake/rrr/rrrConfig.cmake lib/cmake/rrr/rrrConfigVersion.cmake
          lib/cmake/rrr/rrrTargets.cmake lib/pkgconfig/rrr.pc ${fmus}
          share/rrr/rrr_bench.dbc share/rrr/rrr_cia402.eds bin/rrr_hil_plant bin/rrr_hil_controller)
  if(NOT EXISTS "${prefix}/${f}")
    message(FATAL_ERROR "cmake --install did not install ${f}")
  endif()
endforeach()
foreach(link librrr.so librrr.so.${SOVERSION})
  if(NOT IS_SYMLINK "${libdir}/${link}")
    message(FATAL_ERROR "${link} is not a symbolic link")
  endif()
endforeach()
if(NOT READELF)
  message(FATAL_ERROR "readelf not found (binutils)")
endif()
run(${READELF} -d "${libdir}/librrr.so.${VERSION}")
string(REGEX MATCH "Library soname: \\[([^]]*)\\]" _ "${run_out}")
set(soname "${CMAKE_MATCH_1}")
if(NOT soname STREQUAL "librrr.so.${SOVERSION}")
  message(FATAL_ERROR "SONAME of librrr.so.${VERSION} is '${soname}', not librrr.so.${SOVERSION}")
endif()
message(STATUS "installed: librrr.so.${VERSION} (SONAME ${soname}), librrr.a, headers, "
               "rrrConfig.cmake, rrr.pc, ${n_fmus} FMUs (FMI 2.0 and 3.0) and their list "
               "fmu_names.txt, the CAN bench nodes and the DBC")

# the downstream CMake project
set(consumer "${WORK}/consumer")
run(${CMAKE_COMMAND} -S "${SOURCE}/examples/c_consumer" -B "${consumer}" -G "${GENERATOR}"
    -DCMAKE_C_COMPILER=${CC} -DCMAKE_BUILD_TYPE=Release "-DCMAKE_PREFIX_PATH=${prefix}")
if(NOT run_out MATCHES "FMUs in ${prefix}/share/rrr/fmus")
  message(FATAL_ERROR "the package does not name its FMU folder:\n${run_out}")
endif()
run(${CMAKE_COMMAND} --build "${consumer}")
foreach(exe rrr_consumer rrr_consumer_static)
  run("${consumer}/${exe}")
  message(STATUS "${exe}: ${run_out}")
  if(NOT run_out MATCHES "librrr ${VERSION}: .* 4 IK branches")
    message(FATAL_ERROR "${exe} printed: ${run_out}")
  endif()
endforeach()
# the shared one loads librrr.so.0 from the prefix
run(ldd "${consumer}/rrr_consumer")
if(NOT run_out MATCHES "librrr.so.${SOVERSION} => ${libdir}/librrr.so.${SOVERSION}")
  message(FATAL_ERROR "rrr_consumer does not load the installed librrr.so.${SOVERSION}:\n${run_out}")
endif()

# pkg-config
if(NOT PKG_CONFIG)
  message(FATAL_ERROR "pkg-config not found (Debian: apt-get install pkg-config)")
endif()
set(ENV{PKG_CONFIG_PATH} "${libdir}/pkgconfig")
run(${PKG_CONFIG} --modversion rrr)
string(STRIP "${run_out}" modversion)
if(NOT modversion STREQUAL VERSION)
  message(FATAL_ERROR "pkg-config --modversion rrr: '${modversion}', expected ${VERSION}")
endif()
run(${PKG_CONFIG} --libs rrr)
string(STRIP "${run_out}" libs)
run(${PKG_CONFIG} --cflags rrr)
string(STRIP "${run_out}" cflags)
message(STATUS "pkg-config --cflags --libs rrr: ${cflags} ${libs}")
if(NOT libs MATCHES "-lrrr")
  message(FATAL_ERROR "pkg-config --libs rrr: '${libs}'")
endif()
# librrr.so records its own libm; rrr.pc gives -lm too (for librrr.a and for the consumer's
# own <math.h> calls, as rrr::rrr does)
run(${READELF} -d "${libdir}/librrr.so.${VERSION}")
if(NOT run_out MATCHES "NEEDED[^\n]*libm\\.so")
  message(FATAL_ERROR "librrr.so does not record libm as NEEDED:\n${run_out}")
endif()
if(NOT libs MATCHES "-lrrr -lm")
  message(FATAL_ERROR "pkg-config --libs rrr has no -lm after -lrrr: ${libs}")
endif()

# the documented pkg-config lines (README or docs/: the ```bash block that runs `pkg-config
# --cflags --libs rrr` and builds examples/c_consumer/main.c; docs/c-library.md first), run
# exactly as written by sh, with the prefix it installed into ($HOME/rrr or /opt/rrr) replaced
# by this prefix,
# in a folder with examples/c_consumer/main.c and no LD_LIBRARY_PATH: the rpath of rrr.pc
# finds librrr.so.0
set(block "")
file(GLOB_RECURSE docs "${SOURCE}/docs/*.md")
list(SORT docs)
list(REMOVE_ITEM docs "${SOURCE}/docs/c-library.md")
foreach(doc "${SOURCE}/docs/c-library.md" ${docs} "${SOURCE}/README.md")
  file(READ "${doc}" text)
  string(REGEX MATCH "```bash\n(([^`]|`[^`])*pkg-config --cflags --libs rrr\\) -o ([^`]|`[^`])*)```"
         _ "${text}")
  if(CMAKE_MATCH_1)
    set(block "${CMAKE_MATCH_1}")
    set(block_doc "${doc}")
    break()
  endif()
endforeach()
if(NOT block)
  message(FATAL_ERROR "no ```bash block with `pkg-config --cflags --libs rrr` in README.md or "
                      "docs/")
endif()
if(NOT block MATCHES "examples/c_consumer/main.c")
  message(FATAL_ERROR "the pkg-config block of ${block_doc} does not build examples/c_consumer")
endif()
# pkg-config writes a blank of the prefix as "\ ", which a shell's $(pkg-config ...) does not
# undo: a build folder with blanks (a clone in "My projects") gives the block a link to the
# prefix from a folder without
set(block_prefix "${prefix}")
if(prefix MATCHES "[ \t]")
  set(tmp "$ENV{TMPDIR}")
  if(tmp STREQUAL "" OR tmp MATCHES "[ \t]")
    set(tmp "/tmp")
  endif()
  string(RANDOM LENGTH 12 tag)
  set(block_prefix "${tmp}/rrr-install-tree-${tag}")
  file(CREATE_LINK "${prefix}" "${block_prefix}" SYMBOLIC)
endif()
if(block MATCHES "\\$HOME/rrr")
  string(REPLACE "$HOME/rrr" "${block_prefix}" script "${block}")
elseif(block MATCHES "/opt/rrr")
  string(REPLACE "/opt/rrr" "${block_prefix}" script "${block}")
else()
  message(FATAL_ERROR "the pkg-config block of ${block_doc} uses neither $HOME/rrr nor /opt/rrr")
endif()
set(demo "${WORK}/demo")
file(MAKE_DIRECTORY "${demo}/examples/c_consumer")
file(COPY "${SOURCE}/examples/c_consumer/main.c" DESTINATION "${demo}/examples/c_consumer")
file(WRITE "${demo}/doc_block.sh" "set -e\n${script}")
unset(ENV{LD_LIBRARY_PATH})
unset(ENV{PKG_CONFIG_PATH})
execute_process(COMMAND sh doc_block.sh WORKING_DIRECTORY "${demo}" RESULT_VARIABLE rc
                OUTPUT_VARIABLE run_out ERROR_VARIABLE err)
if(NOT block_prefix STREQUAL prefix)
  file(REMOVE "${block_prefix}")
endif()
if(NOT rc EQUAL 0 OR NOT run_out MATCHES "librrr ${VERSION}: .* 4 IK branches")
  message(FATAL_ERROR "the pkg-config block of ${block_doc} failed (${rc}):\n${block}\n"
                      "${run_out}\n${err}")
endif()
message(STATUS "the pkg-config block of ${block_doc}: ${run_out}")
