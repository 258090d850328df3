"""The writing task's animations (rrr_robot.writing.animation): the arm's polyline ends at the
forward kinematics' tip, frames are taken at the stated rate, GIF and MP4 files show the arm and
the trace, bad requests are refused, and a failed write leaves no file (tests/python/
test_writing.py reads the animations of the default run)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from PIL import Image
from rrr_robot.core.param_names import model_fmu_values
from rrr_robot.sim.cosim import CosimOptions
from rrr_robot.sim.native import simulate
from rrr_robot.writing import animation as an
from rrr_robot.writing.job import WritingJob, controller_fmu_values, prepare


def pixels(rgb: np.ndarray, color: tuple[int, int, int]) -> int:
    return int(np.sum(np.all(np.abs(rgb.astype(int) - np.array(color)) <= 24, axis=2)))


@pytest.fixture(scope="module")
def short(tmp_path_factory: pytest.TempPathFactory) -> Any:
    """A one-letter reference and its ctc result through the native closed loop."""
    model, robot, scenarios, ref = prepare(WritingJob(out=tmp_path_factory.mktemp("u"),
                                                      text="a", scenarios=["ctc"]))
    options = CosimOptions(step=float(ref.t[1] - ref.t[0]), plant_values=model_fmu_values(model),
                           controller_values=controller_fmu_values(
                               scenarios[0], model, robot.require_control()))
    return model, ref, simulate(ref.t, ref.q, ref.qd, ref.qdd, ref.x, options)


def test_the_arm_ends_at_the_tip() -> None:
    rng = np.random.default_rng(4)
    model = rr.Model.default().with_params(d2=0.07, d3=-0.02)
    q = rng.uniform(-np.pi, np.pi, (200, 3))
    points = an.link_points(model, q)
    assert points.shape == (200, 7, 3)
    np.testing.assert_array_equal(points[:, 0], 0.0)
    np.testing.assert_allclose(points[:, -1], model.fk(q)[0], rtol=0, atol=1e-14)
    # the shoulder sits on the waist axis at height d1
    np.testing.assert_allclose(points[:, 1], [[0.0, 0.0, model.dh["d1"]]] * 200, atol=1e-15)


def test_frames_every_one_over_fps_and_the_last() -> None:
    t = np.arange(5911) * 1e-3
    idx = an.frame_indices(t, 15.0)
    assert idx[0] == 0 and idx[-1] == t.size - 1
    assert np.all(np.abs(np.diff(t[idx[:-1]]) - 1 / 15) < 1.5e-3)
    assert idx.size == 90
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(rr.BadInputError, match="fps"):
            an.frame_indices(t, bad)


def test_gif_first_frame_shows_the_arm(short: Any, tmp_path: Path) -> None:
    model, ref, res = short
    calls: list[tuple[int, int]] = []
    path = an.animate_result(tmp_path / "a.gif", model, ref, res, title="ctc", fmt="gif",
                             progress=lambda k, n: calls.append((k, n)))
    assert [p.name for p in tmp_path.iterdir()] == ["a.gif"]   # no temporary left
    n = an.frame_indices(res.t).size
    assert calls[-1] == (n, n) and len(calls) == n
    with Image.open(path) as gif:
        first = np.asarray(gif.convert("RGB"))
        gif.seek(gif.n_frames - 1)
        last = np.asarray(gif.convert("RGB"))
    assert pixels(first, an.LINK_COLOR) > 1000
    assert pixels(last, an.TRACE_COLOR) > pixels(first, an.TRACE_COLOR) + 50


def test_mp4(short: Any, tmp_path: Path) -> None:
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")  # in the test extra: never skipped
    model, ref, res = short
    assert an.animation_format("auto") == "mp4"
    path = an.animate_result(tmp_path / "a.mp4", model, ref, res, fmt="auto")
    assert path.read_bytes()[4:8] == b"ftyp"
    reader = imageio_ffmpeg.read_frames(str(path))
    meta = reader.__next__()
    w, h = meta["size"]
    first = np.frombuffer(next(reader), dtype=np.uint8).reshape(h, w, 3)
    reader.close()
    assert (w, h) == (512, 384)
    assert pixels(first, an.LINK_COLOR) > 500   # H.264 shifts colours a little


def test_bad_requests(short: Any, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    model, ref, res = short
    with pytest.raises(rr.BadInputError, match="unknown animation format"):
        an.animate_result(tmp_path / "a.avi", model, ref, res, fmt="avi")
    with pytest.raises(rr.BadInputError, match="its own reference"):
        short_ref = type(ref)(**{**ref.__dict__, "t": ref.t[:10]})
        an.animate_result(tmp_path / "a.gif", model, short_ref, res)
    monkeypatch.setattr(an, "mp4_available", lambda: False)
    assert an.animation_format("auto") == "gif"
    with pytest.raises(rr.BadInputError, match="imageio-ffmpeg"):
        an.animation_format("mp4")
    assert list(tmp_path.iterdir()) == []


def test_a_failed_write_leaves_nothing(short: Any, tmp_path: Path,
                                       monkeypatch: pytest.MonkeyPatch) -> None:
    """A drawing that fails after frames went to ffmpeg (the MP4 file is written as frames come)
    leaves the previous file as it was and no temporary."""
    pytest.importorskip("imageio_ffmpeg")
    model, ref, res = short
    drawn = []

    def broken(self: Any, k: int) -> np.ndarray:
        drawn.append(k)
        if len(drawn) > 5:
            raise RuntimeError("drawing failed")
        return np.zeros((384, 512, 3), dtype=np.uint8)

    monkeypatch.setattr(an._Scene, "draw", broken)
    for name in ("a.mp4", "a.gif"):
        (tmp_path / name).write_bytes(b"old")
        with pytest.raises(RuntimeError):
            an.animate_result(tmp_path / name, model, ref, res, fmt=name[2:])
        assert (tmp_path / name).read_bytes() == b"old"
        drawn.clear()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.gif", "a.mp4"]
