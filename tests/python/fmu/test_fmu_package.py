"""The FMUs as files: fmpy validate, fmpy simulate, the model description (names, units,
causality, structure, GUID) and the one source of truth for value references: the committed
modelDescription.xml files equal the ones the build generated from the C variable tables, and
every start value in them is what the binary reports (and, in the plant and the controller,
what librrr's defaults are).
"""

from __future__ import annotations

import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description, simulate_fmu
from fmpy.validation import validate_fmu
from support.fmu_support import COMMITTED_XML, FMU_NAMES, MODEL_FMUS, STEP, Slave, fmu_file, joint

MODEL_PARAMS = (
    [("d1", "m"), ("a2", "m"), ("a3", "m"), ("d2", "m"), ("d3", "m"), ("g", "m/s2")]
    + [(f"p[{i}]", "kg.m" if i in (3, 4, 15, 16) else "kg.m2") for i in range(1, 17)]
    + [(n, "N.m/V") for n in joint("kt")]
    + [(f"f[{i},{k}]", "V") for i in (1, 2, 3) for k in (1, 2, 3)]
    + [(f"w[{i},{k}]", "s/rad") for i in (1, 2, 3) for k in (1, 2, 3)]
    + [(n, "V.s/rad") for n in joint("b")]
    + [("u_max", "V")]
)

# name -> (causality, unit) as the issue specifies them
EXPECTED: dict[str, dict[str, tuple[str, str | None]]] = {
    "plant": {
        **{n: ("input", "V") for n in joint("u")},
        **{n: ("output", "rad") for n in joint("q")},
        **{n: ("output", "rad/s") for n in joint("qd")},
        **{n: ("output", "rad/s2") for n in joint("qdd")},
        **{f"tip.{c}": ("output", "m") for c in "xyz"},
        **{n: ("parameter", u) for n, u in MODEL_PARAMS},
        **{n: ("parameter", "rad") for n in joint("q0")},
        **{n: ("parameter", "rad/s") for n in joint("qd0")},
        "h_int": ("parameter", "s"),
        "adaptive": ("parameter", None),
        "rtol": ("parameter", None),
        "atol": ("parameter", None),
    },
    "controller": {
        **{n: ("input", "rad") for n in joint("q_ref") + joint("q")},
        **{n: ("input", "rad/s") for n in joint("qd_ref") + joint("qd")},
        **{n: ("input", "rad/s2") for n in joint("qdd_ref") + joint("qdd")},
        **{n: ("output", "V") for n in joint("u") + joint("u_n") + joint("u_c")},
        **{n: ("parameter", "V/rad") for n in joint("kp")},
        **{n: ("parameter", "V.s/rad") for n in joint("kd")},
        "feedforward": ("parameter", None),
        "lead": ("parameter", "s"),
        **{n: ("parameter", u) for n, u in MODEL_PARAMS},
    },
}


