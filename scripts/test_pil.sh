#!/usr/bin/env bash
# Processor in the loop (docs/microcontroller.md): the GNU Arm toolchain, picolibc and
# qemu-system-arm (installed with apt-get when missing and root), the controller firmware of
# c_src/firmware built with warnings as errors into build-firmware (the images `rrr hil pil`
# runs by default), then its tests, tests/python/can/test_hil_pil.py (the firmware in QEMU against
# the C plant node and against a fake plant; about a minute).
#
#   bash scripts/test_pil.sh               # tools, build, tests
#   bash scripts/test_pil.sh --build-only  # tools and build (the test command's pytest stage
#                                          # runs tests/python/can/test_hil_pil.py itself)
#
# Python: the active virtual environment, else .venv (scripts/setup_env.sh makes it).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
BUILD_ONLY=0
case "${1:-}" in
  --build-only) BUILD_ONLY=1 ;;
  "") ;;
  *) echo "usage: bash scripts/test_pil.sh [--build-only]" >&2; exit 2 ;;
esac
pil_tools_ok() {
  command -v arm-none-eabi-gcc >/dev/null 2>&1 && command -v qemu-system-arm >/dev/null 2>&1 &&
    [ -e "$(arm-none-eabi-gcc -print-file-name=picolibc.specs)" ]
}
if ! pil_tools_ok; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "== installing gcc-arm-none-eabi, picolibc-arm-none-eabi and qemu-system-arm (the firmware) =="
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq gcc-arm-none-eabi \
      picolibc-arm-none-eabi qemu-system-arm >/dev/null
  fi
  if ! pil_tools_ok; then
    echo "the firmware needs the GNU Arm toolchain, picolibc and QEMU (Debian: apt-get install" \
         "gcc-arm-none-eabi picolibc-arm-none-eabi qemu-system-arm)" >&2
    exit 1
  fi
fi
echo "== the controller firmware: c_src/firmware -> build-firmware (Cortex-M7 and Cortex-M4F images) =="
cmake -S c_src/firmware -B build-firmware -DRRR_WERROR=ON >/dev/null
cmake --build build-firmware -j "$(nproc 2>/dev/null || echo 2)"
if [ "$BUILD_ONLY" = 1 ]; then
  exit 0
fi
PY=python
if [ -z "${VIRTUAL_ENV:-}" ] && [ -x .venv/bin/python ]; then
  PY=.venv/bin/python
fi
echo "== processor in the loop: tests/python/can/test_hil_pil.py =="
RRR_PIL_FIRMWARE_DIR="$ROOT/build-firmware" "$PY" -m pytest -q tests/python/can/test_hil_pil.py
