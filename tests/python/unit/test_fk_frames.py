"""Model.fk_frames (rrr_fk_frames): every DH frame and the tool, against Model.fk (bit for bit),
a DH chain built here with numpy, and the URDF export read by Pinocchio (link k = frame k-1
turned by q_k, tool = frame 3); bad input refused naming the row."""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin
import pytest
import rrr_robot as rr
from rrr_robot.core.urdf import write_urdf

MODEL = rr.Model.default()


def rz(theta: float) -> np.ndarray:
    c, s = math.cos(theta), math.sin(theta)
    return np.array([[c, -s, 0, 0], [s, c, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1.0]])


def placement(d: float, a: float, alpha: float) -> np.ndarray:
    c, s = math.cos(alpha), math.sin(alpha)
    return np.array([[1, 0, 0, a], [0, c, -s, 0], [0, s, c, d], [0, 0, 0, 1.0]])


def test_tool_frame_is_fk_bit_for_bit_and_batches_match_rows() -> None:
    q = np.random.default_rng(1).uniform(-4, 4, (500, 3))
    frames = MODEL.fk_frames(q)
    assert frames.shape == (500, 4, 4, 4) and frames.dtype == np.float64
    x, rot = MODEL.fk(q, simd="scalar")  # the batch kernels: within 1e-13 (test_batch.py)
    assert np.array_equal(frames[:, 3, :3, 3], x)
    assert np.array_equal(frames[:, 3, :3, :3], rot)
    assert np.array_equal(frames[:, :, 3, :], np.broadcast_to([0, 0, 0, 1.0], (500, 4, 4)))
    assert np.array_equal(frames[:, 0], np.broadcast_to(np.eye(4), (500, 4, 4)))
    one = MODEL.fk_frames(q[7])
    assert one.shape == (4, 4, 4) and np.array_equal(one, frames[7])


def test_frames_are_the_dh_chain() -> None:
    dh = MODEL.dh
    table = [(dh["d1"], 0.0, math.pi / 2), (dh["d2"], dh["a2"], 0.0), (dh["d3"], dh["a3"], 0.0)]
    for q in np.random.default_rng(2).uniform(-4, 4, (200, 3)):
        frames = MODEL.fk_frames(q)
        chain = np.eye(4)
        for k in range(3):
            chain = chain @ rz(q[k]) @ placement(*table[k])
            np.testing.assert_allclose(frames[k + 1], chain, rtol=0, atol=1e-15)


def test_frames_are_the_urdf_links(tmp_path) -> None:
    """Pinocchio's placement of each URDF joint frame (= the link frame) and of the tool."""
    urdf = write_urdf(tmp_path / "rrr.urdf")
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    tool = model.getFrameId("tool")
    for q in np.random.default_rng(3).uniform(-3, 3, (100, 3)):
        pin.framesForwardKinematics(model, data, q)
        frames = MODEL.fk_frames(q)
        for k in range(1, 4):
            link = data.oMi[model.getJointId(f"joint{k}")].homogeneous
            np.testing.assert_allclose(link, frames[k - 1] @ rz(q[k - 1]), rtol=0, atol=1e-12)
        np.testing.assert_allclose(data.oMf[tool].homogeneous, frames[3], rtol=0, atol=1e-12)


@pytest.mark.parametrize("bad", [[0.1, math.nan, 0.3], [math.inf, 0, 0]])
def test_bad_input_is_refused(bad: list[float]) -> None:
    with pytest.raises(rr.BadInputError, match=r"rrr_fk_frames.*sample 1"):
        MODEL.fk_frames([[0.0, 0.0, 0.0], bad])
    with pytest.raises(rr.BadInputError, match="rrr_fk_frames"):
        MODEL.fk_frames(bad)
