"""The release folder's FMU bundle and checks (scripts/dist.sh runs them).

    dist_check.py bundle --fmus BUILD/fmus --ssp FILE.ssp --data python/rrr_robot/data --out ZIP
    dist_check.py scan WHEEL_OR_ZIP...
    dist_check.py compare --tree WHEEL --sdist WHEEL

bundle: the zip of every FMU (the build's fmus/ folder as it is: FMI 2.0 at the top, fmi3/,
aarch64-linux/), the SSP archive, the EDS and the DBC, each FMU's documentation/ unpacked into
documentation/<id>/ and SHA256SUMS of all of them, in one folder rrr_robot-fmus-<version>/;
each FMU must hold the binaries of every platform (a missing cross compiler drops some).

scan: every ELF file in the wheels and zips, also inside the FMUs and SSP archives in them:
the CPU (the wheel's; aarch64 in aarch64 folders), the libraries it needs (glibc's only, never
libpython) and the newest GLIBC symbol version it needs, which must not pass the wheel's
manylinux tag (a zip: glibc 2.17); the wheels must hold the package's compiled parts.

compare: the wheel built from the tree and the one built from the sdist hold the same files
(but for rrr_robot/fmus/aarch64-linux/, the FMI 2.0 archives for aarch64 hosts, which an x86-64
build adds) and every file that is not compiled has the same bytes: the sdist builds the
package the tree builds.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import re
import sys
import zipfile
from collections.abc import Iterator
from pathlib import Path, PurePosixPath

from elftools.elf.dynamic import DynamicSection
from elftools.elf.elffile import ELFFile
from elftools.elf.gnuversions import GNUVerNeedSection

#: glibc's libraries (the manylinux policies allow these and the loader)
GLIBC_LIBS = {"libc.so.6", "libm.so.6", "libdl.so.2", "libpthread.so.0", "librt.so.1"}
MACHINES = {"EM_X86_64": "x86_64", "EM_AARCH64": "aarch64"}
#: FMU platform folders each archive must hold: FMI 2.0, FMI 3.0, FMI 2.0 for aarch64 hosts
FMU_PLATFORMS = {"": {"linux64", "win64", "aarch64-linux"},
                 "fmi3": {"x86_64-linux", "x86_64-windows", "aarch64-linux"},
                 "aarch64-linux": {"linux64"}}
NESTED = (".fmu", ".ssp", ".zip")


def version_key(v: str) -> tuple[int, ...]:
    return tuple(int(x) for x in v.split("."))


def members(data: bytes, where: str) -> Iterator[tuple[str, bytes]]:
    """(path, bytes) of every file in the zip ``data``, recursing into FMUs and archives."""
    with zipfile.ZipFile(io.BytesIO(data)) as z:
        for info in z.infolist():
            if info.is_dir():
                continue
            body = z.read(info)
            path = f"{where}!{info.filename}"
            yield path, body
            if info.filename.endswith(NESTED):
                yield from members(body, path)


class ElfInfo:
    """The CPU, the libraries and the newest GLIBC version an ELF file needs."""

    def __init__(self, body: bytes) -> None:
        elf = ELFFile(io.BytesIO(body))
        self.machine = MACHINES.get(elf["e_machine"], elf["e_machine"])
        self.needed: list[str] = []
        self.glibc = "0"
        for sec in elf.iter_sections():
            if isinstance(sec, DynamicSection):
                self.needed += [t.needed for t in sec.iter_tags() if t.entry.d_tag == "DT_NEEDED"]
            if isinstance(sec, GNUVerNeedSection):
                for _, auxs in sec.iter_versions():
                    for aux in auxs:
                        m = re.fullmatch(r"GLIBC_([0-9.]+)", aux.name)
                        if m and version_key(m.group(1)) > version_key(self.glibc):
                            self.glibc = m.group(1)


def tag_of(name: str) -> tuple[str, str]:
    """(arch, glibc) of a manylinux wheel's file name; a zip: x86_64 and glibc 2.17."""
    m = re.search(r"manylinux_(\d+)_(\d+)_(x86_64|aarch64)", name)
    if name.endswith(".whl"):
        if m is None:
            raise SystemExit(f"{name}: no manylinux_X_Y platform tag")
        return m.group(3), f"{m.group(1)}.{m.group(2)}"
    return "x86_64", "2.17"


