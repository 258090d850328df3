"""The writing task end to end through the FMUs and the CLI (paper section V)."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.sim.cosim import CosimOptions, run_cosim
from rrr_robot.writing.job import PAPER_RMS_U_N, WritingJob, run_writing

FIGURES = [
    "fig2_reference.png", "fig3_joint_positions.png", "fig4_joint_velocities.png",
    "fig5_ik_difference.png", "fig6_torque_difference.png", "fig7_letters_pd.png",
    "fig8_letters_ctc.png", "fig_letters_mismatch.png", "fig9_u2_ctc.png", "fig_u2_pd.png",
    "fig_u2_mismatch.png", "fig_tip_error.png",
]


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, dict]:
    out = tmp_path_factory.mktemp("writing")
    result = subprocess.run(
        [sys.executable, "-m", "rrr_robot", "writing", "--out", str(out), "--quiet",
         "--animate", "gif"],
        capture_output=True, text=True, timeout=900,
    )
    assert result.returncode == 0, result.stderr
    return out, json.loads((out / "summary.json").read_text())


def test_outputs_and_summary_shape(run: tuple[Path, dict]) -> None:
    out, summary = run
    assert set(summary["scenarios"]) == {"pd", "ctc", "mismatch"}
    for s in summary["scenarios"].values():
        assert len(s["rms_u_n"]) == 3 and len(s["rms_u_c"]) == 3
        for key in ("tip_error_max", "tip_error_rms", "wall_time", "realtime_factor"):
            assert isinstance(s[key], float) and np.isfinite(s[key]) and s[key] > 0
    for name in FIGURES:
        assert (out / name).stat().st_size > 10_000, name
    header = (out / "ctc.csv").read_text().splitlines()[0].split(",")
    assert header[:4] == ["t", "q_ref[1]", "q_ref[2]", "q_ref[3]"] and "tip.z" in header


def test_the_animations_show_the_arm_writing(run: tuple[Path, dict]) -> None:
    """--animate gif: one GIF per scenario; the first frame shows the arm (pixels of the link
    colour, far more than the legend's sample line), the last one the written text as well
    (pixels of the trace colour beyond those of the legend, which the first frame has alone);
    the three together well under 10 MB."""
    from PIL import Image
    from rrr_robot.writing.animation import FPS, LINK_COLOR, TRACE_COLOR

    out, summary = run
    names = [f"anim_{s}.gif" for s in ("pd", "ctc", "mismatch")]
    assert set(names) <= set(summary["files"])
    assert sum((out / n).stat().st_size for n in names) < 10e6

    def pixels(frame: Image.Image, color: tuple[int, int, int]) -> int:
        rgb = np.asarray(frame.convert("RGB"), dtype=int)
        return int(np.sum(np.all(np.abs(rgb - np.array(color)) <= 24, axis=2)))

    for name in names:
        with Image.open(out / name) as gif:
            assert gif.format == "GIF" and gif.size == (512, 384)
            assert gif.n_frames >= int(summary["reference"]["duration"] * FPS)
            assert pixels(gif, LINK_COLOR) > 1000, name     # the links, drawn 5 pt wide
            legend = pixels(gif, TRACE_COLOR)               # nothing written yet
            assert legend < 100, name
            gif.seek(gif.n_frames - 1)
            assert pixels(gif, LINK_COLOR) > 1000, name
            assert pixels(gif, TRACE_COLOR) - legend > 150, name     # the text


def test_feedforward_beats_pd_as_in_the_paper(run: tuple[Path, dict]) -> None:
    s = run[1]["scenarios"]
    assert s["ctc"]["tip_error_max"] * 5 <= s["pd"]["tip_error_max"]
    assert s["mismatch"]["tip_error_max"] < s["pd"]["tip_error_max"]
    for i in range(3):  # every joint carries inertia (and joints 2, 3 gravity)
        assert s["ctc"]["rms_u_n"][i] > s["ctc"]["rms_u_c"][i]
        assert s["mismatch"]["rms_u_n"][i] > s["mismatch"]["rms_u_c"][i]
    assert s["pd"]["rms_u_n"] == [0.0, 0.0, 0.0]


def test_default_robot_is_calibrated_to_eq16(run: tuple[Path, dict]) -> None:
    """Calibration, not validation: tools/calibrate_kt.py set k_t so RMS u_n matches eq 16."""
    rms = run[1]["scenarios"]["ctc"]["rms_u_n"]
    for got, paper in zip(rms, PAPER_RMS_U_N, strict=True):
        assert abs(got / paper - 1.0) < 0.25


def test_csv_matches_summary(run: tuple[Path, dict]) -> None:
    out, summary = run
    data = np.genfromtxt(out / "ctc.csv", delimiter=",", names=True)
    err = np.sqrt((data["tipx"] - data["x_refx"]) ** 2 + (data["tipy"] - data["x_refy"]) ** 2
                  + (data["tipz"] - data["x_refz"]) ** 2)
    assert err.max() == pytest.approx(summary["scenarios"]["ctc"]["tip_error_max"], rel=1e-9)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--scenario", "nonsense"], "unknown scenario 'nonsense'"),
        (["--scale", "6"], "writing area"),
        (["--text", "\u263a"], "\u263a"),
        (["--text", "a" * 5000], "at most 200"),
    ],
)
def test_bad_inputs_fail_before_simulating(tmp_path: Path, args: list[str], message: str) -> None:
    out = tmp_path / "out"
    result = subprocess.run(
        [sys.executable, "-m", "rrr_robot", "writing", "--out", str(out), "--quiet", *args],
        capture_output=True, text=True, timeout=300,
    )
    assert result.returncode != 0
    assert message in result.stderr
    assert not out.exists()  # nothing ran, nothing written


def test_malformed_scenario_file(tmp_path: Path) -> None:
    bad = tmp_path / "bad.toml"
    for text, message in [
        ("[scenario]\nname = 'x'\n", "needs a [scenario] table"),
        ("[scenario]\nname = 'x'\nfeedforward = true\n[gains]\nkp = [1, 2]\n", "kp must be"),
        ("[scenario]\nname = 'x'\nfeedforward = true\ncolor = 1\n", "unknown key"),
        ("[scenario\n", "malformed scenario file"),
    ]:
        bad.write_text(text)
        with pytest.raises(rr.BadInputError, match=message.replace("[", r"\[")):
            run_writing(WritingJob(out=tmp_path / "o", scenarios=[str(bad)]))
        assert not (tmp_path / "o").exists()


def test_fmu_error_is_a_clear_exception() -> None:
    """A rejected parameter surfaces as CosimError naming the FMU, the call and the time."""
    t = np.arange(0.0, 0.01, 1e-3)
    q = np.tile([0.3, 0.4, 1.0], (t.size, 1))
    zero = np.zeros_like(q)
    with pytest.raises(rr.CosimError, match=r"plant: fmi2ExitInitializationMode .* t = 0") as e:
        run_cosim(t, q, zero, zero, zero, CosimOptions(plant_values={"kt[2]": -1.0}))
    assert "kt[2]" in str(e.value)
    with pytest.raises(rr.BadInputError, match="no variable named 'kp'"):
        run_cosim(t, q, zero, zero, zero, CosimOptions(controller_values={"kp": 1.0}))
    with pytest.raises(rr.BadInputError, match="NaN"):
        run_cosim(t, q + np.nan, zero, zero, zero)


def test_unreadable_files_and_outputs_fail_cleanly(tmp_path: Path) -> None:
    """Binary robot or scenario files and an output path that is a file: a message and exit 2,
    no traceback, before any simulation."""
    binary = tmp_path / "binary.toml"
    binary.write_bytes(b"\xff\xfe\x00")
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    cases = [
        (["--robot", str(binary), "--out", str(tmp_path / "o1")], "robot file"),
        (["--scenario", str(binary), "--out", str(tmp_path / "o2")], "malformed scenario file"),
        (["--out", str(blocker), "--scenario", "ctc", "--no-figures"], "output folder"),
    ]
    for args, message in cases:
        result = subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--quiet", *args],
                                capture_output=True, text=True, timeout=300)
        assert result.returncode == 2, result.stderr
        assert message in result.stderr and "Traceback" not in result.stderr
    assert blocker.read_text() == "not a folder"


def _robot_files(folder: Path) -> tuple[Path, Path]:
    """default.toml (the packaged robot's file, copied) and heavy.toml (the same with a forearm
    of 4.0 kg instead of 2.5 kg: a payload)."""
    from rrr_robot.core.model import DEFAULT_ROBOT_TOML

    text = DEFAULT_ROBOT_TOML.read_text(encoding="utf-8")
    default, heavy = folder / "default.toml", folder / "heavy.toml"
    default.write_text(text, encoding="utf-8")
    assert text.count("\nmass = 2.5\n") == 1
    heavy.write_text(text.replace("\nmass = 2.5\n", "\nmass = 4.0\n"), encoding="utf-8")
    return default, heavy


def _writing(out: Path, *args: str) -> dict:
    result = subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--out", str(out),
                             "--text", "am", "--no-figures", "-q", *args],
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stderr
    return json.loads((out / "summary.json").read_text())


@pytest.mark.parametrize("engine", ["fmpy", "native"])
def test_controller_robot_of_the_same_file_is_the_plain_run(tmp_path: Path, engine: str) -> None:
    """--controller-robot FILE with the file of --robot: the tables of the plain run, byte for
    byte (also with [mismatch], which then perturbs the controller robot's model)."""
    default, _ = _robot_files(tmp_path)
    runs = {"plain": [], "twice": ["--controller-robot", str(default)]}
    summaries = {name: _writing(tmp_path / name, "--robot", str(default), "--engine", engine,
                                "--scenario", "ctc", "--scenario", "mismatch", *extra)
                 for name, extra in runs.items()}
    for scn in ("ctc", "mismatch"):
        plain = (tmp_path / "plain" / f"{scn}.csv").read_bytes()
        assert plain == (tmp_path / "twice" / f"{scn}.csv").read_bytes(), scn
    assert summaries["plain"]["controller_robot"] is None
    assert summaries["twice"]["controller_robot"] == str(default)


def test_controller_robot_runs_the_mismatch_asked_for(tmp_path: Path) -> None:
    """rrr writing --robot heavy.toml --controller-robot default.toml: the plant is the heavy
    arm (its motion differs from the default arm's), the controller computes the default model's
    feedforward (u_n, from the reference and its model only: the default run's, bit for bit),
    and the computed torque no longer cancels the dynamics (the tip error grows)."""
    from rrr_robot.core.tables import read_csv_table

    default, heavy = _robot_files(tmp_path)
    common = ["--scenario", "ctc", "--engine", "native"]
    tip = {name: _writing(tmp_path / name, *args, *common)["scenarios"]["ctc"]["tip_error_max"]
           for name, args in (("default", ["--robot", str(default)]),
                              ("heavy", ["--robot", str(heavy)]),
                              ("mismatch", ["--robot", str(heavy), "--controller-robot",
                                            str(default)]))}
    table = {name: read_csv_table(tmp_path / name / "ctc.csv")
             for name in ("default", "heavy", "mismatch")}
    for col in ("u_n[1]", "u_n[2]", "u_n[3]"):
        np.testing.assert_array_equal(table["mismatch"][col], table["default"][col])
        assert not np.array_equal(table["heavy"][col], table["default"][col])
    assert not np.array_equal(table["mismatch"]["q[2]"], table["default"]["q[2]"])
    assert tip["mismatch"] > 10 * tip["heavy"] and tip["mismatch"] > 10 * tip["default"], tip
