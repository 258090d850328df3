"""rrr ssp and rrr run-ssp: the writing task as an SSP 1.0 archive, run in libcosim and in FMPy.

One module fixture exports the archive of each built-in scenario (default text) and runs each in
both tools once through the command line (libcosim's and the FMI Library's log lines go to the
command's output, which is kept); rrr writing's figures for the same scenarios come from its
native engine (bit-identical to its FMPy co-simulation, tests/python/model/test_native_engine.py).
"""

from __future__ import annotations

import json
import re
import subprocess
import sys
import zipfile
from pathlib import Path
from typing import Any

import pytest
from rrr_robot.cli import main
from rrr_robot.core.tables import read_csv_table
from rrr_robot.ssp.archive import read_ssp
from rrr_robot.ssp.ssd import validate_ssd
from rrr_robot.writing.job import WritingJob, run_writing
from rrr_robot.writing.scenarios import BUILTIN
from support import REPO

TOOLS = ("libcosim", "fmpy")


def rrr(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "rrr_robot", *args], capture_output=True,
                          text=True, timeout=600, check=False)


@pytest.fixture(scope="module")
def runs(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Any]:
    root = tmp_path_factory.mktemp("ssp")
    writing = run_writing(WritingJob(out=root / "writing", engine="native", figures=False))
    out: dict[str, Any] = {"root": root, "writing": writing, "ssp": {}, "runs": {}}
    for scn in BUILTIN:
        ssp = root / f"{scn}.ssp"
        cli = rrr("ssp", "--out", str(ssp), "--scenario", scn)
        assert cli.returncode == 0, cli.stderr
        out["ssp"][scn] = ssp
        for tool in TOOLS:
            folder = root / f"{scn}-{tool}"
            figures = [] if (scn, tool) == ("ctc", "fmpy") else ["--no-figures"]
            run = rrr("-v", "run-ssp", str(ssp), "--tool", tool, "--out", str(folder), "-q",
                      *figures)
            assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
            summary = json.loads((folder / "summary.json").read_text())
            out["runs"][(scn, tool)] = (summary, folder, run.stdout + run.stderr)
    return out


def test_ssd_validates_and_describes_the_loop(runs: dict[str, Any]) -> None:
    ssp = runs["ssp"]["ctc"]
    with zipfile.ZipFile(ssp) as z:
        names = set(z.namelist())
        ssd = z.read("SystemStructure.ssd")
    assert names == {"SystemStructure.ssd", "resources/rrr_reference.fmu",
                     "resources/rrr_controller.fmu", "resources/rrr_plant.fmu"}
    validate_ssd(ssd, str(ssp))  # the SSP 1.0 schema that FMPy ships
    arch = read_ssp(ssp)
    assert set(arch.sources) == {"reference", "controller", "plant"}
    conns = {(a, b, c, d) for a, b, c, d in arch.connections}
    j = (1, 2, 3)
    expected = {("reference", f"{s}[{i}]", "controller", f"{s}[{i}]")
                for s in ("q_ref", "qd_ref", "qdd_ref") for i in j}
    expected |= {("plant", f"{s}[{i}]", "controller", f"{s}[{i}]")
                 for s in ("q", "qd", "qdd") for i in j}
    expected |= {("controller", f"u[{i}]", "plant", f"u[{i}]") for i in j}
    assert conns == expected
    ref = runs["writing"]["reference"]
    assert arch.step == ref["step"] == 1e-3
    assert arch.start_time == 0.0 and arch.stop_time == pytest.approx(ref["duration"], abs=1e-12)
    p = arch.parameters
    assert p["reference"] == {"lookahead": 1e-3}
    assert p["controller"]["lead"] == 1e-3 and p["controller"]["feedforward"] is True
    assert p["controller"]["kp[2]"] == 100.0 and len(p["controller"]) >= 47 + 8
    assert {"q0[1]", "qd0[3]", "a2", "p[16]"} <= set(p["plant"])
    assert arch.table["t"].size == round(ref["duration"] / ref["step"]) + 1
    pd = read_ssp(runs["ssp"]["pd"])
    assert pd.parameters["controller"]["feedforward"] is False


@pytest.mark.parametrize("tool", TOOLS)
@pytest.mark.parametrize("scenario", BUILTIN)
def test_tool_tracks_the_letters_like_rrr_writing(runs: dict[str, Any], scenario: str,
                                                  tool: str) -> None:
    summary, folder, _ = runs["runs"][(scenario, tool)]
    ours = runs["writing"]["scenarios"][scenario]
    got = summary["scenarios"][scenario]
    assert got["status"] == "ok"
    assert got["tip_error_max"] <= 2.0 * ours["tip_error_max"], (got, ours)
    assert got["tip_error_max"] > 0.0
    # the same format: the metrics of rrr writing, the columns of its table
    assert set(got) == set(ours)
    assert set(summary) >= {"scenarios", "reference", "engine", "files", "paper_eq16"}
    figures = [f for f in summary["files"] if f.endswith(".png")]
    assert [f for f in summary["files"] if f not in figures] == [f"{scenario}.csv",
                                                                 "summary.json"]
    if (scenario, tool) == ("ctc", "fmpy"):  # the figures of rrr writing for this scenario
        assert figures == sorted(["fig2_reference.png", "fig3_joint_positions.png",
                                  "fig4_joint_velocities.png", "fig5_ik_difference.png",
                                  "fig6_torque_difference.png", "fig8_letters_ctc.png",
                                  "fig9_u2_ctc.png", "fig_tip_error.png"])
    else:
        assert figures == []
    table = read_csv_table(folder / f"{scenario}.csv")
    theirs = read_csv_table(runs["root"] / "writing" / f"{scenario}.csv")
    assert list(table) == list(theirs)
    assert table["t"].size == theirs["t"].size - 1  # the tools record from the first step's end
    assert table["t"][0] == pytest.approx(1e-3) and table["t"][-1] == pytest.approx(
        theirs["t"][-1])