@pytest.mark.parametrize("which", FMU_NAMES)
def test_fmpy_validate_finds_no_problems(which: str) -> None:
    path = fmu_file(which)
    assert validate_fmu(str(path)) == []
    cli = subprocess.run(
        [sys.executable, "-m", "fmpy", "validate", str(path)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert cli.returncode == 0, cli.stdout + cli.stderr
    assert "No problems found." in cli.stdout


@pytest.mark.parametrize("which", FMU_NAMES)
def test_fmpy_simulate_runs_the_default_experiment(which: str) -> None:
    result = simulate_fmu(str(fmu_file(which)), validate=True)
    assert len(result) == 1001
    np.testing.assert_allclose(result["time"][[0, 1, -1]], [0.0, STEP, 1.0], atol=1e-12)
    for name in result.dtype.names:
        assert np.all(np.isfinite(result[name])), name


def test_fmpy_simulate_cli(tmp_path: object) -> None:
    # the fmpy command that FMPy installed beside this interpreter (a venv need not be
    # activated, so PATH is not asked)
    fmpy_exe = shutil.which("fmpy", path=str(Path(sys.executable).parent))
    assert fmpy_exe is not None, f"no fmpy command beside {sys.executable} (installed with FMPy)"
    for which in FMU_NAMES:
        out = f"{tmp_path}/{which}.csv"
        cli = subprocess.run(
            [fmpy_exe, "simulate", str(fmu_file(which)), "--output-file", out],
            capture_output=True,
            text=True,
            check=False,
        )
        assert cli.returncode == 0, cli.stdout + cli.stderr
        rows = np.genfromtxt(out, delimiter=",", names=True)
        assert len(rows) == 1001 and np.all(np.isfinite(rows.view((float, len(rows.dtype)))))


@pytest.mark.parametrize("which", FMU_NAMES)
def test_committed_xml_equals_the_generated_one(which: str) -> None:
    """The FMU ships the XML the build printed from the C variable table."""
    with zipfile.ZipFile(fmu_file(which)) as zf:
        shipped = zf.read("modelDescription.xml")
        names = zf.namelist()
    committed = COMMITTED_XML[which].read_bytes()
    assert shipped == committed, (
        f"{COMMITTED_XML[which]} is out of date: build the CMake target rrr_fmu_update_xml"
    )
    assert f"binaries/linux64/rrr_{which}.so" in names


@pytest.mark.parametrize("which", MODEL_FMUS)
def test_model_description(which: str) -> None:
    with Slave(which) as s:
        md = s.md
    assert md.fmiVersion == "2.0"
    assert md.coSimulation is not None and md.modelExchange is not None  # one binary, both
    assert md.coSimulation.modelIdentifier == f"rrr_{which}"
    assert md.modelExchange.modelIdentifier == f"rrr_{which}"
    for interface in (md.coSimulation, md.modelExchange):
        assert interface.canGetAndSetFMUstate and interface.canSerializeFMUstate
    assert md.coSimulation.canHandleVariableCommunicationStepSize
    assert float(md.defaultExperiment.stepSize) == STEP
    assert {c.name for c in md.logCategories} >= {"logStatusError", "logCalls"}
    variables = {v.name: v for v in md.modelVariables}
    assert {k: (v.causality, v.unit) for k, v in variables.items()} == EXPECTED[which]
    for v in md.modelVariables:
        assert v.description, v.name
        if v.causality == "parameter":
            assert v.variability == "fixed" and v.initial == "exact", v.name
        else:
            assert v.variability == "continuous", v.name
    for flag in ("feedforward", "adaptive"):
        assert variables.get(flag) is None or variables[flag].type == "Boolean"
    vrs = sorted(v.valueReference for v in md.modelVariables)
    assert vrs == list(range(len(vrs)))


def test_model_structure() -> None:
    with Slave("plant") as p, Slave("controller") as c:
        plant = {o.variable.name: {d.name for d in o.dependencies} for o in p.md.outputs}
        ctrl = {o.variable.name: {d.name for d in o.dependencies} for o in c.md.outputs}
        derivatives = {d.variable.name: (d.variable.derivative.name,
                                         {k.name for k in d.dependencies})
                       for d in p.md.derivatives}
    u = set(joint("u"))
    # q and qd are continuous states: an output that is a state depends on that state only (no
    # direct feedthrough from u); the tip on q (tip.z = d1 + a2 s2 + a3 s23: not on q1); qdd
    # on u, qd, q2 and q3 (D, c, h ignore q1). tests/python/fmu/test_fmu_derivatives.py checks
    # every entry and kind against the numbers.
    for name in joint("q") + joint("qd"):
        assert plant[name] == {name}, name
    for name in ["tip.x", "tip.y"]:
        assert plant[name] == set(joint("q")), name
    assert plant["tip.z"] == {"q[2]", "q[3]"}
    accel = u | set(joint("qd")) | {"q[2]", "q[3]"}
    for name in joint("qdd"):
        assert plant[name] == accel
    assert derivatives == {
        **{f"qd[{i}]": (f"q[{i}]", {f"qd[{i}]"}) for i in (1, 2, 3)},
        **{f"qdd[{i}]": (f"qd[{i}]", accel) for i in (1, 2, 3)},
    }
    assert not c.md.derivatives  # the controller has no states
    # the feedforward: the dynamics do not depend on q1, so neither does u_n
    ref = set(joint("q_ref") + joint("qd_ref") + joint("qdd_ref")) - {"q_ref[1]"}
    for i in (1, 2, 3):
        # qdd[i] through the predictor (parameter lead)
        pd = {f"q_ref[{i}]", f"qd_ref[{i}]", f"q[{i}]", f"qd[{i}]", f"qdd[{i}]"}
        assert ctrl[f"u_n[{i}]"] == ref
        assert ctrl[f"u_c[{i}]"] == pd
        assert ctrl[f"u[{i}]"] == ref | pd


@pytest.mark.parametrize("which", FMU_NAMES)
def test_guid_is_checked(which: str) -> None:
    s = Slave(which, guid="{00000000-0000-0000-0000-000000000000}")
    with pytest.raises(Exception, match="Failed to instantiate"):
        s.instantiate()
    assert any("wrong GUID" in m for m in s.errors())


@pytest.mark.parametrize("which", FMU_NAMES)
def test_xml_start_values_are_the_binary_defaults(which: str) -> None:
    with Slave(which).instantiate() as s:
        s.fmu.enterInitializationMode()
        for v in s.md.modelVariables:
            if v.causality == "output":
                assert v.start is None and v.initial == "calculated", v.name
                continue
            if v.type == "Boolean":
                got = s.fmu.getBoolean([v.valueReference])[0]
                assert got == (v.start in ("true", True)), v.name
            else:
                got = s.fmu.getReal([v.valueReference])[0]
                assert got == float(v.start), v.name  # bit for bit: shortest round-trip text


def test_defaults_equal_the_core_defaults() -> None:
    """Cross-check with the Python binding of librrr (the C harness checks the same in C)."""
    import rrr_robot

    m = rrr_robot.Model.default()
    expected = {**m.dh, "g": m.g, "u_max": m.u_max}
    expected |= {f"p[{i + 1}]": float(x) for i, x in enumerate(m.p)}
    expected |= {f"kt[{i + 1}]": float(x) for i, x in enumerate(m.kt)}
    expected |= {f"b[{i + 1}]": float(x) for i, x in enumerate(m.b)}
    for i in range(3):
        for k in range(3):
            expected[f"f[{i + 1},{k + 1}]"] = float(m.f[i][k])
            expected[f"w[{i + 1},{k + 1}]"] = float(m.w[i][k])
    for which in MODEL_FMUS:
        with Slave(which).instantiate() as s:
            s.fmu.enterInitializationMode()
            got = dict(zip(expected, s.get(expected), strict=True))
        assert got == expected


@pytest.mark.parametrize("which", FMU_NAMES)
@pytest.mark.parametrize("fmi", [2, 3])
def test_documentation_lists_the_archives_binaries(which: str, fmi: int) -> None:
    """documentation/index.html names exactly the binaries/ folders of its archive (the build
    passes them to the generator: aarch64-linux too when it had the cross compiler)."""
    import re

    import rrr_robot

    with zipfile.ZipFile(rrr_robot.fmu_path(which, fmi)) as z:
        page = z.read("documentation/index.html").decode()
        folders = {n.split("/")[1] for n in z.namelist()
                   if n.startswith("binaries/") and n.count("/") >= 2}
    item = re.search(r"<li>Binaries in <code>binaries/</code>: (.*?)</li>", page)
    assert item, "the page lists no binaries"
    listed = set(re.findall(r"<code>([^<]+)</code>", item[1].split(" (")[0]))
    assert listed == folders, (listed, folders)


#: How close a fresh FMPy simulation of the default experiment comes to the reference result in
#: the archive, relative to each column's largest magnitude: Co-Simulation runs the same code
#: (measured 3e-11 at most: FMPy's communication points differ from k * h in the last bits, which
#: the adaptive step control carries on), Model Exchange integrates with CVode at the default
#: experiment's tolerance 1e-8 (measured 1.1e-5, the plant's qdd[3]).
REFERENCE_RTOL = {"CoSimulation": 1e-9, "ModelExchange": 1e-4}


@pytest.mark.parametrize("which", FMU_NAMES)
@pytest.mark.parametrize("fmi", [2, 3])
def test_the_reference_result_is_a_fresh_simulation(which: str, fmi: int) -> None:
    """Each archive carries its default experiment's result as the Reference-FMUs do (the
    layered standard FMI-LS-REF): extra/org.fmi-standard.fmi-ls-ref/ holds the manifest and
    rrr_<name>_out.csv (time and every output), written by the build. FMPy simulating the
    archive's default experiment, in both interfaces, gives it within REFERENCE_RTOL."""
    import io
    import xml.etree.ElementTree as ET

    import rrr_robot

    path = rrr_robot.fmu_path(which, fmi)
    folder = "extra/org.fmi-standard.fmi-ls-ref/"
    with zipfile.ZipFile(path) as z:
        manifest = ET.fromstring(z.read(folder + "fmi-ls-manifest.xml"))
        related = manifest.find("Related")
        assert related is not None and related.get("role") == "result"
        assert manifest.get("{http://fmi-standard.org/fmi-ls-manifest}fmi-ls-name") == \
            "org.fmi-standard.fmi-ls-ref"
        text = z.read(folder + related.get("source", "")).decode()
    header = text.split("\n", 1)[0].split(",")
    ref = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1)
    outputs = [v.name for v in read_model_description(str(path)).modelVariables
               if v.causality == "output"]
    assert header == ["time", *outputs]
    assert ref.shape == (1001, len(header)) and ref[-1, 0] == 1.0  # 0 to 1 s at 1 ms
    for kind, rtol in REFERENCE_RTOL.items():
        res = simulate_fmu(str(path), fmi_type=kind, output=outputs)
        np.testing.assert_array_equal(res["time"], ref[:, 0])
        for k, name in enumerate(outputs, start=1):
            scale = max(float(np.abs(ref[:, k]).max()), 1.0)
            err = float(np.abs(res[name] - ref[:, k]).max())
            assert err <= rtol * scale, (kind, name, err, scale)