def scan(path: Path) -> list[str]:
    """Problems of one wheel or zip (printing one line per ELF file)."""
    arch, glibc = tag_of(path.name)
    problems = []
    names = set()
    count = 0
    for member, body in members(path.read_bytes(), path.name):
        names.add(member.split("!", 2)[1] if member.count("!") == 1 else "")
        if not body.startswith(b"\x7fELF"):
            continue
        count += 1
        info = ElfInfo(body)
        want = "aarch64" if "aarch64" in member else arch
        print(f"  {info.machine:8} GLIBC_{info.glibc:6} {' '.join(info.needed):40} {member}")
        if info.machine != want:
            problems.append(f"{member}: {info.machine} code in an {want} place")
        if version_key(info.glibc) > version_key(glibc):
            problems.append(f"{member}: needs GLIBC_{info.glibc}, the tag allows {glibc}")
        other = [n for n in info.needed
                 if n not in GLIBC_LIBS and not n.startswith("ld-linux")]
        if other:
            problems.append(f"{member}: needs {', '.join(other)} (only glibc's libraries)")
    print(f"{path.name}: {count} ELF files, none needs more than glibc {glibc}"
          if not problems else f"{path.name}: {len(problems)} problem(s)")
    if path.suffix == ".whl":
        problems += [f"{path.name}: no {n}" for n in expected_files(path) if n not in names]
    return problems


def expected_files(wheel: Path) -> list[str]:
    """The compiled parts every wheel holds: the extension, the libraries, the nodes and their
    list of profiles, the FMUs of fmus/fmu_names.txt in both FMI versions."""
    with zipfile.ZipFile(wheel) as z:
        fmus = z.read("rrr_robot/fmus/fmu_names.txt").decode().split()
    files = ["rrr_robot/core/_ext.abi3.so", "rrr_robot/librrr.so",
             "rrr_robot/librrr_hil_supervisor.so", "rrr_robot/bin/rrr_hil_plant",
             "rrr_robot/bin/rrr_hil_controller", "rrr_robot/bin/hil_profiles.txt"]
    for name in fmus:
        files += [f"rrr_robot/fmus/rrr_{name}.fmu", f"rrr_robot/fmus/fmi3/rrr_{name}.fmu"]
    return files


def digests(wheel: Path) -> dict[str, str]:
    """sha256 of every file of a wheel but its .dist-info's WHEEL and RECORD."""
    out = {}
    with zipfile.ZipFile(wheel) as z:
        for info in z.infolist():
            if info.is_dir() or re.search(r"\.dist-info/(WHEEL|RECORD)$", info.filename):
                continue
            body = z.read(info)
            compiled = body.startswith(b"\x7fELF") or info.filename.endswith(NESTED)
            out[info.filename] = "compiled" if compiled else hashlib.sha256(body).hexdigest()
    return out


def compare(tree: Path, sdist: Path) -> list[str]:
    a, b = digests(tree), digests(sdist)
    only_a64_hosts = "rrr_robot/fmus/aarch64-linux/"
    problems = [f"only in the tree's wheel: {n}" for n in sorted(set(a) - set(b))
                if not n.startswith(only_a64_hosts)]
    problems += [f"only in the sdist's wheel: {n}" for n in sorted(set(b) - set(a))]
    problems += [f"differs: {n}" for n in sorted(set(a) & set(b)) if a[n] != b[n]]
    same = sum(1 for n in set(a) & set(b) if a[n] == b[n] != "compiled")
    print(f"{tree.name} (tree) and {sdist.name} (sdist): {len(set(a) & set(b))} files in both, "
          f"{same} of them not compiled and byte for byte the same; only in the tree's: "
          f"{len(set(a) - set(b))} (the FMI 2.0 archives for aarch64 hosts)")
    return problems


