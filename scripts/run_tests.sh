#!/usr/bin/env bash
# Sets up everything and runs every test: C tests (core, FMU harness) under AddressSanitizer and
# UndefinedBehaviorSanitizer via CTest, the generated-code check, ruff, and pytest.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
export RRR_PIP_TARGET=".[test]"
# shellcheck disable=SC1091
. scripts/setup_env.sh
JOBS="$(nproc 2>/dev/null || echo 2)"
echo "== C tests under ASan + UBSan =="
cmake -S . -B build-asan -DRRR_SANITIZE=ON -DCMAKE_BUILD_TYPE=Debug -DPython3_EXECUTABLE="$(command -v python)"
cmake --build build-asan -j "$JOBS"
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1 \
  ctest --test-dir build-asan --output-on-failure -j "$JOBS"
echo "== libFuzzer on the CAN frame decoders (short run; c_src/hil/README.md has the long one) =="
if ! command -v clang >/dev/null 2>&1 || [ ! -e "$(clang -print-file-name=libclang_rt.fuzzer-x86_64.a)" ]; then
  if [ "$(id -u)" = 0 ]; then
    apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq clang libclang-rt-14-dev >/dev/null
  else
    echo "clang with libFuzzer is needed for the fuzz run: sudo apt-get install clang libclang-rt-14-dev" >&2
    exit 1
  fi
fi
cmake -S . -B build-fuzz -DCMAKE_C_COMPILER=clang -DRRR_HIL_FUZZ=ON -DRRR_BUILD_TESTS=OFF \
  -DCMAKE_BUILD_TYPE=Debug -DPython3_EXECUTABLE="$(command -v python)" >/dev/null
cmake --build build-fuzz --target fuzz_hil_decode -j "$JOBS"
mkdir -p build-fuzz/corpus
build-fuzz/c_src/hil/fuzz_hil_decode -max_total_time="${RRR_FUZZ_SECONDS:-30}" -max_len=96 \
  -print_final_stats=1 build-fuzz/corpus 2>&1 | tail -n 12
echo "== ruff =="
ruff check python tests bench tools c_src/rrr/gen
echo "== pytest =="
python -m pytest -q tests/python
