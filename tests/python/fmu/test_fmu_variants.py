"""Every variant of the FMUs: FMI 2.0 and 3.0, Model Exchange and Co-Simulation, rebuilt from
the sources inside the archive, on an old glibc.

Checks (the acceptance of the portable-FMU issue): fmpy validate finds no problem in any FMU
archive and FMPy simulates each interface of the plant and the controller; FMI 3.0 Co-Simulation
equals FMI 2.0 bit for bit (plant open loop; the writing task); the plant's Model Exchange under
FMPy's CVode (rtol 1e-10) agrees with its Co-Simulation to 1e-6 rad over 2 s; a binary rebuilt by
``fmpy compile`` or by the README's plain compiler command from the archive's sources/ gives the
shipped results within 1e-10; no FMU's Linux binaries need a glibc symbol newer than 2.28; each
FMU's documentation lists every variable.
"""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np
import pytest
import rrr_robot as rr
from fmpy import extract, read_model_description, simulate_fmu
from fmpy.validation import validate_fmu
from rrr_robot.sim.fmu_slave import FmuSlave
from rrr_robot.sim.fmus import FMU_NAMES, variants

VERSIONS = (2, 3)
NAMES = ("plant", "controller")  # the FMUs simulated here (their inputs and outputs below)
J = (1, 2, 3)
Q0 = {"q0[1]": 0.1, "q0[2]": 0.4, "q0[3]": 1.0}
U = {"u[1]": 0.5, "u[2]": 1.0, "u[3]": 0.3}
PLANT_OUT = [f"{s}[{i}]" for s in ("q", "qd", "qdd") for i in J] + ["tip.x", "tip.y", "tip.z"]
CTRL_IN = {**{f"q_ref[{i}]": 0.1 * i for i in J}, **{f"qd_ref[{i}]": 0.2 for i in J},
           **{f"qdd_ref[{i}]": -0.3 for i in J}, **{f"q[{i}]": 0.05 * i for i in J},
           **{f"qd[{i}]": 0.1 for i in J}}
CTRL_OUT = [f"{s}[{i}]" for s in ("u", "u_n", "u_c") for i in J]
LINUX = {2: "linux64", 3: "x86_64-linux"}


def fmu(which: str, version: int) -> Path:
    return rr.fmu_path(which, version)


def columns(result: np.ndarray, names: list[str]) -> np.ndarray:
    return np.column_stack([result[n] for n in names])


def simulate(path: Path | str, which: str, fmi_type: str, stop: float = 1.0,
             **kwargs: object) -> np.ndarray:
    start = {**Q0, **U} if which == "plant" else CTRL_IN
    out = PLANT_OUT if which == "plant" else CTRL_OUT
    res = simulate_fmu(str(path), fmi_type=fmi_type, stop_time=stop, output_interval=1e-3,
                       start_values=start, output=out, **kwargs)
    return columns(res, out)


def test_rrr_fmus_lists_every_variant() -> None:
    everything = variants()
    found = {(v.which, v.fmi_version): v for v in everything if not v.host}
    hosts = {v.which: v for v in everything if v.host}
    assert set(found) == {(w, v) for w in FMU_NAMES for v in VERSIONS}
    for (_, version), v in found.items():
        assert v.interfaces == ("ModelExchange", "CoSimulation")
        assert LINUX[version] in v.platforms
        assert v.has_sources and v.has_documentation
        assert v.linux_cpu == ("x86_64" if version == 2 else "")
    # the aarch64 Linux binaries (with gcc-aarch64-linux-gnu at build time; the test command
    # installs it): in every archive, and FMI 2.0 archives for aarch64 hosts, whose linux64 is
    # the same aarch64 binary (docs/aarch64.md)
    with_a64 = {k for k, v in found.items() if "aarch64-linux" in v.platforms}
    assert with_a64 in (set(), set(found)), with_a64
    if with_a64:
        assert set(hosts) == set(FMU_NAMES)
        for which, v in hosts.items():
            assert v.host == "aarch64-linux" and v.fmi_version == 2
            assert v.platforms == ("linux64",) and v.linux_cpu == "aarch64"
            assert v.platform_labels() == ["linux64 (aarch64)"]
            with zipfile.ZipFile(v.path) as a, zipfile.ZipFile(found[(which, 2)].path) as b:
                so = f"rrr_{which}.so"
                assert a.read(f"binaries/linux64/{so}") == b.read(f"binaries/aarch64-linux/{so}")
                assert a.read("modelDescription.xml") == b.read("modelDescription.xml")
                assert {n for n in a.namelist() if not n.startswith("binaries/")} == \
                    {n for n in b.namelist() if not n.startswith("binaries/")}
    else:
        assert not hosts
    cli = subprocess.run([sys.executable, "-m", "rrr_robot", "fmus"], capture_output=True,
                         text=True, check=True)
    lines = cli.stdout.strip().splitlines()
    n = len(FMU_NAMES)
    assert len(lines) == 2 * n + len(hosts) and sum("FMI 3.0" in x for x in lines) == n, \
        cli.stdout
    assert sum("linux64 (x86_64)" in x for x in lines) == n, cli.stdout
    assert sum("linux64 (aarch64)" in x for x in lines) == len(hosts), cli.stdout
    if with_a64:
        assert all("aarch64-linux" in x for x in lines if "FMI 3.0" in x), cli.stdout


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("which", FMU_NAMES)
def test_fmpy_validates(which: str, version: int) -> None:
    assert validate_fmu(str(fmu(which, version))) == []
    md = read_model_description(str(fmu(which, version)))
    assert md.fmiVersion == f"{version}.0"
    assert md.modelExchange is not None and md.coSimulation is not None


