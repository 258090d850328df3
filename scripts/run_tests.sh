#!/usr/bin/env bash
# Sets up everything and runs every test: C tests (core, FMUs, CAN bench) under AddressSanitizer
# and UndefinedBehaviorSanitizer via CTest (with the FMUs' Windows binaries run under wine, their
# aarch64 Linux binaries and the aarch64 bench nodes under qemu-user), the same CTest on the
# README's default build (Release), ruff,
# the Python package's import layers (lint-imports) and types (mypy), pytest (including the
# generated-code checks, the CAN bench over SocketCAN in a QEMU guest), and short libFuzzer runs
# on the CAN frame decoders, on forged FMU states (each FMU) and on the FMU importer's scanner. mingw-w64, wine,
# gcc-aarch64-linux-gnu, qemu-user, chromium and clang are installed with apt-get when missing
# and root.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
export RRR_PIP_TARGET=".[test,bench,docs]"
# The Windows binaries of the FMUs are cross-compiled with mingw-w64 and tested under wine: both
# must be present before the FMUs are built (by pip install below and by CMake).
windows_tools_ok() {
  command -v x86_64-w64-mingw32-gcc >/dev/null 2>&1 && command -v wine >/dev/null 2>&1
}
if ! windows_tools_ok; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "== installing gcc-mingw-w64-x86-64 and wine (Windows binaries of the FMUs) =="
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq \
      gcc-mingw-w64-x86-64 wine >/dev/null
  fi
  if ! windows_tools_ok; then
    echo "the FMU tests need the mingw-w64 cross compiler and wine (Debian: apt-get install" \
         "gcc-mingw-w64-x86-64 wine)" >&2
    exit 1
  fi
fi
# The aarch64 Linux binaries of the FMUs are cross-compiled with gcc-aarch64-linux-gnu and run
# under qemu-user (with the cross toolchain's sysroot) against x86-64, as are the bench nodes
# (docs/aarch64.md): both before the FMUs are built.
aarch64_tools_ok() {
  command -v aarch64-linux-gnu-gcc >/dev/null 2>&1 && command -v qemu-aarch64 >/dev/null 2>&1 &&
    [ -e /usr/aarch64-linux-gnu/lib/ld-linux-aarch64.so.1 ]
}
if ! aarch64_tools_ok; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "== installing gcc-aarch64-linux-gnu and qemu-user (aarch64 binaries of the FMUs) =="
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq gcc-aarch64-linux-gnu qemu-user >/dev/null
  fi
  if ! aarch64_tools_ok; then
    echo "the aarch64 tests need the cross compiler and qemu-user (Debian: apt-get install" \
         "gcc-aarch64-linux-gnu qemu-user)" >&2
    exit 1
  fi
