# CMake toolchain file: bare-metal Arm Cortex-M with the GNU Arm Embedded toolchain and picolibc
# (Debian: apt-get install gcc-arm-none-eabi picolibc-arm-none-eabi). It builds the firmware of
# c_src/firmware (docs/microcontroller.md has the whole story):
#
#   cmake -S c_src/firmware -B build-firmware     # this file is the project's default
#   cmake --build build-firmware -j2
#
# The CPU and FPU flags are per target (c_src/firmware/CMakeLists.txt: one image per core);
# here only what every image shares: Thumb code, picolibc's C library and no start files (the
# firmware has its own startup and linker script).
#
# Variables (-D or environment): RRR_ARM_PREFIX (default arm-none-eabi-: the compiler is
# <prefix>gcc).
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

if(NOT RRR_ARM_PREFIX)
  if(DEFINED ENV{RRR_ARM_PREFIX})
    set(RRR_ARM_PREFIX "$ENV{RRR_ARM_PREFIX}")
  else()
    set(RRR_ARM_PREFIX arm-none-eabi-)
  endif()
endif()
list(APPEND CMAKE_TRY_COMPILE_PLATFORM_VARIABLES RRR_ARM_PREFIX)

find_program(RRR_ARM_GCC NAMES ${RRR_ARM_PREFIX}gcc)
if(NOT RRR_ARM_GCC)
  message(FATAL_ERROR "cmake/arm-none-eabi.cmake: no ${RRR_ARM_PREFIX}gcc on PATH "
                      "(Debian: apt-get install gcc-arm-none-eabi picolibc-arm-none-eabi)")
endif()
set(CMAKE_C_COMPILER "${RRR_ARM_GCC}")
find_program(RRR_ARM_SIZE NAMES ${RRR_ARM_PREFIX}size)

# a bare-metal program cannot be linked without its startup: CMake's compiler check builds a
# static library instead
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)
set(CMAKE_C_FLAGS_INIT "-specs=picolibc.specs -mthumb")
# (CMake links with CMAKE_C_FLAGS too: picolibc.specs comes from there)
set(CMAKE_EXE_LINKER_FLAGS_INIT "-nostartfiles")

set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