@pytest.mark.parametrize("scenario", ["ctc", "pd"])
def test_an_importer_that_ignores_the_bindings_runs_the_same_system(
        runs: dict[str, Any], scenario: str) -> None:
    """FMPy's plain simulate_ssp, with no parameter set (it applies no SSD binding and no XML
    start value itself; only the archive's experiment times are given): the FMUs in the archive
    start with the scenario's values (resources/start_values.csv, read by their binaries), so
    it tracks as rrr writing does (before: the arm started away from the text, 386 mm)."""
    import numpy as np
    from fmpy import read_model_description
    from fmpy.ssp.simulation import simulate_ssp
    from rrr_robot.ssp.archive import reference_rows

    ssp = runs["ssp"][scenario]
    arch = read_ssp(ssp)
    res = simulate_ssp(str(ssp), start_time=arch.start_time, stop_time=arch.stop_time,
                       step_size=arch.step)
    t_end = res["time"] + arch.step  # FMPy records a step's outputs under its start time
    keep = t_end <= arch.stop_time + 1e-9
    ref = reference_rows(arch.table, t_end[keep], arch.step, str(ssp))
    tip = np.column_stack([res[f"plant.tip.{a}"][keep] for a in "xyz"])
    x_ref = np.column_stack([ref[f"x_ref.{a}"] for a in "xyz"])
    err = float(np.linalg.norm(tip - x_ref, axis=1).max())
    ours = runs["writing"]["scenarios"][scenario]["tip_error_max"]
    assert 0.0 < err <= 2.0 * ours, (err, ours)
    # the same run as with the bindings applied (rrr run-ssp --tool fmpy), to the last bit
    with_bindings = read_csv_table(runs["runs"][(scenario, "fmpy")][1] / f"{scenario}.csv")
    for a, col in zip("xyz", ("tip.x", "tip.y", "tip.z"), strict=True):
        assert np.array_equal(res[f"plant.tip.{a}"][keep], with_bindings[col])
    # the XML's start values are the bindings too (for tools that read them)
    with zipfile.ZipFile(ssp) as z:
        for comp, params in arch.parameters.items():
            member = f"resources/rrr_{comp}.fmu"
            (Path(runs["root"]) / f"{scenario}-{comp}.fmu").write_bytes(z.read(member))
            md = read_model_description(str(Path(runs["root"]) / f"{scenario}-{comp}.fmu"))
            starts = {v.name: v.start for v in md.modelVariables}
            for name, value in params.items():
                want = ("true" if value else "false") if isinstance(value, bool) else value
                got = starts[name]
                assert (got == want if isinstance(value, bool) else float(got) == value), \
                    (comp, name, got, value)


def test_libcosim_and_fmpy_agree(runs: dict[str, Any]) -> None:
    for scn in BUILTIN:
        a = runs["runs"][(scn, "libcosim")][0]["scenarios"][scn]["tip_error_max"]
        b = runs["runs"][(scn, "fmpy")][0]["scenarios"][scn]["tip_error_max"]
        assert abs(a - b) <= 0.05 * a, (scn, a, b)


def test_libcosim_prints_no_fmi_library_errors(runs: dict[str, Any]) -> None:
    for scn in BUILTIN:
        log = runs["runs"][(scn, "libcosim")][2]
        assert log.count("[FMI Library: FMILIB] Loading 'linux64' binary") == 3, log[-2000:]
        bad = [x for x in log.splitlines() if re.search(r"\[(error|warning|fatal)\]", x)]
        assert bad == []


def test_packaged_table_is_what_the_generator_writes(tmp_path: Path) -> None:
    out = tmp_path / "reference.csv"
    gen = subprocess.run([sys.executable, str(REPO / "tools" / "make_reference_table.py"),
                          str(out)], capture_output=True, text=True, check=False)
    assert gen.returncode == 0, gen.stderr
    committed = REPO / "fmu" / "reference" / "resources" / "reference.csv"
    assert out.read_bytes() == committed.read_bytes()