fi
# pkg-config: the installed-tree test (CTest install_tree) checks `pkg-config --libs rrr`
if ! command -v pkg-config >/dev/null 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq pkg-config >/dev/null
fi
# The SocketCAN tests (tests/python/test_socketcan_guest.py, docs/socketcan.md) boot a QEMU guest
# with Debian's kernel (AF_CAN, vcan): can_guest.py installs qemu-system-x86, busybox-static,
# cpio and can-utils with apt-get when missing and root, and downloads the kernel package into
# ~/.cache/rrr-can-guest (never installed); it names what is missing otherwise.
echo "== the SocketCAN test guest: tools, kernel, initramfs (tests/python/can_guest.py) =="
python3 tests/python/can_guest.py prepare
# chromium: tests/python/test_view.py opens the page of `rrr view` in headless Chromium
if ! command -v chromium >/dev/null 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  echo "== installing chromium (the browser view's test, headless) =="
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends chromium >/dev/null
fi
# doxygen: the manual's C API page (docs/api/c.md) is Doxygen's reading of librrr's headers
if ! command -v doxygen >/dev/null 2>&1 && [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
  echo "== installing doxygen (the manual's C API page) =="
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends doxygen >/dev/null
fi
# shellcheck disable=SC1091
. scripts/setup_env.sh
JOBS="$(nproc 2>/dev/null || echo 2)"
# The benchmark's C++ driver (one Pinocchio translation unit: about 2 min of CPU) builds in the
# background at the lowest priority while the tests below run, in a process group of its own
# (stopped with this script); bench/run_bench.py --quick uses it at the end.
mkdir -p build-bench
echo "== building bench/run_bench.py's C++ driver in the background (nice 19, build-bench/) =="
setsid nice -n 19 python bench/run_bench.py --build-only --werror --build-dir build-bench \
  > build-bench/build.log 2>&1 &
BENCH_BUILD=$!
trap 'kill -- "-$BENCH_BUILD" 2>/dev/null || true' EXIT
echo "== C tests under ASan + UBSan =="
# warnings are errors in every build of the test command (RRR_WERROR; off in a user's build)
cmake -S . -B build-asan -DRRR_SANITIZE=ON -DRRR_WERROR=ON -DCMAKE_BUILD_TYPE=Debug \
  -DPython3_EXECUTABLE="$(command -v python)"
cmake --build build-asan -j "$JOBS"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure -j "$JOBS"
echo "== the README's CMake build (default type: Release, tests on) and its CTest =="
cmake -S . -B build-release -DRRR_WERROR=ON -DPython3_EXECUTABLE="$(command -v python)"
cmake --build build-release -j "$JOBS"
ctest --test-dir build-release --output-on-failure -j "$JOBS"
echo "== ruff, lint-imports, mypy =="
ruff check python tests bench tools c_src/rrr/gen
# the layers of the Python package (pyproject.toml [tool.importlinter]), checked on the rrr_robot
# that setup_env.sh has just installed from this tree
lint-imports
mypy python/rrr_robot
echo "== the manual: sphinx-build with warnings as errors (docs/ -> build-docs/index.html) =="
# a broken link or anchor, an unresolved reference or a page outside the navigation fails it
sphinx-build -q -W --keep-going -n -b html docs build-docs
echo "== pytest (with every block of README.md and docs/: tests/python/test_doc_blocks.py) =="
python -m pytest -q --durations=25 tests/python
# the release folder (sdist, wheels, FMU bundle) built with zig and checked, then installed and
# run as a user would: scripts/test_dist.sh (docs/getting-started.md, "From the release folder")
bash scripts/test_dist.sh
echo "== every bench script's quick mode (bench/: they print their tables; no number is checked) =="
if ! wait "$BENCH_BUILD"; then
  cat build-bench/build.log >&2
  echo "the benchmark's C++ driver did not build (build-bench/build.log above)" >&2
  exit 1
fi
python bench/run_bench.py --quick --skip-build --build-dir build-bench
for script in bench/bench_*.py; do
  echo "-- python $script --quick"
  python "$script" --quick
done
echo "== libFuzzer on the CAN frame decoders (short run; docs/can-bench.md has the long one) =="
fuzzer_ok() {
  command -v clang >/dev/null 2>&1 && [ -e "$(clang -print-file-name=libclang_rt.fuzzer-x86_64.a)" ]
}
if ! fuzzer_ok; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq clang >/dev/null
    # libFuzzer ships in the compiler-rt package of the same major version as clang
    CLANG_MAJOR="$(clang -dumpversion | cut -d. -f1)"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "libclang-rt-${CLANG_MAJOR}-dev" >/dev/null
  fi
  if ! fuzzer_ok; then
    echo "the fuzz run needs clang with libFuzzer (Debian: apt-get install clang" \
         "libclang-rt-<clang major>-dev); everything else above passed" >&2
    exit 1
  fi
fi
cmake -S . -B build-fuzz -DCMAKE_C_COMPILER=clang -DRRR_HIL_FUZZ=ON -DRRR_FMU_FUZZ=ON \
  -DRRR_BUILD_TESTS=OFF -DRRR_WERROR=ON -DRRR_FMU_WINDOWS=OFF -DRRR_FMU_AARCH64=OFF \
  -DCMAKE_BUILD_TYPE=Debug -DPython3_EXECUTABLE="$(command -v python)" >/dev/null
cmake --build build-fuzz --target fuzz_hil_decode fuzz_fmu_state fuzz_fmi_import fuzz_hil_canopen \
  -j "$JOBS"
mkdir -p build-fuzz/corpus
build-fuzz/c_src/hil/fuzz_hil_decode -max_total_time="${RRR_FUZZ_SECONDS:-30}" -max_len=96 \
  -print_final_stats=1 build-fuzz/corpus c_src/hil/fuzz/seeds 2>&1 | tail -n 12
echo "== libFuzzer on the CANopen slave: frame and time sequences through one node (short run) =="
mkdir -p build-fuzz/corpus_canopen
build-fuzz/c_src/hil/fuzz_hil_canopen -max_total_time="${RRR_CANOPEN_FUZZ_SECONDS:-15}" \
  -max_len=600 -print_final_stats=1 build-fuzz/corpus_canopen 2>&1 | tail -n 4
echo "== libFuzzer on forged FMU states with valid checksums (each FMU, FMI 2 and 3; short run) =="
for model in $(cat build-fuzz/fmus/fmu_names.txt); do  # the FMUs, as fmu/CMakeLists.txt lists them
  mkdir -p "build-fuzz/corpus_$model"
  build-fuzz/fmu/fuzz_fmu_state_$model -max_total_time="${RRR_FMU_FUZZ_SECONDS:-15}" -max_len=89 \
    -print_final_stats=1 "build-fuzz/corpus_$model" 2>&1 | tail -n 4
done
echo "== libFuzzer on the FMI-LS-BUS network FMUs: forged FMU states, hostile Rx_Data values =="
# (fmu/CMakeLists.txt builds both targets for each node; docs/ls-bus.md). 5 s each, 20 s in all:
# the LS-BUS tests' share of the test command stays near 2 minutes. Both CTests drive the same
# targets without libFuzzer: lsbus_rx_smoke_* (every hostile kind of operation, cut at every
# byte) and fmu_state_fuzz_*_can (every state word forged)
for model in controller_can plant_can; do
  mkdir -p "build-fuzz/corpus_$model" "build-fuzz/corpus_lsbus_rx_$model"
  build-fuzz/fmu/fuzz_fmu_state_$model -max_total_time="${RRR_LSBUS_FUZZ_SECONDS:-5}" \
    -max_len=89 -print_final_stats=1 "build-fuzz/corpus_$model" 2>&1 | tail -n 4
  build-fuzz/fmu/fuzz_lsbus_rx_$model -max_total_time="${RRR_LSBUS_FUZZ_SECONDS:-5}" \
    -max_len=4096 -print_final_stats=1 "build-fuzz/corpus_lsbus_rx_$model" 2>&1 | tail -n 4
done
echo "== libFuzzer on the FMU importer's modelDescription scanner (c_src/fmi_import; short run) =="
mkdir -p build-fuzz/corpus_fmi_import
for xml in fmu/*/modelDescription.xml; do
  cp "$xml" "build-fuzz/corpus_fmi_import/$(basename "$(dirname "$xml")").xml"
done
build-fuzz/c_src/fmi_import/fuzz_fmi_import -max_total_time="${RRR_FMI_FUZZ_SECONDS:-15}" \
  -max_len=65536 -print_final_stats=1 build-fuzz/corpus_fmi_import 2>&1 | tail -n 4
echo "== all test stages passed (CTest twice, ruff, lint-imports, mypy, the manual, pytest, the" \
     "benchmarks' quick modes, libFuzzer) =="
