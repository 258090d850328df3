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
echo "== ruff =="
ruff check python tests bench tools c_src/rrr/gen
echo "== pytest =="
python -m pytest -q tests/python
