"""The writing task (paper section V): reference path in the writing plane with pen lifts,
closed-form IK reproduced by FK, joint rates consistent with finite differences, C2 continuity,
rest at both ends, fast and slow phases, agreement with the Robotics Toolbox numeric IK (the
paper's Fig 5), and clear errors for texts that cannot be written."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.core.model import DEFAULT_ROBOT_TOML
from rrr_robot.writing import trajectory as tr
from rrr_robot.writing.letters import join_strokes, text_strokes
from rrr_robot.writing.references import numeric_ik_path, numeric_references


def wrap(a: np.ndarray) -> np.ndarray:
    return (a + np.pi) % (2 * np.pi) - np.pi


@pytest.fixture(scope="module")
def ref(model: rr.Model) -> tr.Reference:
    return tr.make_reference(model)


# ---- shape of the reference -----------------------------------------------------------------
def test_default_text_has_the_papers_letters() -> None:
    assert all(ch in tr.DEFAULT_TEXT for ch in "\u03c9m\u03b3")  # omega, m, gamma


def test_uniform_grid_and_shapes(ref: tr.Reference) -> None:
    n = ref.t.size
    np.testing.assert_allclose(np.diff(ref.t), ref.spec.dt, rtol=0, atol=1e-12)
    for name in ("x", "xd", "xdd", "q", "qd", "qdd"):
        assert getattr(ref, name).shape == (n, 3), name
        assert np.all(np.isfinite(getattr(ref, name))), name
    assert ref.pen_down.shape == ref.speed.shape == ref.s.shape == (n,)
    assert np.all(np.diff(ref.s) >= -1e-12), "the path parameter runs forwards"


def test_pen_down_in_plane_pen_up_out_of_it(ref: tr.Reference) -> None:
    spec = ref.spec
    np.testing.assert_array_equal(ref.x[ref.pen_down, 1], spec.plane_y)
    np.testing.assert_array_equal(ref.xd[ref.pen_down, 1], 0.0)
    up = ~ref.pen_down
    assert up.any(), "the default text needs pen lifts"
    assert np.all(ref.x[up, 1] > spec.plane_y)
    # each lift reaches the full lift height (the plateau of the bump)
    edges = np.flatnonzero(np.diff(up.astype(int)))
    assert edges.size % 2 == 0
    for a, b in edges.reshape(-1, 2):
        np.testing.assert_allclose(ref.x[a + 1 : b + 1, 1].max(), spec.plane_y + spec.lift)
    # pen-down samples stay in the writing area
    xz = ref.x[ref.pen_down][:, [0, 2]]
    assert xz[:, 0].min() >= spec.x_range[0] and xz[:, 0].max() <= spec.x_range[1]
    assert xz[:, 1].min() >= spec.z_range[0] and xz[:, 1].max() <= spec.z_range[1]


def test_fk_reproduces_the_tip_path(model: rr.Model, ref: tr.Reference) -> None:
    x_fk, _ = model.fk(ref.q)
    assert np.abs(x_fk - ref.x).max() < 1e-12
    assert np.abs(np.diff(ref.q, axis=0)).max() < 0.01, "q is continuous (no branch jump)"


def test_joint_rates_through_the_jacobian(model: rr.Model, ref: tr.Reference) -> None:
    """xd = J qd and xdd = J qdd + Jd qd hold back through the forward map."""
    xd, xdd = model.tip_motion(ref.q, ref.qd, ref.qdd)
    assert np.abs(xd - ref.xd).max() < 1e-12
    assert np.abs(xdd - ref.xdd).max() < 1e-9


def test_finite_differences_of_q(ref: tr.Reference) -> None:
    """Central differences of q against qd and qdd.

    q is C2 with a bounded (piecewise continuous) third derivative, |q'''| <= L. Then
    |(q(t+h) - q(t-h)) / 2h - q'(t)| <= L h^2 / 6 and
    |(q(t+h) - 2 q(t) + q(t-h)) / h^2 - q''(t)| <= L h / 3 (Taylor with integral remainder).
    L is estimated on the grid from qdd itself, per joint, with a 1.5 safety factor; round-off
    (|q| ~ 3 rad, eps 2.2e-16) adds 1e-15 / h and 4e-15 / h^2.
    """
    h = ref.spec.dt
    q, qd, qdd = ref.q, ref.qd, ref.qdd
    jerk = 1.5 * np.abs(np.diff(qdd, axis=0)).max(axis=0) / h
    d1 = (q[2:] - q[:-2]) / (2 * h)
    d2 = (q[2:] - 2 * q[1:-1] + q[:-2]) / h**2
    err1 = np.abs(d1 - qd[1:-1]).max(axis=0)
    err2 = np.abs(d2 - qdd[1:-1]).max(axis=0)
    assert np.all(err1 <= jerk * h**2 / 6 + 1e-15 / h), (err1, jerk * h**2 / 6)
    assert np.all(err2 <= jerk * h / 3 + 4e-15 / h**2), (err2, jerk * h / 3)
    # and the bounds are meaningful: small against the signals themselves
    assert np.all(err1 < 0.005 * np.abs(qd).max(axis=0))
    assert np.all(err2 < 0.1 * np.abs(qdd).max(axis=0))


def test_c2_continuity_refines_with_dt(model: rr.Model) -> None:
    """A jump in xdd (or xd) would not shrink when dt is halved; a C2 path's steps do: with a
    bounded jerk the largest step of xdd is about jerk_max dt. The timing law is the same on
    both grids (its spline lives on a fixed 0.5 ms grid)."""
    coarse = tr.make_reference(model, tr.WritingSpec(text="\u03c9m", dt=1e-3))
    fine = tr.make_reference(model, tr.WritingSpec(text="\u03c9m", dt=2.5e-4))

    def step(a: np.ndarray) -> float:
        return float(np.abs(np.diff(a, axis=0)).max())

    assert step(fine.xdd) < 0.5 * step(coarse.xdd)
    assert step(fine.xd) < 0.3 * step(coarse.xd)
    assert step(fine.qdd) < 0.5 * step(coarse.qdd)
    jerk_max = step(fine.xdd) / fine.spec.dt
    assert jerk_max < 2000.0, f"tip jerk {jerk_max:.0f} m/s^3"
    assert step(coarse.xdd) <= 1.5 * jerk_max * coarse.spec.dt


def test_starts_and_ends_at_rest(ref: tr.Reference) -> None:
    for k in (0, -1):
        for name in ("xd", "xdd", "qd", "qdd"):
            np.testing.assert_array_equal(getattr(ref, name)[k], 0.0, err_msg=name)
        assert ref.pen_down[k]
    assert ref.s[0] == 0.0 and ref.s[-1] > 0.5
    rest = round(ref.spec.rest / ref.spec.dt)
    np.testing.assert_array_equal(ref.x[:rest], np.broadcast_to(ref.x[0], (rest, 3)))
    np.testing.assert_array_equal(ref.x[-rest:], np.broadcast_to(ref.x[-1], (rest, 3)))


def test_fast_and_slow_phases(ref: tr.Reference) -> None:
    spec = ref.spec
    v = ref.speed
    assert v.max() >= 0.95 * spec.peak_speed
    assert v.max() <= 1.01 * spec.peak_speed
    writing = ref.pen_down & (ref.s > 0) & (ref.s < ref.s[-1])
    assert np.any(writing & (v < 0.1)), "slow phases while writing"
    assert np.any(writing & (v > 0.3)), "fast phases while writing"
    # several distinct slow phases (cusps, loops), not one
    slow = (writing & (v < 0.1)).astype(int)
    assert np.count_nonzero(np.diff(slow) == 1) >= 10
    assert 4.0 < ref.duration < 8.0


def test_workspace_report(model: rr.Model, ref: tr.Reference) -> None:
    spec = ref.spec
    assert ref.min_margin_m >= spec.min_workspace_margin
    assert np.min(model.workspace_margin(ref.x)) >= ref.min_margin_m - 1e-4
    sing = [model.singularity(q) for q in ref.q[::50]]
    assert min(s.elbow_margin for s in sing) >= ref.min_elbow_margin - 1e-12
    assert min(s.shoulder_margin for s in sing) >= ref.min_shoulder_margin_m - 1e-12
    assert ref.min_elbow_margin > 0.5 and ref.min_shoulder_margin_m > 0.3


def test_numeric_ik_matches_closed_form(model: rr.Model, ref: tr.Reference) -> None:
    """The paper's Fig 5: MuJoCo's numeric IK along the path, every 20th sample."""
    idx = np.arange(0, ref.t.size, 20)
    q_num = numeric_ik_path(model, ref.x[idx], ref.q[0] + 0.01)
    assert np.abs(wrap(q_num - ref.q[idx])).max() < 1e-9


def test_numeric_references_match_the_closed_form(ref: tr.Reference, tmp_path: Path) -> None:
    """Figs 5 and 6 along the whole reference: MuJoCo's IK and mj_inverse against the closed
    form; a robot file of base parameters only keeps Fig 5 and says why Fig 6 is missing."""
    robot = rr.read_robot_file(DEFAULT_ROBOT_TOML)
    refs = numeric_references(robot.model, robot, ref)
    assert np.abs(wrap(refs.ik - ref.q)).max() < 1e-12
    assert refs.tau is not None
    tau = robot.model.inverse_dynamics(ref.q, ref.qd, ref.qdd)
    assert np.abs(refs.tau - tau).max() < 1e-10 * np.abs(tau).max()
    robot.model.to_toml(tmp_path / "bp_robot.toml")  # [base_parameters], no link tables
    base_only = rr.read_robot_file(tmp_path / "bp_robot.toml")
    refs = numeric_references(base_only.model, base_only, ref)
    assert refs.ik.shape == ref.q.shape and refs.tau is None
    assert "base parameters" in refs.tau_skipped


# ---- other texts and bad input ------------------------------------------------------------------
@pytest.mark.parametrize(
    "text", ["m", "\u03b3\u03c9", "Hi!", "ab\ncd", "\u03a9 x", "\u03b1\u03b2\u03b3"]
)
def test_other_texts(model: rr.Model, text: str) -> None:
    ref = tr.make_reference(model, tr.WritingSpec(text=text))
    assert np.abs(model.fk(ref.q)[0] - ref.x).max() < 1e-12
    np.testing.assert_array_equal(ref.x[ref.pen_down, 1], ref.spec.plane_y)
    np.testing.assert_array_equal(ref.xd[[0, -1]], 0.0)
    assert ref.speed.max() <= 1.01 * ref.spec.peak_speed


def test_text_too_large_raises_before_running(
    model: rr.Model, monkeypatch: pytest.MonkeyPatch
) -> None:
    def must_not_run(*args: object, **kwargs: object) -> None:
        raise AssertionError("the timing law ran for a text that does not fit")

    monkeypatch.setattr(tr, "timing_law", must_not_run)
    # at the height asked for (fit_to_area false), and below min_letter_height when fitted
    with pytest.raises(rr.BadInputError, match="wide"):
        tr.make_reference(model, tr.WritingSpec(letter_height=0.12, fit_to_area=False))
    with pytest.raises(rr.BadInputError, match="high"):
        tr.make_reference(model, tr.WritingSpec(text="a\nb\nc", letter_height=0.07,
                                                fit_to_area=False))
    with pytest.raises(rr.BadInputError, match="below min_letter_height"):
        tr.make_reference(model, tr.WritingSpec(text="\n".join("abcdefghi")))


def test_off_workspace_raises_before_running(
    model: rr.Model, monkeypatch: pytest.MonkeyPatch
) -> None:
    def must_not_run(*args: object, **kwargs: object) -> None:
        raise AssertionError("IK ran for an unreachable text")

    monkeypatch.setattr(tr, "timing_law", must_not_run)
    far = tr.WritingSpec(x_range=(0.7, 1.0))
    with pytest.raises(rr.BadInputError, match="outside the workspace"):
        tr.make_reference(model, far)
    # 'm' centred at x = 0.66 m: its right edge passes 12 mm from the outer workspace sphere
    near_edge = tr.WritingSpec(x_range=(0.61, 0.71), z_range=(0.45, 0.55), text="m")
    with pytest.raises(rr.BadInputError, match="too close"):
        tr.make_reference(model, near_edge)
    assert issubclass(rr.BadInputError, ValueError)


@pytest.mark.parametrize("ch", ["\u20ac", "\u65e5", "\u00e9"])
def test_unknown_glyph_is_named(model: rr.Model, ch: str) -> None:
    with pytest.raises(rr.BadInputError, match=f"U\\+{ord(ch):04X}"):
        tr.make_reference(model, tr.WritingSpec(text=f"a{ch}b"))


@pytest.mark.parametrize(
    "changes",
    [{"letter_height": -0.01}, {"peak_speed": 0.0}, {"x_range": (0.6, 0.4)},
     {"min_speed": 0.5}, {"text": "  "}, {"elbow": "sideways"}, {"dt": float("nan")}],
)
def test_bad_spec(changes: dict) -> None:
    with pytest.raises(rr.BadInputError):
        tr.WritingSpec(**changes)


def test_spec_from_robot_file() -> None:
    with DEFAULT_ROBOT_TOML.open("rb") as fh:
        table = tomllib.load(fh)["writing"]
    spec = tr.WritingSpec.from_toml_table(table)
    assert spec.plane_y == table["plane_y"]
    assert spec.x_range == tuple(table["x_range"]) and spec.z_range == tuple(table["z_range"])
    assert spec.letter_height == table["letter_height"]
    assert spec.peak_speed == table["peak_speed"]
    assert spec == tr.WritingSpec(), "the dataclass defaults are the robot file's"
    with pytest.raises(rr.BadInputError, match="colour"):
        tr.WritingSpec.from_toml_table({**table, "colour": "red"})


# ---- letters ----------------------------------------------------------------------------------
def test_joined_strokes_like_a_hand() -> None:
    a = np.array([[0.0, 0.0], [0.0, 10.0]])
    # starts where the last stroke ended: one stroke
    assert len(join_strokes([a, np.array([[0.0, 10.0], [5.0, 10.0]])], 5.0)) == 1
    # starts on the last 4 units of the previous one: run back along it (a cusp)
    joined = join_strokes([a, np.array([[0.0, 6.0], [5.0, 8.0]])], 5.0)
    assert len(joined) == 1
    np.testing.assert_array_equal(joined[0], [[0, 0], [0, 10], [0, 6], [5, 8]])
    # the pen lies on the new stroke's head: run up the head and back (omega's spike)
    joined = join_strokes([a, np.array([[3.0, 14.0], [0.0, 10.0], [-5.0, 5.0]])], 5.0)
    np.testing.assert_array_equal(joined[0], [[0, 0], [0, 10], [3, 14], [0, 10], [-5, 5]])
    # too far back, or elsewhere: a pen lift
    assert len(join_strokes([a, np.array([[0.0, 2.0], [5.0, 2.0]])], 5.0)) == 2
    assert len(join_strokes([a, np.array([[9.0, 9.0], [5.0, 2.0]])], 5.0)) == 2


def test_letter_sizes() -> None:
    # capital height = letter_height (base line z = 0 to the cap line)
    pts = np.vstack(text_strokes("H", 0.07, latin_font="futural"))
    np.testing.assert_allclose([pts[:, 1].min(), pts[:, 1].max()], [0.0, 0.07], atol=1e-15)
    # cursive m is one stroke, the Greek omega and gamma come from the Greek font
    assert len(text_strokes("m", 0.07)) == 1
    assert len(text_strokes("\u03c9", 0.07)) == 1
    assert len(text_strokes("\u03b3", 0.07)) == 2


def test_pen_lifts_towards_the_robot(model: rr.Model) -> None:
    ref = tr.make_reference(model, tr.WritingSpec(text="\u03b3", plane_y=0.25))
    assert np.all(ref.x[~ref.pen_down, 1] < 0.25)
    np.testing.assert_array_equal(ref.x[ref.pen_down, 1], 0.25)


def test_unknown_font(model: rr.Model) -> None:
    with pytest.raises(rr.BadInputError, match="unknown Hershey font 'nope'"):
        tr.make_reference(model, tr.WritingSpec(latin_font="nope"))


def test_singularities_of_a_path_equal_the_per_row_classification(
        model: rr.Model, ref: tr.Reference) -> None:
    """The reference's singular margins in one pass are librrr's row by row, bit for bit: along
    the default reference and at random configurations (every quadrant, near the singular
    sets too)."""
    rng = np.random.default_rng(26)
    q = np.vstack([ref.q, rng.uniform(-7.0, 7.0, (20_000, 3)),
                   [[0.1, 0.2, 0.0], [0.0, np.pi / 2, np.pi], [1.0, -0.3, 1e-12]]])
    elbow, shoulder, det = tr._singularities(model, q)
    rows = [model.singularity(qi) for qi in q]
    assert np.array_equal(elbow, [s.elbow_margin for s in rows])
    assert np.array_equal(shoulder, [s.shoulder_margin for s in rows])
    assert np.array_equal(det, [s.det_jacobian for s in rows])
    assert ref.min_elbow_margin == float(elbow[: ref.t.size].min())


@pytest.mark.parametrize("q", [np.zeros((4, 2)), np.array([[0.0, np.nan, 0.0]])])
def test_singularities_refuse_bad_rows(model: rr.Model, q: np.ndarray) -> None:
    with pytest.raises(rr.RrrError, match="_singularities"):
        tr._singularities(model, q)
