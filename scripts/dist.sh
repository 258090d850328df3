#!/usr/bin/env bash
# Builds and checks the release folder dist/ (docs/getting-started.md, "From the release folder"):
#   rrr_robot-<v>.tar.gz                                  the sdist
#   rrr_robot-<v>-cp311-abi3-manylinux_2_17_x86_64...whl  CPython >= 3.11, x86-64 Linux, glibc >= 2.17
#   rrr_robot-<v>-cp311-abi3-manylinux_2_17_aarch64...whl the same for aarch64 Linux
#   rrr_robot-fmus-<v>.zip                                every FMU (FMI 2.0 and 3.0; Linux x86-64
#                                                         and aarch64, Windows), the SSP archive,
#                                                         the EDS, the DBC, each FMU's documentation,
#                                                         SHA256SUMS
#   SHA256SUMS                                            of the four files above
# Every Linux binary (librrr, the extension, the bench nodes, the FMUs' Linux binaries) is built
# by one portable toolchain, Zig's C compiler from the Python package ziglang, for glibc 2.17
# (cmake/zig.cmake); no container. The x86-64 wheel is built from the tree, the aarch64 wheel from
# the sdist (tools/dist_check.py compares the two). Checked before dist/ is written: auditwheel
# show, the GLIBC versions of every ELF file (also inside the FMUs), the libraries they need,
# abi3audit on the extensions, twine check. Built in build-dist/ and renamed to dist/ at the end:
# a failed run leaves the dist/ of the last good run (or none).
#
# Needs python3 (>= 3.11, with venv), the tools of an FMU build (mingw-w64 for the FMUs' Windows
# binaries; qemu-user and the aarch64 C library, Debian's gcc-aarch64-linux-gnu, to run the
# generators of the aarch64 build) and the network of pip (or its cache): the build tools are
# installed into build-dist/venv. About 2 to 3.5 minutes here (2 cores).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
T0=$SECONDS
GLIBC="2.17"
GLIBC_TAG="${GLIBC/./_}"
VERSION="$(sed -n 's/^#define RRR_VERSION_STRING "\([0-9.]*\)"$/\1/p' \
  c_src/rrr/include/rrr/rrr_version.h)"
missing=""
command -v x86_64-w64-mingw32-gcc >/dev/null 2>&1 || missing+=" gcc-mingw-w64-x86-64"
command -v qemu-aarch64 >/dev/null 2>&1 || missing+=" qemu-user"
[ -e /usr/aarch64-linux-gnu/lib/ld-linux-aarch64.so.1 ] || missing+=" gcc-aarch64-linux-gnu"
if [ -n "$missing" ]; then
  echo "scripts/dist.sh needs (Debian: apt-get install$missing)" >&2
  exit 1
fi

# the build tools, in a venv of their own (the build runs without isolation, in this venv)
VENV=build-dist/venv
TOOLS=("ziglang>=0.13" "auditwheel>=6.4" "twine>=5" "abi3audit>=0.0.20"
       "scikit-build-core>=0.11" "fmpy>=0.3.32")
if [ ! -x "$VENV/bin/python" ]; then
  python3 -m venv "$VENV"
fi
PY="$ROOT/$VENV/bin/python"
if ! "$PY" -m pip install --quiet --disable-pip-version-check "${TOOLS[@]}"; then
  echo "scripts/dist.sh: could not install the build tools into $VENV: ${TOOLS[*]}" >&2
  exit 1
fi
RRR_ZIG="$("$PY" -c 'import ziglang, os; print(os.path.join(os.path.dirname(ziglang.__file__), "zig"))')"
export RRR_ZIG

RUN="build-dist/run-$$"
STAGE="$RUN/dist"
rm -rf "$RUN"
mkdir -p "$STAGE"
trap 'rm -rf "$ROOT/$RUN"' EXIT

echo "== the sdist =="
"$PY" - "$STAGE" <<'EOF'
import sys
from scikit_build_core.build import build_sdist
print(build_sdist(sys.argv[1]))
EOF
SDIST="$STAGE/rrr_robot-$VERSION.tar.gz"
mkdir -p "$RUN/sdist"
tar -xzf "$SDIST" -C "$RUN/sdist"