def bundle(fmus: Path, ssp: Path, data: Path, out: Path) -> list[str]:
    names = (fmus / "fmu_names.txt").read_text().split()
    version = re.sub(r"^rrr_robot-fmus-|\.zip$", "", out.name)
    top = PurePosixPath(f"rrr_robot-fmus-{version}")
    files: dict[str, bytes] = {}
    problems = []
    for sub, platforms in FMU_PLATFORMS.items():
        for name in names:
            rel = f"{sub}/rrr_{name}.fmu" if sub else f"rrr_{name}.fmu"
            body = (fmus / rel).read_bytes()
            files[rel] = body
            with zipfile.ZipFile(io.BytesIO(body)) as z:
                have = {PurePosixPath(n).parts[1] for n in z.namelist()
                        if n.startswith("binaries/") and len(PurePosixPath(n).parts) > 2}
                if have != platforms:
                    problems.append(f"{rel}: binaries for {sorted(have)}, expected "
                                    f"{sorted(platforms)}")
                if sub == "":
                    for n in z.namelist():
                        if n.startswith("documentation/") and not n.endswith("/"):
                            files[f"documentation/rrr_{name}/{n[len('documentation/'):]}"] = (
                                z.read(n))
    # the FMI-LS-BUS network FMUs (FMI 3.0 only; docs/ls-bus.md), as the build lists them
    lsbus = (fmus / "lsbus_fmu_names.txt").read_text().split()
    for name in lsbus:
        rel = f"fmi3/rrr_{name}.fmu"
        body = (fmus / rel).read_bytes()
        files[rel] = body
        with zipfile.ZipFile(io.BytesIO(body)) as z:
            have = {PurePosixPath(n).parts[1] for n in z.namelist()
                    if n.startswith("binaries/") and len(PurePosixPath(n).parts) > 2}
            if have != FMU_PLATFORMS["fmi3"]:
                problems.append(f"{rel}: binaries for {sorted(have)}, expected "
                                f"{sorted(FMU_PLATFORMS['fmi3'])}")
            for n in z.namelist():
                if n.startswith("documentation/") and not n.endswith("/"):
                    files[f"documentation/rrr_{name}/{n[len('documentation/'):]}"] = z.read(n)
    files["fmu_names.txt"] = (fmus / "fmu_names.txt").read_bytes()
    files["lsbus_fmu_names.txt"] = (fmus / "lsbus_fmu_names.txt").read_bytes()
    files[ssp.name] = ssp.read_bytes()
    for f in ("rrr_cia402.eds", "rrr_bench.dbc"):
        files[f] = (data / f).read_bytes()
    sums = "".join(f"{hashlib.sha256(b).hexdigest()}  {n}\n" for n, b in sorted(files.items()))
    files["SHA256SUMS"] = sums.encode()
    tmp = out.with_name(out.name + ".part")
    with zipfile.ZipFile(tmp, "w", zipfile.ZIP_DEFLATED) as z:
        for n, b in sorted(files.items()):
            z.writestr(str(top / n), b)
    tmp.replace(out)
    print(f"{out}: {len(files)} files ({len(names)} FMUs x 3 archives, {len(lsbus)} FMI-LS-BUS "
          "network FMUs, the SSP archive, the EDS, the DBC, the documentation, SHA256SUMS)")
    return problems


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    b = sub.add_parser("bundle")
    b.add_argument("--fmus", type=Path, required=True)
    b.add_argument("--ssp", type=Path, required=True)
    b.add_argument("--data", type=Path, required=True)
    b.add_argument("--out", type=Path, required=True)
    s = sub.add_parser("scan")
    s.add_argument("files", type=Path, nargs="+")
    c = sub.add_parser("compare")
    c.add_argument("--tree", type=Path, required=True)
    c.add_argument("--sdist", type=Path, required=True)
    args = p.parse_args()
    if args.cmd == "bundle":
        problems = bundle(args.fmus, args.ssp, args.data, args.out)
    elif args.cmd == "scan":
        problems = [q for f in args.files for q in scan(f)]
    else:
        problems = compare(args.tree, args.sdist)
    for q in problems:
        print(f"dist_check {args.cmd}: {q}", file=sys.stderr)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
