# CMake toolchain file: build with Zig's C compiler (the Python package ziglang) for a chosen CPU
# and glibc version, from any Linux host: the portable wheels of scripts/dist.sh
# (docs/getting-started.md, "From the release folder").
#
#   cmake -S . -B build-zig -DCMAKE_TOOLCHAIN_FILE=cmake/zig.cmake \
#         -DRRR_ZIG_TARGET=aarch64-linux-gnu.2.17 -DRRR_BUILD_TESTS=OFF
#
# zig links against stubs of the glibc version named in the target, so the binaries need nothing
# newer than it, whatever the build machine's glibc. Every Linux binary is built by the one zig:
# librrr, the extension, the bench nodes, the FMUs and their aarch64 binaries (RRR_AARCH64_CC
# defaults to zig for aarch64 Linux); the FMUs' Windows binaries stay mingw-w64's (RRR_MINGW_CC:
# zig would put its .pdb and import library beside each DLL, and link the UCRT, not msvcrt).
#
# Variables (-D or environment):
#   RRR_ZIG_TARGET  zig's -target (default x86_64-linux-gnu.2.17)
#   RRR_ZIG         the zig executable (default: zig on PATH, else ziglang's in python3)
#   RRR_ZIG_SYSROOT for a foreign CPU: the target's C library, where qemu-user finds the loader
#                   when the build runs its generators (default /usr/<arch>-linux-gnu, the
#                   Debian cross toolchain's)
foreach(v RRR_ZIG_TARGET RRR_ZIG RRR_ZIG_SYSROOT)
  if(NOT ${v} AND DEFINED ENV{${v}})
    set(${v} "$ENV{${v}}")
  endif()
endforeach()
if(NOT RRR_ZIG_TARGET)
  set(RRR_ZIG_TARGET x86_64-linux-gnu.2.17)
endif()
if(NOT RRR_ZIG)
  find_program(RRR_ZIG_ON_PATH zig)
  if(RRR_ZIG_ON_PATH)
    set(RRR_ZIG "${RRR_ZIG_ON_PATH}")
  else()
    execute_process(COMMAND python3 -c
                    "import ziglang, os; print(os.path.join(os.path.dirname(ziglang.__file__), 'zig'))"
                    OUTPUT_VARIABLE RRR_ZIG OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  endif()
endif()
if(NOT RRR_ZIG OR NOT EXISTS "${RRR_ZIG}")
  message(FATAL_ERROR "cmake/zig.cmake: no zig (pip install ziglang, or set RRR_ZIG to the zig "
                      "executable)")
endif()
# kept for the re-runs of CMake that the build starts
set(RRR_ZIG "${RRR_ZIG}" CACHE FILEPATH "the zig executable")
set(RRR_ZIG_TARGET "${RRR_ZIG_TARGET}" CACHE STRING "zig's -target")
string(REGEX MATCH "^[^-]+" _rrr_zig_arch "${RRR_ZIG_TARGET}")
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES RRR_ZIG_TARGET RRR_ZIG RRR_ZIG_SYSROOT
     RRR_ZIG_WRAPPERS)

# One small script per tool: CMake wants a program per compiler and archiver, zig is one program
# with subcommands. Written once, in the top build folder (try_compile gets its path).
if(NOT RRR_ZIG_WRAPPERS)
  set(RRR_ZIG_WRAPPERS "${CMAKE_BINARY_DIR}/zig-wrappers")
  # the FMUs' aarch64 binaries: aarch64 Linux, the same glibc. zig ships its own compiler-rt: it
  # ignores -static-libgcc, which the FMU builds pass for gcc (unused-argument warnings)
  string(REGEX REPLACE "^[^-]+" "aarch64" _rrr_zig_a64 "${RRR_ZIG_TARGET}")
  set(_rrr_zig_cc "cc -Wno-unused-command-line-argument -target")
  foreach(pair "cc|${_rrr_zig_cc} ${RRR_ZIG_TARGET}" "ar|ar" "ranlib|ranlib"
          "cc-aarch64|${_rrr_zig_cc} ${_rrr_zig_a64}")
    string(REPLACE "|" ";" pair "${pair}")
    list(GET pair 0 name)
    list(GET pair 1 args)
    file(WRITE "${RRR_ZIG_WRAPPERS}/tmp/zig-${name}" "#!/bin/sh\nexec \"${RRR_ZIG}\" ${args} \"$@\"\n")
    file(COPY "${RRR_ZIG_WRAPPERS}/tmp/zig-${name}" DESTINATION "${RRR_ZIG_WRAPPERS}"
         FILE_PERMISSIONS OWNER_READ OWNER_WRITE OWNER_EXECUTE GROUP_READ GROUP_EXECUTE
                          WORLD_READ WORLD_EXECUTE)
  endforeach()
  file(REMOVE_RECURSE "${RRR_ZIG_WRAPPERS}/tmp")
endif()
set(CMAKE_C_COMPILER "${RRR_ZIG_WRAPPERS}/zig-cc")
set(CMAKE_AR "${RRR_ZIG_WRAPPERS}/zig-ar" CACHE FILEPATH "zig ar")
set(CMAKE_RANLIB "${RRR_ZIG_WRAPPERS}/zig-ranlib" CACHE FILEPATH "zig ranlib")
if(NOT _rrr_zig_arch STREQUAL "aarch64")
  set(RRR_AARCH64_CC "${RRR_ZIG_WRAPPERS}/zig-cc-aarch64" CACHE FILEPATH "zig cc for aarch64")
endif()
# No contraction into fused multiply-adds (clang contracts within expressions by default, and
# aarch64 has FMA): the same results on every CPU (docs/aarch64.md)
set(CMAKE_C_FLAGS_INIT "-ffp-contract=off")
# libm is zig's stub of the target glibc, linked by name (find_library would find the host's)
set(RRR_LIBM m CACHE STRING "libm (zig: by name)")
set(RRR_HIL_LIBM m CACHE STRING "libm (zig: by name)")

string(TOLOWER "${CMAKE_HOST_SYSTEM_PROCESSOR}" _rrr_host_arch)
if(_rrr_host_arch STREQUAL "amd64")
  set(_rrr_host_arch x86_64)
elseif(_rrr_host_arch STREQUAL "arm64")
  set(_rrr_host_arch aarch64)
endif()
if(NOT _rrr_zig_arch STREQUAL _rrr_host_arch)
  set(CMAKE_SYSTEM_NAME Linux)
  set(CMAKE_SYSTEM_PROCESSOR ${_rrr_zig_arch})
  # the build runs two generators it compiles (fmu/CMakeLists.txt): under qemu-user
  if(NOT RRR_ZIG_SYSROOT)
    set(RRR_ZIG_SYSROOT "/usr/${_rrr_zig_arch}-linux-gnu")
  endif()
  find_program(RRR_ZIG_QEMU NAMES qemu-${_rrr_zig_arch} qemu-${_rrr_zig_arch}-static)
  if(NOT RRR_ZIG_QEMU)
    message(FATAL_ERROR "cmake/zig.cmake: building for ${_rrr_zig_arch} runs the FMUs' generators "
                        "under qemu-${_rrr_zig_arch} (Debian: apt-get install qemu-user)")
  endif()
  set(CMAKE_CROSSCOMPILING_EMULATOR "${RRR_ZIG_QEMU};-L;${RRR_ZIG_SYSROOT}")
endif()