def test_fmpy_validates_the_aarch64_host_archives() -> None:
    """FMPy reads them like the others (it loads binaries/linux64 on aarch64 Linux); its
    supported_platforms (``fmpy info``) calls that folder linux64, whatever its CPU."""
    from fmpy import supported_platforms

    everything = variants()
    hosts = [v for v in everything if v.host]
    with_a64 = any("aarch64-linux" in v.platforms for v in everything if v.fmi_version == 3)
    assert len(hosts) == (len(FMU_NAMES) if with_a64 else 0)
    for v in hosts:
        assert validate_fmu(str(v.path)) == [], v.path
        assert supported_platforms(str(v.path)) == ["c-code", "linux64"]
    print(f"{len(hosts)} aarch64-host FMI 2.0 archives validated")


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("which", NAMES)
@pytest.mark.parametrize("fmi_type", ["CoSimulation", "ModelExchange"])
def test_fmpy_simulates_each_interface(which: str, version: int, fmi_type: str) -> None:
    x = simulate(fmu(which, version), which, fmi_type, stop=0.5)
    assert x.shape[0] >= 500 and np.all(np.isfinite(x))
    if which == "plant":
        assert np.ptp(x[:, 0:3], axis=0).min() > 1e-3  # the arm moves under the voltages
    else:
        assert np.ptp(x, axis=0).max() == 0.0  # constant inputs, constant outputs
        assert np.abs(x[0, 0:3]).max() > 0.1


def open_loop(path: Path, seconds: float) -> np.ndarray:
    rows = []
    with FmuSlave(path, "plant") as p:
        p.initialize(0.0, {**Q0, **U})
        out = p.real_block(PLANT_OUT)
        rows.append(p.get_block(out).copy())
        for _ in range(round(seconds / 1e-3)):
            p.do_step(1e-3)
            rows.append(p.get_block(out).copy())
    return np.array(rows)


def test_fmi3_cosimulation_equals_fmi2_bit_for_bit() -> None:
    a, b = open_loop(fmu("plant", 2), 1.0), open_loop(fmu("plant", 3), 1.0)
    assert a.shape == (1001, 12)
    assert np.array_equal(a, b)


def test_writing_task_fmi3_equals_fmi2(tmp_path: Path) -> None:
    from rrr_robot.writing.job import WritingJob, run_writing

    out = {}
    for version in VERSIONS:
        job = WritingJob(out=tmp_path / f"fmi{version}", scenarios=["ctc", "mismatch"],
                         figures=False, fmi_version=version)
        out[version] = run_writing(job)
    for name in ("ctc", "mismatch"):
        a = (tmp_path / "fmi2" / f"{name}.csv").read_bytes()
        b = (tmp_path / "fmi3" / f"{name}.csv").read_bytes()
        assert a == b, name
        assert out[2]["scenarios"][name]["tip_error_max"] == \
            out[3]["scenarios"][name]["tip_error_max"]
    assert out[3]["fmi_version"] == "3.0"


@pytest.mark.parametrize("version", VERSIONS)
def test_model_exchange_under_cvode_agrees_with_cosimulation(version: int) -> None:
    """2 s of open-loop motion under constant voltages (joint 3 spins up to > 10 rad/s)."""
    path = fmu("plant", version)
    cs = simulate(path, "plant", "CoSimulation", stop=2.0)
    me = simulate(path, "plant", "ModelExchange", stop=2.0, solver="CVode",
                  relative_tolerance=1e-10)
    assert cs.shape == me.shape == (2001, 12)
    assert np.abs(cs[:, 5]).max() > 10.0
    err = np.abs(cs[:, 0:3] - me[:, 0:3]).max()
    print(f"FMI {version}: max |q_ME - q_CS| over 2 s = {err:.2e} rad")
    assert err < 1e-6


