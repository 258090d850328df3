# CMake toolchain file: cross-build the project for 64-bit ARM Linux (aarch64, glibc) with the
# GNU cross toolchain (Debian: apt-get install gcc-aarch64-linux-gnu; its sysroot is
# /usr/aarch64-linux-gnu). docs/aarch64.md has the whole story.
#
#   cmake -S . -B build-aarch64 -DCMAKE_TOOLCHAIN_FILE=cmake/aarch64-linux-gnu.cmake \
#         -DRRR_BUILD_PYEXT=OFF -DRRR_BUILD_TESTS=OFF
#   cmake --build build-aarch64 -j2
#
# gives librrr, the FMUs (binaries/linux64 and binaries/aarch64-linux: this build's only
# platform) and the CAN bench nodes rrr_hil_plant and rrr_hil_controller, all aarch64.
# The FMU build runs two small generators it compiles (the model description and documentation
# writers): with qemu-user installed (Debian: apt-get install qemu-user) CMake runs them under
# qemu-aarch64 (CMAKE_CROSSCOMPILING_EMULATOR, set below), and CTest runs the C tests the same way.
#
# Variables (-D or environment): RRR_AARCH64_PREFIX (default aarch64-linux-gnu-: the compiler is
# <prefix>gcc), RRR_AARCH64_SYSROOT (default /usr/aarch64-linux-gnu: the target's libc, also the
# emulator's -L).
set(CMAKE_SYSTEM_NAME Linux)
set(CMAKE_SYSTEM_PROCESSOR aarch64)

if(NOT RRR_AARCH64_PREFIX)
  if(DEFINED ENV{RRR_AARCH64_PREFIX})
    set(RRR_AARCH64_PREFIX "$ENV{RRR_AARCH64_PREFIX}")
  else()
    set(RRR_AARCH64_PREFIX aarch64-linux-gnu-)
  endif()
endif()
if(NOT RRR_AARCH64_SYSROOT)
  if(DEFINED ENV{RRR_AARCH64_SYSROOT})
    set(RRR_AARCH64_SYSROOT "$ENV{RRR_AARCH64_SYSROOT}")
  else()
    set(RRR_AARCH64_SYSROOT /usr/aarch64-linux-gnu)
  endif()
endif()
# try_compile projects see these too
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES RRR_AARCH64_PREFIX RRR_AARCH64_SYSROOT)

find_program(RRR_AARCH64_GCC NAMES ${RRR_AARCH64_PREFIX}gcc)
if(NOT RRR_AARCH64_GCC)
  message(FATAL_ERROR "cmake/aarch64-linux-gnu.cmake: no ${RRR_AARCH64_PREFIX}gcc on PATH "
                      "(Debian: apt-get install gcc-aarch64-linux-gnu)")
endif()
set(CMAKE_C_COMPILER "${RRR_AARCH64_GCC}")

# the target's headers and libraries from the sysroot only; programs (python, cantools) from the host
set(CMAKE_FIND_ROOT_PATH "${RRR_AARCH64_SYSROOT}")
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

find_program(RRR_QEMU_AARCH64 NAMES qemu-aarch64 qemu-aarch64-static)
if(RRR_QEMU_AARCH64)
  set(CMAKE_CROSSCOMPILING_EMULATOR "${RRR_QEMU_AARCH64};-L;${RRR_AARCH64_SYSROOT}")
endif()
