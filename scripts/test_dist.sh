#!/usr/bin/env bash
# The release folder, built and used as a user would (a stage of scripts/run_tests.sh):
#  1. bash scripts/dist.sh: the sdist, the two wheels, the FMU bundle, with its checks;
#  2. the x86-64 wheel in a fresh venv with no C compiler and no CMake on PATH, binary packages
#     only (pip --only-binary :all:): the install timed, then rrr writing --no-figures -q (it
#     must print the README's ctc line), rrr hil bench and rrr fmus;
#  3. the same wheel on every other CPython >= 3.11 that pyenv has here (3.12, 3.13): the one
#     abi3 extension loads and computes;
#  4. aarch64, under qemu-user: Debian's CPython 3.11 for arm64, unpacked (never installed) into
#     ~/.cache/rrr-aarch64-python, runs the aarch64 wheel (pip install --target --platform, with
#     its dependencies' aarch64 wheels): Model.default().inverse_dynamics and the aarch64 plant
#     FMU under FMPy, bit for bit against x86-64; then rrr hil bench with the aarch64 plant node
#     (on the aarch64 plant FMU) against the x86-64 controller node: the same results as the
#     x86-64 nodes.
# RRR_DIST_REUSE=1 uses the dist/ there is instead of building it. Needs what scripts/dist.sh needs, and apt-get (the arm64 packages are downloaded into the cache
# folder with a private package list: the machine's apt configuration is not touched).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
T0=$SECONDS
if [ "${RRR_DIST_REUSE:-0}" = 1 ] && [ -e dist/SHA256SUMS ]; then
  echo "== RRR_DIST_REUSE=1: the release folder dist/ as it is =="
else
  echo "== the release folder: bash scripts/dist.sh =="
  bash scripts/dist.sh
fi
VERSION="$(sed -n 's/^#define RRR_VERSION_STRING "\([0-9.]*\)"$/\1/p' \
  c_src/rrr/include/rrr/rrr_version.h)"
WHL_X86="$(ls "$ROOT"/dist/rrr_robot-"$VERSION"-*x86_64*.whl)"
WHL_A64="$(ls "$ROOT"/dist/rrr_robot-"$VERSION"-*aarch64*.whl)"
WORK="$(mktemp -d "${TMPDIR:-/tmp}/rrr dist test.XXXXXX")"  # a path with a space
trap 'rm -rf "$WORK"' EXIT
ctc_line="$(grep -m1 '^ *ctc: tip error' README.md | sed 's/\.\.\.x real time$//')"

# PATH without compilers or CMake: every program of PATH but those, linked into one folder
NOCC="$WORK/nocc-bin"
mkdir -p "$NOCC"
IFS=: read -r -a path_dirs <<< "$PATH"
for d in "${path_dirs[@]}"; do
  [ -d "$d" ] || continue
  for f in "$d"/*; do
    n="$(basename "$f")"
    case "$n" in
      cc|c89|c99|gcc|gcc-*|*-gcc|*-gcc-*|clang|clang-*|*-clang|tcc|cpp|cpp-*|c++|g++|g++-*|\
      *-g++|*-g++-*|cmake|cmake-*|ccmake|cpack|ctest|zig|ld|ld.*|*-ld|as|*-as) continue ;;
    esac
    [ -e "$NOCC/$n" ] || ln -s "$f" "$NOCC/$n"
  done
done

T1=$SECONDS
echo "== the x86-64 wheel in a fresh venv, no C compiler or CMake on PATH =="
python3 -m venv "$WORK/venv"
(
  export PATH="$WORK/venv/bin:$NOCC"
  for tool in cc gcc clang cmake; do
    if command -v "$tool" >/dev/null 2>&1; then
      echo "test_dist: $tool is still on PATH: $(command -v "$tool")" >&2
      exit 1
    fi
  done
  t0=$SECONDS
  python -m pip install --quiet --disable-pip-version-check --only-binary=:all: "$WHL_X86"
  echo "installed in $((SECONDS - t0)) s: $(basename "$WHL_X86") and its dependencies" \
       "(binary packages only)"
  cd "$WORK"
  rrr writing --no-figures -q --out writing | tee writing.txt
  if ! grep -qF -- "$ctc_line" writing.txt; then
    echo "test_dist: rrr writing did not print the README's line: $ctc_line" >&2
    exit 1
  fi
  rrr hil bench -q --out hil-x86 | tee hil-x86.txt
  rrr fmus | tee fmus.txt
  grep -q "plant *FMI 2.0 .*aarch64-linux, linux64 (x86_64), win64 " fmus.txt
  python - <<'EOF' > "$WORK/x86.txt"
import numpy as np
import rrr_robot as rr
from fmpy import simulate_fmu
tau = rr.Model.default().inverse_dynamics([0.1, 0.5, -0.7], [0.3, -0.2, 0.4], [1.0, 2.0, -3.0])
print("tau", [float(x).hex() for x in tau])
res = simulate_fmu(str(rr.fmu_path("plant")), stop_time=0.05, output_interval=0.001,
                   start_values={"u[1]": 1.0, "u[2]": -2.0, "u[3]": 0.5})
print("fmu", [float(x).hex() for x in np.asarray(res[res.dtype.names[1]])[-3:]],
      res.dtype.names[1], len(res))
EOF
  cat "$WORK/x86.txt"
)

echo "   $((SECONDS - T1)) s"
T1=$SECONDS
echo "== the same wheel on the other CPython versions (pyenv): the abi3 extension =="
other=0
for py in /root/.pyenv/versions/3.1[2-9]*/bin/python3 "${HOME}"/.pyenv/versions/3.1[2-9]*/bin/python3; do
  [ -x "$py" ] || continue
  v="$("$py" -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
  [ -d "$WORK/venv-$v" ] && continue
  "$py" -m venv "$WORK/venv-$v"
  "$WORK/venv-$v/bin/python" -m pip install --quiet --disable-pip-version-check \
    --only-binary=:all: --no-deps "$WHL_X86" numpy
  "$WORK/venv-$v/bin/python" - <<'EOF' > "$WORK/x86-$v.txt"