def strip_linux_binary(src: Path, dst: Path, version: int) -> None:
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w", zipfile.ZIP_DEFLATED) as zout:
        for item in zin.infolist():
            if not item.filename.startswith(f"binaries/{LINUX[version]}/"):
                zout.writestr(item, zin.read(item.filename))
    with zipfile.ZipFile(dst) as z:
        assert not any(n.startswith(f"binaries/{LINUX[version]}/") and n.endswith(".so")
                       for n in z.namelist())


@pytest.mark.parametrize("version", VERSIONS)
def test_fmpy_compile_rebuilds_the_binary_from_the_archive(tmp_path: Path, version: int) -> None:
    shipped = fmu("plant", version)
    rebuilt = tmp_path / "rrr_plant.fmu"
    strip_linux_binary(shipped, rebuilt, version)
    fmpy = shutil.which("fmpy", path=str(Path(sys.executable).parent))
    assert fmpy is not None
    run = subprocess.run([fmpy, "compile", str(rebuilt)], capture_output=True, text=True)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    a = simulate(shipped, "plant", "CoSimulation")
    b = simulate(rebuilt, "plant", "CoSimulation")
    print(f"FMI {version}: fmpy compile vs shipped: max diff {np.abs(a - b).max():.2e}")
    assert np.abs(a - b).max() <= 1e-10


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("which", NAMES)
def test_plain_compiler_command_builds_a_working_binary(tmp_path: Path, which: str,
                                                        version: int) -> None:
    """The command of the README and of documentation/index.html, from the archive alone."""
    shipped = fmu(which, version)
    unzip = Path(extract(str(shipped), str(tmp_path / "fmu")))
    doc = (unzip / "documentation" / "index.html").read_text()
    command = re.search(r"^cc .*-lm$", doc, re.MULTILINE)
    assert command is not None
    sources = sorted(str(p.relative_to(unzip)) for p in (unzip / "sources").glob("*.c"))
    out = f"binaries/{LINUX[version]}/rrr_{which}.so"
    (unzip / out).unlink()
    argv = ["cc", "-std=c11", "-O2", "-shared", "-fPIC", "-fvisibility=hidden", "-o", out,
            *sources, "-lm"]
    assert command.group(0) == " ".join(argv[:7]) + f" rrr_{which}.so sources/*.c -lm"
    run = subprocess.run(argv, cwd=unzip, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    a = simulate(shipped, which, "CoSimulation", stop=0.5)
    b = simulate(unzip, which, "CoSimulation", stop=0.5)
    assert np.abs(a - b).max() <= 1e-10


def glibc_versions(binary: Path) -> set[tuple[int, ...]]:
    dump = subprocess.run(["objdump", "-T", str(binary)], capture_output=True, text=True,
                          check=True).stdout
    return {tuple(int(x) for x in v.split(".")) for v in re.findall(r"GLIBC_([0-9.]+)", dump)}


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("which", FMU_NAMES)
def test_linux_binaries_load_on_glibc_2_28(tmp_path: Path, which: str, version: int) -> None:
    unzip = Path(extract(str(fmu(which, version)), str(tmp_path)))
    versions = glibc_versions(unzip / "binaries" / LINUX[version] / f"rrr_{which}.so")
    print(f"rrr_{which} FMI {version}: GLIBC versions required: "
          f"{sorted('.'.join(map(str, v)) for v in versions)}")
    assert versions and max(versions) <= (2, 28)


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("which", FMU_NAMES)
def test_sources_and_documentation(tmp_path: Path, which: str, version: int) -> None:
    unzip = Path(extract(str(fmu(which, version)), str(tmp_path)))
    shipped_c = {p.name for p in (unzip / "sources").glob("*.c")}
    if version == 2:
        md = ET.parse(unzip / "modelDescription.xml").getroot()
        for interface in ("ModelExchange", "CoSimulation"):
            listed = {f.get("name") for f in md.findall(f"{interface}/SourceFiles/File")}
            assert listed == shipped_c, interface
    else:
        bd = ET.parse(unzip / "sources" / "buildDescription.xml").getroot()
        listed = {f.get("name") for f in bd.iter("SourceFile")}
        assert listed == shipped_c
    assert f"fmi{version}_functions.c" in shipped_c and "model.c" in shipped_c
    doc = (unzip / "documentation" / "index.html").read_text()
    md_vars = read_model_description(str(unzip)).modelVariables
    for v in md_vars:
        assert f"<code>{v.name}</code>" in doc, v.name
        if v.unit:
            assert f"<td>{v.unit}</td>" in doc, v.name
    assert "What it computes" in doc and "Conventions" in doc