# wheel ARCH SOURCE [-C SETTING]...: the abi3 wheel for ARCH (x86_64, aarch64), built from SOURCE
# with zig
wheel() {
  local arch="$1" src="$2" t0=$SECONDS
  shift 2
  echo "== the $arch wheel, from $src (zig cc -target $arch-linux-gnu.$GLIBC) =="
  nice -n 10 "$PY" -m pip wheel --quiet --no-deps --no-build-isolation --wheel-dir "$RUN/$arch" \
    -C cmake.define.CMAKE_TOOLCHAIN_FILE="$ROOT/cmake/zig.cmake" \
    -C cmake.define.RRR_ZIG_TARGET="$arch-linux-gnu.$GLIBC" \
    -C build.verbose=false -C build-dir="$RUN/build-$arch" \
    -C "wheel.tags=cp311-abi3-manylinux_${GLIBC_TAG}_$arch" \
    -C "wheel.tags=cp311-abi3-manylinux2014_$arch" "$@" \
    "$src"
  mv "$RUN/$arch"/*.whl "$STAGE/"
  echo "   $((SECONDS - t0)) s"
}
CMAKE_BUILD_PARALLEL_LEVEL="${CMAKE_BUILD_PARALLEL_LEVEL:-2}"
export CMAKE_BUILD_PARALLEL_LEVEL
wheel x86_64 "$ROOT"
# the aarch64 wheel's FMUs carry what an aarch64 Linux host loads, not Windows binaries (the x86-64
# wheel's and the bundle's have every platform)
wheel aarch64 "$RUN/sdist/rrr_robot-$VERSION" -C cmake.define.RRR_FMU_WINDOWS=OFF
WHL_X86="$(ls "$STAGE"/rrr_robot-"$VERSION"-*x86_64*.whl)"
WHL_A64="$(ls "$STAGE"/rrr_robot-"$VERSION"-*aarch64*.whl)"

echo "== the FMU bundle (from the x86-64 build: every FMU with its Linux x86-64 and aarch64 and" \
     "Windows binaries) and the SSP archive of the writing task =="
# rrr ssp runs the x86-64 wheel, installed with its dependencies into the tools venv
"$PY" -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps "$WHL_X86"
"$PY" -m pip install --quiet --disable-pip-version-check --no-compile "$WHL_X86"
"$ROOT/$VENV/bin/rrr" ssp --scenario ctc --out "$RUN/rrr_writing_ctc.ssp" -q
"$PY" tools/dist_check.py bundle --fmus "$RUN/build-x86_64/fmus" --ssp "$RUN/rrr_writing_ctc.ssp" \
  --data python/rrr_robot/data --out "$STAGE/rrr_robot-fmus-$VERSION.zip"

echo "== checks: auditwheel show, GLIBC versions and libraries of every ELF file, abi3audit," \
     "twine check, the two wheels' file lists =="
for w in "$WHL_X86" "$WHL_A64"; do
  "$ROOT/$VENV/bin/auditwheel" show "$w" | tee "$RUN/auditwheel.txt"
  if ! tr '\n' ' ' < "$RUN/auditwheel.txt" | grep -q "manylinux_${GLIBC_TAG}_"; then
    echo "auditwheel does not place $(basename "$w") at manylinux_${GLIBC_TAG}" >&2
    exit 1
  fi
  "$ROOT/$VENV/bin/abi3audit" --strict --summary "$w"
done
"$PY" tools/dist_check.py scan "$WHL_X86" "$WHL_A64" "$STAGE/rrr_robot-fmus-$VERSION.zip"
"$PY" tools/dist_check.py compare --tree "$WHL_X86" --sdist "$WHL_A64"
"$ROOT/$VENV/bin/twine" --no-color check --strict "$STAGE"/*.whl "$STAGE"/*.tar.gz

(cd "$STAGE" && sha256sum -- *.tar.gz *.whl *.zip > SHA256SUMS)
# dist/ appears complete or not at all: the staged folder is renamed over the old one
rm -rf build-dist/dist.old
if [ -e dist ]; then
  mv dist build-dist/dist.old
fi
mv "$STAGE" dist
rm -rf build-dist/dist.old
echo "== dist/ ($((SECONDS - T0)) s) =="
ls -l dist