import rrr_robot as rr
tau = rr.Model.default().inverse_dynamics([0.1, 0.5, -0.7], [0.3, -0.2, 0.4], [1.0, 2.0, -3.0])
print("tau", [float(x).hex() for x in tau])
EOF
  if ! grep -qxF "$(head -1 "$WORK/x86-$v.txt")" "$WORK/x86.txt"; then
    echo "test_dist: CPython $v computes $(cat "$WORK/x86-$v.txt")" >&2
    exit 1
  fi
  echo "CPython $v: the wheel installs, its extension loads and computes the same torques"
  other=$((other + 1))
done
echo "other CPython versions checked: $other ($((SECONDS - T1)) s)"
T1=$SECONDS

echo "== aarch64 under qemu-user: Debian's CPython 3.11 for arm64 runs the aarch64 wheel =="
DEB="$(cut -d. -f1 /etc/debian_version 2>/dev/null || echo none)"
A64="${RRR_AARCH64_PYTHON:-$HOME/.cache/rrr-aarch64-python/debian-$DEB}"
# the interpreter, the libraries its standard library loads, libstdc++ (numpy's wheels need it)
A64_PKGS=(python3.11-minimal libpython3.11-stdlib libstdc++6)
if [ "$(cat "$A64/packages" 2>/dev/null)" != "${A64_PKGS[*]}" ]; then
  echo "-- downloading Debian's python3.11 for arm64 into $A64 (once) --"
  rm -rf "$A64"
  mkdir -p "$A64/lists/partial" "$A64/cache/archives/partial" "$A64/debs" "$A64/root"
  touch "$A64/status"
  apt_opts=(-o "Dir::State::Lists=$A64/lists" -o "Dir::Cache=$A64/cache"
            -o "Dir::State::Status=$A64/status" -o APT::Architecture=arm64
            -o APT::Architectures::=arm64 -o APT::Sandbox::User=root)
  apt-get -qq "${apt_opts[@]}" update
  # with their dependencies
  mapfile -t pkgs < <(apt-cache "${apt_opts[@]}" depends --recurse --no-recommends \
      --no-suggests --no-conflicts --no-breaks --no-replaces --no-enhances \
      "${A64_PKGS[@]}" | grep -v '^[ <]' | sort -u |
    grep -vxE 'dpkg|tar|install-info|perl|perl-base|perl-modules-.*|libperl.*|mailcap|mime-support|media-types')
  (cd "$A64/debs" && apt-get -qq "${apt_opts[@]}" download "${pkgs[@]/%/:arm64}")
  for deb in "$A64"/debs/*.deb; do
    dpkg-deb -x "$deb" "$A64/root"
  done
  rm -rf "$A64/debs" "$A64/cache" "$A64/lists"
  echo "${A64_PKGS[*]}" > "$A64/packages"
fi
PY_A64=("qemu-aarch64" "$A64/root/usr/bin/python3.11")
export QEMU_LD_PREFIX="$A64/root"
"${PY_A64[@]}" -c 'import platform, sys; print("aarch64 CPython", sys.version.split()[0], platform.machine())'
"$WORK/venv/bin/python" -m pip install --quiet --disable-pip-version-check --only-binary=:all: \
  --platform manylinux_2_36_aarch64 --platform manylinux_2_28_aarch64 \
  --platform manylinux_2_17_aarch64 --platform manylinux2014_aarch64 \
  --python-version 3.11 --implementation cp --abi cp311 --abi abi3 --abi none \
  --target "$WORK/a64-site" "$WHL_A64"
PYTHONPATH="$WORK/a64-site" "${PY_A64[@]}" - <<'EOF' > "$WORK/a64.txt"
import platform
import numpy as np
import rrr_robot as rr
from fmpy import simulate_fmu
assert platform.machine() == "aarch64", platform.machine()
tau = rr.Model.default().inverse_dynamics([0.1, 0.5, -0.7], [0.3, -0.2, 0.4], [1.0, 2.0, -3.0])
print("tau", [float(x).hex() for x in tau])
res = simulate_fmu(str(rr.fmu_path("plant")), stop_time=0.05, output_interval=0.001,
                   start_values={"u[1]": 1.0, "u[2]": -2.0, "u[3]": 0.5})
print("fmu", [float(x).hex() for x in np.asarray(res[res.dtype.names[1]])[-3:]],
      res.dtype.names[1], len(res))
EOF
cat "$WORK/a64.txt"
# (FMPy prints a line of its own there: it ships no aarch64 build of its logger helper)
if ! diff <(grep -E '^(tau|fmu) ' "$WORK/x86.txt") <(grep -E '^(tau|fmu) ' "$WORK/a64.txt"); then
  echo "test_dist: the aarch64 wheel computes other values than the x86-64 one (above)" >&2
  exit 1
fi
echo "aarch64: the extension's torques and the plant FMU's outputs are bit for bit x86-64's" \
     "($((SECONDS - T1)) s)"
T1=$SECONDS

# the bench: the aarch64 plant node under qemu, on the aarch64 plant FMU, against the x86-64
# controller node (RRR_HIL_BIN_DIR: the nodes rrr hil bench starts; the plant's --fmu is swapped
# for the aarch64 archive's, unzipped)
A64_PKG="$WORK/a64-site/rrr_robot"
mkdir -p "$WORK/a64-bin" "$WORK/a64-fmu"
python3 -m zipfile -e "$A64_PKG/fmus/rrr_plant.fmu" "$WORK/a64-fmu"
cat > "$WORK/a64-bin/rrr_hil_plant" <<EOF
#!/usr/bin/env bash
args=()
while [ \$# -gt 0 ]; do
  if [ "\$1" = --fmu ]; then args+=(--fmu "$WORK/a64-fmu"); shift 2; else args+=("\$1"); shift; fi
done
exec qemu-aarch64 "$A64_PKG/bin/rrr_hil_plant" "\${args[@]}"
EOF
chmod +x "$WORK/a64-bin/rrr_hil_plant"
ln -s "$WORK/venv/lib/python3.11/site-packages/rrr_robot/bin/rrr_hil_controller" "$WORK/a64-bin/"
(
  cd "$WORK"
  RRR_HIL_BIN_DIR="$WORK/a64-bin" "$WORK/venv/bin/rrr" hil bench -q --no-figures --out hil-a64 |
    tee hil-a64.txt
)
# the same lines (but the folder and the frame rate, a speed) and the same plant and controller logs
same() { grep -v "^results in" "$1" | sed -E 's/[0-9]+ frames\/s/N frames\/s/'; }
if ! diff <(same "$WORK/hil-x86.txt") <(same "$WORK/hil-a64.txt"); then
  echo "test_dist: the bench with the aarch64 plant node printed other results (above)" >&2
  exit 1
fi
for log in plant.csv controller.csv; do
  if ! cmp "$WORK/hil-x86/$log" "$WORK/hil-a64/$log"; then
    echo "test_dist: the bench with the aarch64 plant node logged another $log" >&2
    exit 1
  fi
done
echo "aarch64 plant node: the bench's results and logs are those of the x86-64 node, bit for" \
     "bit ($((SECONDS - T1)) s)"
echo "== the release folder built, checked and used in $((SECONDS - T0)) s =="
