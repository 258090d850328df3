#!/usr/bin/env bash
# Sets up everything and runs every test, each stage once. In the foreground: pytest in two workers
# (including the generated-code checks, every block of README.md and docs/), and beside it a second
# pytest session with the CAN bench's cases over SocketCAN in a QEMU guest (marker vm). Beside them,
# in the background at a lower priority, each in its own build folder: the release folder
# (scripts/test_dist.sh: the sdist, the wheels and the FMU bundle built with zig, checked, installed
# without a compiler; it starts first, beside the install of .venv); the C tests (core, FMUs, CAN
# bench) under AddressSanitizer and UndefinedBehaviorSanitizer via CTest; ruff, the Python package's
# import layers (lint-imports) and types (mypy); the README's default build (Release) with the CTest
# tests of what that build changes or alone builds (label release: the install tree, the optimised
# kernels, the librrr symbol check, the documented aarch64 cross build, the FMUs' Windows binaries
# under wine and aarch64 binaries under qemu-user); the manual (sphinx, warnings as errors); every
# bench script's quick mode; short libFuzzer runs on the CAN frame decoders, the CANopen slave,
# forged FMU states (each FMU) and the FMU importer's scanner. Each background stage logs to
# build-logs/<stage>.log, printed when the foreground stage ends (a failure is named at once); the
# wall time and CPU time of each stage and the total are printed at the end, and how busy the
# machine was meanwhile. mingw-w64, wine, gcc-aarch64-linux-gnu, qemu-user, chromium, clang, the
# SocketCAN guest's tools and (by scripts/test_pil.sh) the controller firmware's gcc-arm-none-eabi,
# picolibc-arm-none-eabi and qemu-system-arm are installed with apt-get when missing and root.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
export RRR_PIP_TARGET=".[test,bench,docs]"