def _rewrite(src: Path, dst: Path, drop: str = "",
             edit: tuple[str, str] | None = None) -> Path:
    """A copy of an archive without the member ``drop`` and with one SSD text replaced."""
    with zipfile.ZipFile(src) as zin, zipfile.ZipFile(dst, "w") as zout:
        for item in zin.infolist():
            if item.filename == drop:
                continue
            data = zin.read(item.filename)
            if edit is not None and item.filename == "SystemStructure.ssd":
                text = data.decode()
                assert edit[0] in text
                data = text.replace(edit[0], edit[1], 1).encode()
            zout.writestr(item, data)
    return dst


BROKEN = {
    "missing FMU": ({"drop": "resources/rrr_plant.fmu"},
                    "component plant: its FMU 'resources/rrr_plant.fmu' is not in the archive"),
    "bad connection": ({"edit": ('endElement="plant" endConnector="u[2]"',
                                 'endElement="plant" endConnector="v[2]"')},
                       "bad connection controller.u[2] -> plant.v[2]"),
    "input twice": ({"edit": ('startConnector="q[1]" endElement="controller" '
                              'endConnector="q[1]"',
                              'startConnector="q[1]" endElement="controller" '
                              'endConnector="q[2]"')},
                    "input controller.q[1] has 0 connections, expected 1"),
    "output as input": ({"edit": ('endElement="plant" endConnector="u[1]"',
                                  'endElement="plant" endConnector="q[1]"')},
                        "bad connection controller.u[1] -> plant.q[1]"),
    "schema": ({"edit": ('kind="input"', 'kind="sideways"')},
               "does not validate against the SSP 1.0 schema"),
    "no SSD": ({"drop": "SystemStructure.ssd"}, "the archive has no SystemStructure.ssd"),
    "unknown parameter": ({"edit": ('<ssv:Parameter name="lookahead">',
                                    '<ssv:Parameter name="look_ahead">')},
                          "'look_ahead' is no parameter of resources/rrr_reference.fmu"),
}


@pytest.mark.parametrize("case", list(BROKEN))
def test_broken_archive_is_a_clear_error(runs: dict[str, Any], tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str], case: str) -> None:
    how, message = BROKEN[case]
    broken = _rewrite(runs["ssp"]["ctc"], tmp_path / "broken.ssp", **how)  # type: ignore[arg-type]
    out = tmp_path / "out"
    for tool in TOOLS:
        assert main(["run-ssp", str(broken), "--tool", tool, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert err.startswith("rrr: error: ") and message in err, err
        assert len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_not_an_archive_and_bad_options(tmp_path: Path,
                                        capsys: pytest.CaptureFixture[str]) -> None:
    junk = tmp_path / "junk.ssp"
    junk.write_text("not a zip")
    out = tmp_path / "out"
    assert main(["run-ssp", str(junk), "--tool", "fmpy", "--out", str(out)]) == 2
    assert "not an SSP archive" in capsys.readouterr().err
    assert main(["run-ssp", str(tmp_path / "none.ssp"), "--tool", "fmpy", "--out",
                 str(out)]) == 2
    assert "no such SSP file" in capsys.readouterr().err
    assert main(["run-ssp", str(junk), "--tool", "fmpy", "--real-time", "--out",
                 str(out)]) == 2
    assert "--real-time needs --tool libcosim" in capsys.readouterr().err
    assert main(["ssp", "--out", str(tmp_path / "x.zip")]) == 2
    assert "must name an .ssp file" in capsys.readouterr().err
    assert main(["ssp", "--out", str(tmp_path / "x.ssp"), "--scenario", "nope"]) == 2
    assert "unknown scenario 'nope'" in capsys.readouterr().err
    assert not out.exists() and not (tmp_path / "x.ssp").exists()


def test_controller_robot_sets_the_controllers_parameters(tmp_path: Path) -> None:
    """rrr ssp --robot heavy.toml --controller-robot default.toml: the plant's bindings are the
    heavy arm's model, the controller's the default robot's (rrr writing --controller-robot);
    the archive names both files."""
    from rrr_robot.core.model import DEFAULT_ROBOT_TOML
    from rrr_robot.core.param_names import model_fmu_values
    from rrr_robot.core.robot import read_robot_file

    text = DEFAULT_ROBOT_TOML.read_text(encoding="utf-8")
    heavy = tmp_path / "heavy.toml"
    heavy.write_text(text.replace("\nmass = 2.5\n", "\nmass = 4.0\n"), encoding="utf-8")
    ssp = tmp_path / "mix.ssp"
    assert main(["ssp", "--out", str(ssp), "--text", "am", "--robot", str(heavy),
                 "--controller-robot", str(DEFAULT_ROBOT_TOML), "-q"]) == 0
    arch = read_ssp(ssp)
    plant = model_fmu_values(read_robot_file(heavy).model)
    controller = model_fmu_values(read_robot_file(DEFAULT_ROBOT_TOML).model)
    assert plant["p[1]"] != controller["p[1]"]
    for name, value in plant.items():
        assert arch.parameters["plant"][name] == value, name
    for name, value in controller.items():
        assert arch.parameters["controller"][name] == value, name
    assert arch.info["robot"] == "heavy.toml"
    assert arch.info["controller_robot"] == DEFAULT_ROBOT_TOML.name