# ---- stage bookkeeping: wall times, background stages in process groups of their own ---------
T_ALL=$SECONDS
busy_jiffies() {  # the machine's busy CPU time so far, in clock ticks (every process)
  awk '/^cpu / { print $2 + $3 + $4 + $7 + $8 + $9 }' /proc/stat 2>/dev/null || echo 0
}
BUSY0=$(busy_jiffies)
TIMES=""
BG_NAMES=()
BG_FNS=()
BG_PIDS=()
BG_T0=()
LOGS="$ROOT/build-logs"
CPU_SUM=0
record() {  # NAME WALL_SECONDS CPU_SECONDS
  TIMES+="$(printf '%6d s %6s s  %s' "$2" "$3" "$1")"$'\n'
  [[ ! "$3" =~ ^[0-9]+$ ]] || CPU_SUM=$((CPU_SUM + $3))
}
children_cpu() {  # VAR: VAR = the CPU seconds (user + system) of this shell's finished children
  local f
  f=$(mktemp)
  times > "$f"  # in this shell: a subshell would count its own children (none)
  printf -v "$1" '%s' "$(awk 'NR == 2 { s = 0; for (i = 1; i <= 2; i++) { split($i, a, /[ms]/);
                                s += a[1] * 60 + a[2] }; printf "%d", s + 0.5 }' "$f")"
  rm -f "$f"
}
report() {
  local rc=$? pid
  for pid in "${BG_PIDS[@]}"; do
    [ -n "$pid" ] && kill -- "-$pid" 2>/dev/null || true
  done
  printf '== wall time and CPU time (user + system) of each stage ==\n  wall      CPU\n'
  printf '%s%6d s %6s s  total (exit %d)\n' "$TIMES" $((SECONDS - T_ALL)) "$CPU_SUM" "$rc"
  local hz
  hz=$(getconf CLK_TCK 2>/dev/null || echo 100)
  printf 'the machine meanwhile (every process): %d s of CPU busy of %d s on %d cores\n' \
    $((($(busy_jiffies) - BUSY0) / hz)) $((SECONDS - T_ALL)) "$(nproc 2>/dev/null || echo 1)"
}
trap report EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
measured() {  # NAME COMMAND...: run it, record its wall and CPU time; its exit status
  local name=$1 t0=$SECONDS rc=0 cpu="?"
  shift
  mkdir -p "$LOGS"
  rm -f "$LOGS/foreground.cpu"
  # in a subshell of its own: this shell's count would also take in the background stages
  # that end meanwhile
  ( trap 'children_cpu c; echo "$c" > "$LOGS/foreground.cpu"' EXIT; "$@" ) || rc=$?
  [ ! -s "$LOGS/foreground.cpu" ] || read -r cpu < "$LOGS/foreground.cpu"
  record "$name" $((SECONDS - t0)) "$cpu"
  return "$rc"
}
stage() {  # NAME COMMAND...: one stage in the foreground (its failure ends the test command)
  echo "== $1 =="
  measured "$@"
  poll_background
}
FAILED=()
last_stage() {  # NAME COMMAND...: the last foreground stage; the background stages are still
  # waited for and printed when it fails
  local rc=0
  echo "== $1 =="
  measured "$@" || rc=$?
  [ "$rc" = 0 ] || FAILED+=("$1 (exit $rc)")
}
background() {  # NAME NICENESS FUNCTION: a stage in the background, its output in its log
  local name=$1 niceness=$2 fn=$3
  mkdir -p "$LOGS"
  echo "== $name: started in the background (log: build-logs/$fn.log) =="
  rm -f "$LOGS/$fn.seconds"
  # its log is printed when the foreground stage ends; a failure is named on stderr (fd 3) at once
  setsid nice -n "$niceness" bash -c 'stage_main "$@"' _ "$name" "$fn" "$LOGS" \
    3>&2 > "$LOGS/$fn.log" 2>&1 &
  BG_NAMES+=("$name")
  BG_FNS+=("$fn")
  BG_PIDS+=("$!")
  BG_T0+=("$SECONDS")
}
stage_main() {  # NAME FUNCTION LOGS: the body of a background stage (its own bash)
  set -euo pipefail
  # its own wall time and CPU time, passed or failed; a failure is named on stderr at once
  trap "rc=\$?; children_cpu cpu; echo \$SECONDS \$cpu > $(printf %q "$3/$2.seconds");
        [ \"\$rc\" = 0 ] || echo $(printf %q "== $1 FAILED: build-logs/$2.log ==") >&3" EXIT
  "$2"
}
finish_background() {  # INDEX: wait for it, print its log, fail the test command if it failed
  local i=$1 name=${BG_NAMES[$1]} fn=${BG_FNS[$1]} rc=0
  wait "${BG_PIDS[i]}" || rc=$?
  BG_PIDS[i]=""
  local secs=$((SECONDS - BG_T0[i])) cpu="?"  # its own count when it got to the end
  [ ! -s "$LOGS/$fn.seconds" ] || read -r secs cpu < "$LOGS/$fn.seconds"
  echo "== $name (background stage) took $secs s, exit $rc; its log: =="
  cat "$LOGS/$fn.log" || true
  echo "== end of the log of $name =="
  record "$name (background)" "$secs" "$cpu"
  [ "$rc" = 0 ] || FAILED+=("$name (exit $rc, build-logs/$fn.log)")
}
poll_background() {  # print the stages that have ended meanwhile
  local i
  for i in "${!BG_PIDS[@]}"; do
    if [ -n "${BG_PIDS[i]}" ] && ! kill -0 "${BG_PIDS[i]}" 2>/dev/null; then
      finish_background "$i"
    fi
  done
}
wait_background() {
  local i
  for i in "${!BG_PIDS[@]}"; do
    [ -z "${BG_PIDS[i]}" ] || finish_background "$i"
  done
}

# ---- the tools: apt-get installs (all before any stage runs: one dpkg at a time) -------------
apt_ok() { [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; }
APT_UPDATED=0
apt_install() {  # PACKAGE...
  if [ "$APT_UPDATED" = 0 ]; then
    apt-get update -qq
    APT_UPDATED=1
  fi
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "$@" >/dev/null
}
tools() {
  # The Windows binaries of the FMUs are cross-compiled with mingw-w64 and tested under wine:
  # both must be present before the FMUs are built (by pip install below and by CMake).
  windows_tools_ok() {
    command -v x86_64-w64-mingw32-gcc >/dev/null 2>&1 && command -v wine >/dev/null 2>&1
  }
  if ! windows_tools_ok; then
    if apt_ok; then
      echo "== installing gcc-mingw-w64-x86-64 and wine (Windows binaries of the FMUs) =="
      apt_install gcc-mingw-w64-x86-64 wine
    fi
    if ! windows_tools_ok; then
      echo "the FMU tests need the mingw-w64 cross compiler and wine (Debian: apt-get install" \
           "gcc-mingw-w64-x86-64 wine)" >&2
      exit 1
    fi
  fi
  # The aarch64 Linux binaries of the FMUs are cross-compiled with gcc-aarch64-linux-gnu and
  # run under qemu-user (with the cross toolchain's sysroot) against x86-64, as are the bench
  # nodes (docs/aarch64.md): both before the FMUs are built.
  aarch64_tools_ok() {
    command -v aarch64-linux-gnu-gcc >/dev/null 2>&1 && command -v qemu-aarch64 >/dev/null 2>&1 &&
      [ -e /usr/aarch64-linux-gnu/lib/ld-linux-aarch64.so.1 ]
  }
  if ! aarch64_tools_ok; then
    if apt_ok; then
      echo "== installing gcc-aarch64-linux-gnu and qemu-user (aarch64 binaries of the FMUs) =="
      apt_install gcc-aarch64-linux-gnu qemu-user
    fi
    if ! aarch64_tools_ok; then
      echo "the aarch64 tests need the cross compiler and qemu-user (Debian: apt-get install" \
           "gcc-aarch64-linux-gnu qemu-user)" >&2
      exit 1
    fi
  fi
  # pkg-config: the installed-tree test (CTest install_tree) checks `pkg-config --libs rrr`
  if ! command -v pkg-config >/dev/null 2>&1 && apt_ok; then
    apt_install pkg-config
  fi
  # chromium: tests/python/jobs/test_view.py opens the page of `rrr view` in headless Chromium
  if ! command -v chromium >/dev/null 2>&1 && apt_ok; then
    echo "== installing chromium (the browser view's test, headless) =="
    apt_install --no-install-recommends chromium
  fi
  # doxygen: the manual's C API page (docs/api/c.md) is Doxygen's reading of librrr's headers
  if ! command -v doxygen >/dev/null 2>&1 && apt_ok; then
    echo "== installing doxygen (the manual's C API page) =="
    apt_install --no-install-recommends doxygen
  fi
  # libFuzzer: clang and its compiler-rt package of the same major version
  fuzzer_ok() {
    command -v clang >/dev/null 2>&1 &&
      [ -e "$(clang -print-file-name=libclang_rt.fuzzer-x86_64.a)" ]
  }
  if ! fuzzer_ok; then
    if apt_ok; then
      echo "== installing clang and libFuzzer (the fuzz runs) =="
      apt_install clang
      apt_install "libclang-rt-$(clang -dumpversion | cut -d. -f1)-dev"
    fi
    if ! fuzzer_ok; then
      echo "the fuzz runs need clang with libFuzzer (Debian: apt-get install clang" \
           "libclang-rt-<clang major>-dev)" >&2
      exit 1
    fi
  fi
  # The SocketCAN tests (the vm cases of tests/python/can/, docs/socketcan.md) boot a QEMU
  # guest with Debian's kernel (AF_CAN, vcan): can_guest.py installs qemu-system-x86,
  # busybox-static, cpio and can-utils with apt-get when missing and root, and downloads the
  # kernel package into ~/.cache/rrr-can-guest (never installed); it names what is missing
  # otherwise.
  echo "-- the SocketCAN test guest: tools, kernel, initramfs (tests/python/can/can_guest.py)"
  python3 tests/python/can/can_guest.py prepare
}
stage "the tools (apt-get when missing), the SocketCAN guest's kernel and initramfs" tools

# the controller firmware of rrr hil pil: its tools (apt-get when missing and root) and images,
# before the background stages (one dpkg at a time); tests/python/can/test_hil_pil.py runs them
stage "the controller firmware (scripts/test_pil.sh --build-only; docs/microcontroller.md)" \
  bash scripts/test_pil.sh --build-only

# ---- the background stages: each in its own build folder, at a lower priority than pytest ----
# The release folder (sdist, wheels, FMU bundle) built with zig and checked, then installed and
# run as a user would, without a compiler (docs/getting-started.md, "From the release folder")
release_folder() {
  bash scripts/test_dist.sh
}
export -f stage_main children_cpu release_folder
# the longest of them, and it needs neither .venv nor the package: it starts first, beside pip
background "the release folder: scripts/dist.sh, its checks, installed without a compiler" 10 \
  release_folder

stage "the virtual environment .venv and the package (scripts/setup_env.sh)" \
  bash scripts/setup_env.sh
# shellcheck disable=SC1091
RRR_SKIP_INSTALL=1 . scripts/setup_env.sh  # its .venv, in this shell (installed just above)
JOBS="$(nproc 2>/dev/null || echo 2)"
PYTHON="$(command -v python)"
export JOBS PYTHON

# C tests under ASan + UBSan, every one once (all but label release_only). Without the FMUs'
# Windows and aarch64 binaries: cross-compiled, they are never sanitized; their tests run in the
# Release build. Warnings are errors in every build of the test command (RRR_WERROR; off in a
# user's build).
asan() {
  cmake -S . -B build-asan -DRRR_SANITIZE=ON -DRRR_WERROR=ON -DCMAKE_BUILD_TYPE=Debug \
    -DRRR_FMU_WINDOWS=OFF -DRRR_FMU_AARCH64=OFF -DPython3_EXECUTABLE="$PYTHON"
  cmake --build build-asan -j "$JOBS"
  ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
    ctest --test-dir build-asan --output-on-failure -j "$JOBS" -LE release_only
}
# The README's CMake build (default type: Release, tests on): its CTest runs only what that
# build changes or alone builds (label release: the optimised kernels, the symbol check, the
# installed tree, the documented aarch64 cross build, the FMUs' Windows and aarch64 binaries)
release_build() {
  cmake -S . -B build-release -DRRR_WERROR=ON -DPython3_EXECUTABLE="$PYTHON"
  cmake --build build-release -j "$JOBS"
  ctest --test-dir build-release --output-on-failure -j "$JOBS" -L release
}
lint() {
  ruff check python tests bench tools c_src/rrr/gen
  # the layers of the Python package (pyproject.toml [tool.importlinter]), checked on the
  # rrr_robot that setup_env.sh has just installed from this tree
  lint-imports
  mypy python/rrr_robot
}
# The manual: a broken link or anchor, an unresolved reference or a page outside the navigation
# fails it (docs/ -> build-docs/index.html; the README's block that builds it is this stage)
manual() {
  sphinx-build -q -W --keep-going -n -b html docs build-docs
}
# libFuzzer, short runs (docs/can-bench.md and docs/limits.md have the long ones)
fuzz() {
  cmake -S . -B build-fuzz -DCMAKE_C_COMPILER=clang -DRRR_HIL_FUZZ=ON -DRRR_FMU_FUZZ=ON \
    -DRRR_BUILD_TESTS=OFF -DRRR_WERROR=ON -DRRR_FMU_WINDOWS=OFF -DRRR_FMU_AARCH64=OFF \
    -DCMAKE_BUILD_TYPE=Debug -DPython3_EXECUTABLE="$PYTHON" >/dev/null
  cmake --build build-fuzz --target fuzz_hil_decode fuzz_fmu_state fuzz_fmi_import \
    fuzz_hil_canopen -j "$JOBS"
  echo "-- libFuzzer on the CAN frame decoders"
  mkdir -p build-fuzz/corpus
  build-fuzz/c_src/hil/fuzz_hil_decode -max_total_time="${RRR_FUZZ_SECONDS:-15}" -max_len=96 \
    -print_final_stats=1 build-fuzz/corpus c_src/hil/fuzz/seeds 2>&1 | tail -n 12
  echo "-- libFuzzer on the CANopen slave: frame and time sequences through one node"
  mkdir -p build-fuzz/corpus_canopen
  build-fuzz/c_src/hil/fuzz_hil_canopen -max_total_time="${RRR_CANOPEN_FUZZ_SECONDS:-15}" \
    -max_len=600 -print_final_stats=1 build-fuzz/corpus_canopen 2>&1 | tail -n 4
  echo "-- libFuzzer on forged FMU states with valid checksums (each FMU, FMI 2 and 3)"
  for model in $(cat build-fuzz/fmus/fmu_names.txt); do  # as fmu/CMakeLists.txt lists them
    mkdir -p "build-fuzz/corpus_$model"
    "build-fuzz/fmu/fuzz_fmu_state_$model" -max_total_time="${RRR_FMU_FUZZ_SECONDS:-8}" \
      -max_len=89 -print_final_stats=1 "build-fuzz/corpus_$model" 2>&1 | tail -n 4
  done
  echo "-- the FMI-LS-BUS network FMUs: forged FMU states, hostile Rx_Data values (3 s each)"
  # fmu/CMakeLists.txt builds both targets for each node (docs/ls-bus.md); CTest drives the same
  # targets without libFuzzer: lsbus_rx_smoke_* and fmu_state_fuzz_*_can
  for rx in build-fuzz/fmu/fuzz_lsbus_rx_*; do  # the network FMUs' models, as the build made them
    model=${rx##*/fuzz_lsbus_rx_}
    mkdir -p "build-fuzz/corpus_$model" "build-fuzz/corpus_lsbus_rx_$model"
    "build-fuzz/fmu/fuzz_fmu_state_$model" -max_total_time="${RRR_LSBUS_FUZZ_SECONDS:-3}" \
      -max_len=89 -print_final_stats=1 "build-fuzz/corpus_$model" 2>&1 | tail -n 4
    "$rx" -max_total_time="${RRR_LSBUS_FUZZ_SECONDS:-3}" \
      -max_len=4096 -print_final_stats=1 "build-fuzz/corpus_lsbus_rx_$model" 2>&1 | tail -n 4
  done
  echo "-- libFuzzer on the FMU importer's modelDescription scanner (c_src/fmi_import)"
  mkdir -p build-fuzz/corpus_fmi_import
  for xml in fmu/*/modelDescription.xml; do
    cp "$xml" "build-fuzz/corpus_fmi_import/$(basename "$(dirname "$xml")").xml"
  done
  build-fuzz/c_src/fmi_import/fuzz_fmi_import -max_total_time="${RRR_FMI_FUZZ_SECONDS:-10}" \
    -max_len=65536 -print_final_stats=1 build-fuzz/corpus_fmi_import 2>&1 | tail -n 4
}
# Every bench script's quick mode (they print their tables; no number is checked), after the
# benchmark's C++ driver (one Pinocchio translation unit: about 2 min of CPU) is built
benchmarks() {
  python bench/run_bench.py --build-only --werror --build-dir build-bench
  python bench/run_bench.py --quick --skip-build --build-dir build-bench
  local script t0
  for script in bench/bench_*.py; do
    echo "-- python $script --quick"
    t0=$SECONDS
    python "$script" --quick
    echo "-- $script: $((SECONDS - t0)) s"
  done
}
# The SocketCAN cases (marker vm, tests/python/can/): one pytest session of their own, beside
# the others, since most of their time is the QEMU guest's emulated CPU (a third of pytest's when
# they ran in one session); its own temporary folder, so that neither session cleans the other's
pytest_guest() {
  python -m pytest -q -p no:cacheprovider --durations=10 -m vm \
    --basetemp "$(mktemp -d)/pytest-vm" tests/python
}
export -f asan release_build lint manual fuzz benchmarks pytest_guest
background "pytest, the SocketCAN cases in the QEMU guest (-m vm)" 0 pytest_guest
background "the C tests under ASan + UBSan (CTest, build-asan)" 5 asan
background "ruff, lint-imports, mypy" 5 lint
background "the README's Release build and its CTest (label release)" 10 release_build
background "the manual (sphinx-build -W -n)" 10 manual
background "libFuzzer: build-fuzz and the short runs" 10 fuzz
background "every bench script's quick mode (bench/)" 15 benchmarks

# ---- the foreground stage: pytest, the longest -----------------------------------------------
# in two workers (pytest-xdist), a test file each at a time: most of pytest's time is spent waiting
# for the processes a test starts (nodes, rrr commands, timeouts), which the other worker fills
last_stage "pytest, every other test (-m 'not vm'; every block of README.md and docs/)" \
  python -m pytest -q --durations=25 -n "$JOBS" --dist loadfile -m "not vm" tests/python
echo "== waiting for the background stages =="
wait_background
if [ "${#FAILED[@]}" != 0 ]; then
  printf '== FAILED: %s ==\n' "${FAILED[@]}" >&2
  exit 1
fi
echo "== all test stages passed (CTest under ASan + UBSan and of the Release build, ruff," \
     "lint-imports, mypy, pytest, the manual, the benchmarks' quick modes, libFuzzer, the" \
     "release folder) =="
