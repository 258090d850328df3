"""The writing task (paper section V): reference tip and joint motion while the arm writes text.

The tip writes a text in the vertical plane y = ``plane_y`` (x to the right, z up; the text reads
left to right along +x as plotted in the x-z plane) and lifts the pen by ``lift`` in y between
strokes, towards the robot (the paper lies on the far side of the plane). The path is the C2
curve of :mod:`rrr_robot.writing.writing_path` through the strokes of
:mod:`rrr_robot.writing.letters`; the timing law s(t) along it is built in four steps:

1. a limit of s_dot along the path: the tip speed target is ``peak_speed`` on straight parts and
   sqrt(``lateral_acc`` / curvature) in curves, never below ``min_speed``; on top of it the
   geometric parts of the tip acceleration and jerk are bounded, |C''| s_dot^2 <= ``max_acc``
   and |C'''| s_dot^3 <= ``max_jerk`` (these slow the tip at sharp corners and stop it at the
   cusps of 'm' and omega, where the pen reverses), and the pen lift's y acceleration by
   ``lift_acc``;
2. forward and backward passes limit the tangential acceleration to ``tangential_acc`` and bring
   the tip to rest at both ends;
3. integrated in time, this gives s0(t), which is smoothed by a Hann window of half-width
   ``smoothing`` and interpolated by a quintic spline on a 0.5 ms grid: s(t) is C3 and starts
   and ends with exactly zero velocity and acceleration, after ``rest`` seconds at rest;
4. x(t) = C(s(t)), xd = C' s_dot, xdd = C'' s_dot^2 + C' s_ddot exactly (x is C2 in time).

Joint motion: q = closed-form IK (``Model.ik_nearest``, continuous, one posture branch), qd and
qdd through the Jacobian (``Model.joint_motion``). Before the timing law and the IK run, the text
is laid out and checked: each newline starts a new line (``line_spacing`` letter heights below
the last, left-aligned); a text that does not fit the writing area at ``letter_height`` is
shrunk until it fits (``fit_to_area``, :func:`fit_letter_height`), but not below
``min_letter_height`` (refused with the numbers); every point of the path (pen lifts included)
must keep ``min_workspace_margin`` from the workspace boundary; a violation raises
BadInputError. The joint path must then keep |sin q3| >= ``min_elbow_margin`` on one posture
branch.

The reference is sampled at ``dt``, the robot file's [control] sample_time
(:meth:`WritingSpec.from_robot`). One run is bounded (checked before the reference is sampled):
at most MAX_TEXT characters, a path of at most MAX_PATH_LENGTH m, a reference of at most
MAX_REFERENCE_DURATION s and MAX_REFERENCE_SAMPLES samples.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, fields, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core._arrays import FloatArray
from ..core.checked import Invalid, show
from ..core.model import Model
from ..core.robot import (
    DEFAULT_SAMPLE_TIME,
    MAX_TEXT,
    SAMPLE_TIME,
    WRITING_FIELDS,
    RobotFile,
    writing_values,
)
from ..errors import BadInputError, NumericError, RobotFileError
from . import plan_cache
from .letters import text_strokes
from .plan_cache import TipPlan
from .writing_path import PathOptions, WritingPath, build_path

if TYPE_CHECKING:  # scipy.interpolate is imported where a timing law is built (about 0.4 s)
    from scipy.interpolate import BSpline

__all__ = [
    "DEFAULT_TEXT",
    "MAX_PATH_LENGTH",
    "MAX_REFERENCE_DURATION",
    "MAX_REFERENCE_SAMPLES",
    "MAX_TEXT",
    "MIN_HEIGHT_CORNER_RADII",
    "Reference",
    "TimingLaw",
    "WritingSpec",
    "fit_letter_height",
    "fitted_spec",
    "letter_height_range",
    "make_reference",
    "tip_plan",
    "writing_path",
]

logger = logging.getLogger(__name__)

#: Omega, m and gamma of the paper (where its PD corrections peak) between cursive latin letters.
DEFAULT_TEXT = "a\u03c9m\u03b3"  # "a omega m gamma"
#: Bounds of one run, checked before the reference is sampled (and so before any simulation):
#: the path (pen lifts included) at most 100 m long, so the planning grids (0.1 mm) have at most
#: 1e6 points; the reference at most 1000 s long (the timing law's 0.5 ms spline grid: 2e6
#: points) and at most 1,000,000 samples (1000 s at 1 ms; the co-simulation of one scenario
#: then takes about half a minute). MAX_TEXT (200 characters) bounds the text.
MAX_PATH_LENGTH = 100.0
#: The longest reference of one run, s (see MAX_PATH_LENGTH).
MAX_REFERENCE_DURATION = 1000.0
#: The most samples of one run's reference (see MAX_PATH_LENGTH).
MAX_REFERENCE_SAMPLES = 1_000_000
_TIME_GRID = 5e-4            # s, grid of the timing law's quintic spline
_PATH_GRID = 1e-4            # m, grid of s for the speed limit
_TOML_IGNORED = ("duration_hint",)


def short_text(text: str, limit: int = 30) -> str:
    """The text quoted for a message, cut to ``limit`` characters."""
    return repr(text if len(text) <= limit else text[: limit - 3] + "...")


@dataclass(frozen=True)
class WritingSpec:
    """What to write and how fast. Lengths in m, speeds in m/s, accelerations in m/s^2."""

    text: str = DEFAULT_TEXT
    plane_y: float = -0.25
    x_range: tuple[float, float] = (0.35, 0.65)
    z_range: tuple[float, float] = (0.35, 0.60)
    letter_height: float = 0.07            # capital letter, base line to cap line
    fit_to_area: bool = True               # shrink letters that do not fit the writing area
    min_letter_height: float = 0.02        # ... but not below this (m)
    peak_speed: float = 0.4
    min_speed: float = 0.05
    lateral_acc: float = 3.0               # sets the speed in curves: v = sqrt(a / curvature)
    max_acc: float = 10.0                  # bound on the centripetal part |C''| s_dot^2
    lift_acc: float = 2.0                  # bound on the y acceleration of a pen lift
    max_jerk: float = 200.0                # m/s^3, bound on the geometric part |C'''| s_dot^3
    tangential_acc: float = 3.0
    dt: float = DEFAULT_SAMPLE_TIME        # s, set from the robot file's [control] sample_time
    lift: float = 0.02                     # pen lift in y, towards the robot (away from paper)
    corner_radius: float = 0.002           # blend half-width at sharp corners
    lift_radius: float = 0.01              # blend length at the ends of a pen-up move
    corner_angle_deg: float = 60.0         # a stroke vertex turning more is a sharp corner
    smoothing: float = 0.02                # s, half-width of the Hann window on s0(t)
    rest: float = 0.05                     # s at rest before and after writing
    line_spacing: float = 1.6              # in letter heights
    latin_font: str = "scripts"
    greek_font: str = "greek"
    min_workspace_margin: float = 0.02     # m from the workspace boundary, everywhere
    min_elbow_margin: float = 0.05         # |sin q3| along the joint path
    shoulder: str = "front"
    elbow: str = "up"

    def __post_init__(self) -> None:
        # the checks of a robot file's [writing] table (rrr_robot.core.robot), and dt
        # those of [control] sample_time
        if isinstance(self.text, str) and len(self.text) > MAX_TEXT:
            raise BadInputError(
                f"text has {len(self.text)} characters ({short_text(self.text)}); at most "
                f"{MAX_TEXT} per run (planning grows faster than the text): split it"
            )
        for f in fields(self):
            check = SAMPLE_TIME if f.name == "dt" else WRITING_FIELDS[f.name]
            try:
                value = check.check(getattr(self, f.name))
            except Invalid as exc:
                raise BadInputError(f"WritingSpec.{f.name}{exc.index} {exc.requirement}, got "
                                    f"{show(exc.value)}") from None
            object.__setattr__(self, f.name, value)
        if self.min_speed >= self.peak_speed:
            raise BadInputError(f"WritingSpec.min_speed ({self.min_speed}) must be below "
                                f"peak_speed ({self.peak_speed})")

    @classmethod
    def from_toml_table(cls, table: Mapping[str, Any], source: str = "robot file",
                        **overrides: Any) -> WritingSpec:
        """Spec from a [writing] table of a robot file, checked as the robot file reader checks
        it (unknown keys raise RobotFileError, a BadInputError); ``overrides`` replace fields."""
        values = writing_values(table, source)
        return cls._from_values(values, source, **overrides)

    @classmethod
    def from_robot(cls, robot: RobotFile) -> WritingSpec:
        """Spec of a checked robot file: its [writing] values, sampled at its [control]
        sample_time (the one sample period of the writing task)."""
        return cls._from_values(robot.writing, robot.source, dt=robot.sample_time)

    @classmethod
    def _from_values(cls, values: Mapping[str, Any], source: str,
                     **overrides: Any) -> WritingSpec:
        kwargs = {k: v for k, v in values.items() if k not in _TOML_IGNORED}
        try:
            return cls(**(kwargs | overrides))
        except BadInputError as exc:  # what only the fields together decide (min_speed)
            raise RobotFileError(f"{source}: [writing] {exc}", source, "writing") from exc


@dataclass(frozen=True, eq=False)
class Reference:
    """Reference motion of the writing task on a uniform time grid (SI units, rad)."""

    t: FloatArray
    x: FloatArray
    xd: FloatArray
    xdd: FloatArray
    q: FloatArray
    qd: FloatArray
    qdd: FloatArray
    pen_down: np.ndarray
    speed: FloatArray                  # in-plane tip speed sqrt(xd^2 + zd^2), paper eq 14
    s: FloatArray                      # path parameter (about the arc length), m
    min_margin_m: float                # least workspace margin along the path
    min_elbow_margin: float            # least |sin q3|
    min_shoulder_margin_m: float       # least |a2 cos q2 + a3 cos(q2 + q3)|
    spec: WritingSpec = field(repr=False)

    @property
    def duration(self) -> float:
        return float(self.t[-1])


def _strokes(spec: WritingSpec) -> list[FloatArray]:
    return text_strokes(
        spec.text, spec.letter_height, spec.latin_font, spec.greek_font, spec.line_spacing
    )


def _extent(strokes: list[FloatArray]) -> tuple[FloatArray, FloatArray]:
    pts = np.vstack(strokes)
    return pts.min(axis=0), pts.max(axis=0)


def _room(spec: WritingSpec) -> FloatArray:
    return np.array([spec.x_range[1] - spec.x_range[0], spec.z_range[1] - spec.z_range[0]])


def fit_letter_height(spec: WritingSpec) -> float:
    """The letter height the text is written at: ``spec.letter_height`` when the text fits the
    writing area at it (or ``fit_to_area`` is false), otherwise the largest height at which it
    fits (the text's size is proportional to the letter height). BadInputError, with the
    numbers, when that is below ``min_letter_height``."""
    lo, hi = _extent(_strokes(spec))
    size, room = hi - lo, _room(spec)
    if not spec.fit_to_area or np.all(size <= room):
        return spec.letter_height
    # a hair below the exact ratio, so that the fitted text fits despite rounding
    factor = float(np.min(room / size)) * (1.0 - 1e-9)
    height = spec.letter_height * factor
    if height < spec.min_letter_height:
        raise BadInputError(
            f"text {short_text(spec.text)} is {size[0]:.3f} m wide and {size[1]:.3f} m high at "
            f"letter_height {spec.letter_height} m; the writing area is {room[0]:.3f} m x "
            f"{room[1]:.3f} m (x_range {spec.x_range}, z_range {spec.z_range}), so it would fit "
            f"only at letter_height {height:.4f} m, below min_letter_height "
            f"{spec.min_letter_height} m: shorten the text, break it into lines (newlines), or "
            "enlarge the writing area"
        )
    return height


#: The smallest letters written, in corner radii: a glyph's corners are blended over
#: ``corner_radius`` either side, so letters of fewer radii lose their shape to the blends.
MIN_HEIGHT_CORNER_RADII = 5.0


def letter_height_range(spec: WritingSpec) -> tuple[float, float]:
    """The letter heights the text can be written at: from MIN_HEIGHT_CORNER_RADII corner
    radii (smaller letters lose their shape to the corner blends) to the largest at which it
    fits the writing area."""
    lo, hi = _extent(_strokes(spec))
    factor = float(np.min(_room(spec) / np.maximum(hi - lo, 1e-300))) * (1.0 - 1e-9)
    return MIN_HEIGHT_CORNER_RADII * spec.corner_radius, spec.letter_height * factor


def fitted_spec(spec: WritingSpec) -> WritingSpec:
    """``spec`` at the letter height :func:`fit_letter_height` chose (``spec`` itself when the
    text fits as it is)."""
    return _at_height(spec, fit_letter_height(spec))


def _at_height(spec: WritingSpec, height: float) -> WritingSpec:
    if height == spec.letter_height:
        return spec
    logger.info("text %s scaled to letter_height %.4f m (from %g m) to fit the writing area",
                short_text(spec.text), height, spec.letter_height)
    return replace(spec, letter_height=height)


def writing_path(spec: WritingSpec) -> WritingPath:
    """The geometric path of a spec at its letter height, placed in the middle of the writing
    area; raises BadInputError if the text does not fit the area (:func:`fitted_spec` first
    shrinks it to fit)."""
    strokes = _strokes(spec)
    lo, hi = _extent(strokes)
    area_lo = np.array([spec.x_range[0], spec.z_range[0]])
    area_hi = np.array([spec.x_range[1], spec.z_range[1]])
    size, room = hi - lo, area_hi - area_lo
    for k, axis in enumerate(("wide", "high")):
        if size[k] > room[k]:
            raise BadInputError(
                f"text {short_text(spec.text)} is {size[k]:.3f} m {axis} at letter_height "
                f"{spec.letter_height} m, but the writing area is only {room[k]:.3f} m {axis} "
                f"(x_range {spec.x_range}, z_range {spec.z_range}): shorten the text or make "
                "the letters smaller"
            )
    shift = 0.5 * (area_lo + area_hi) - 0.5 * (lo + hi)
    options = PathOptions(
        plane_y=spec.plane_y,
        lift=-spec.lift if spec.plane_y > 0.0 else spec.lift,     # towards the base
        corner_radius=spec.corner_radius,
        lift_radius=spec.lift_radius,
        corner_angle=math.radians(spec.corner_angle_deg),
        noise=0.3 * spec.letter_height / 21.0,
    )
    return build_path([p + shift for p in strokes], options)


def check_workspace(model: Model, path: WritingPath, spec: WritingSpec) -> float:
    """Least workspace margin along the path (pen lifts included), m; raises BadInputError if
    it is below ``spec.min_workspace_margin``."""
    return workspace_margin(model, workspace_samples(path), spec)


def workspace_samples(path: WritingPath) -> FloatArray:
    """The tip positions at which the workspace margin is checked: every 0.2 mm of the path."""
    s = np.linspace(0.0, path.length, max(2, int(path.length / 2e-4) + 1))
    return path.evaluate(s)[0]


def workspace_margin(model: Model, x: FloatArray, spec: WritingSpec) -> float:
    """Least workspace margin of the tip positions x (n, 3), m; raises BadInputError if it is
    below ``spec.min_workspace_margin``."""
    margin = np.asarray(model.workspace_margin(x))
    k = int(np.argmin(margin))
    if margin[k] < spec.min_workspace_margin:
        where = "outside the workspace" if margin[k] < 0 else "too close to its boundary"
        raise BadInputError(
            f"text {short_text(spec.text)}: the tip would pass {where} at x = "
            f"{np.round(x[k], 4).tolist()} "
            f"(margin {margin[k]:.4f} m, required {spec.min_workspace_margin} m); move the "
            "writing area (plane_y, x_range, z_range) or make the letters smaller"
        )
    return float(margin[k])


def _speed_limit(path: WritingPath, s: FloatArray, spec: WritingSpec) -> FloatArray:
    """Upper bound of s_dot along the path (step 1 of the module doc)."""
    _, d1, d2 = path.evaluate(s)
    norm1 = np.linalg.norm(d1, axis=1)
    norm2 = np.linalg.norm(d2, axis=1)
    curvature = np.linalg.norm(np.cross(d1, d2), axis=1) / np.maximum(norm1, 1e-12) ** 3
    v_tip = np.sqrt(spec.lateral_acc / np.maximum(curvature, 1e-12))
    v_tip = np.clip(v_tip, spec.min_speed, spec.peak_speed)
    limit: FloatArray = v_tip / np.maximum(norm1, 1e-12)
    limit = np.minimum(limit, np.sqrt(spec.lift_acc / np.maximum(np.abs(d2[:, 1]), 1e-12)))
    limit = np.minimum(limit, np.sqrt(spec.max_acc / np.maximum(norm2, 1e-12)))
    norm3 = np.linalg.norm(np.gradient(d2, s, axis=0), axis=1)
    limit = np.minimum(limit, np.cbrt(spec.max_jerk / np.maximum(norm3, 1e-12)))
    return limit


def _rest_to_rest(limit: FloatArray, ds: float, acc: FloatArray) -> FloatArray:
    """Largest s_dot(s) under ``limit`` with |s_ddot| <= acc, zero at both ends."""
    v = np.minimum(limit, np.inf)
    v[0] = v[-1] = 0.0
    step = 2.0 * acc * ds
    for k in range(1, v.size):
        v[k] = min(v[k], math.sqrt(v[k - 1] ** 2 + step[k]))
    for k in range(v.size - 2, -1, -1):
        v[k] = min(v[k], math.sqrt(v[k + 1] ** 2 + step[k]))
    return v


def _hann_smooth(values: FloatArray, half_width: int) -> FloatArray:
    k = np.arange(-half_width, half_width + 1)
    window = 1.0 + np.cos(np.pi * k / (half_width + 1))
    window /= window.sum()
    padded = np.concatenate(
        [np.full(half_width, values[0]), values, np.full(half_width, values[-1])]
    )
    return np.convolve(padded, window, mode="valid")


@dataclass(frozen=True)
class TimingLaw:
    """s(t) on [0, duration]: at rest (s = 0, then s = length) outside [t_start, t_stop], a
    quintic spline in between (exactly zero velocity and acceleration while at rest)."""

    spline: BSpline
    t_start: float
    t_stop: float
    duration: float
    length: float

    def evaluate(self, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """s, s_dot, s_ddot at the times t."""
        t = np.asarray(t, dtype=float)
        moving = (t > self.t_start) & (t < self.t_stop)
        out = [np.zeros(t.shape) for _ in range(3)]
        out[0][t >= self.t_stop] = self.length
        for d in range(3):
            out[d][moving] = self.spline(t[moving], nu=d)
        out[0] = np.clip(out[0], 0.0, self.length)
        return out[0], out[1], out[2]


def check_reference_size(duration: float, spec: WritingSpec) -> None:
    """Refuse a reference longer than MAX_REFERENCE_DURATION or with more than
    MAX_REFERENCE_SAMPLES samples at ``spec.dt`` (BadInputError saying what to change)."""
    samples = duration / spec.dt + 1 if math.isfinite(duration) else math.inf
    if samples <= MAX_REFERENCE_SAMPLES and duration <= MAX_REFERENCE_DURATION:
        return
    what = (f"{samples:,.0f} samples at the sample time {spec.dt:g} s" if math.isfinite(samples)
            else "no finite duration")
    raise BadInputError(
        f"text {short_text(spec.text)}: the reference would last {duration:.1f} s ({what}); "
        f"one run is bounded to {MAX_REFERENCE_DURATION:g} s and {MAX_REFERENCE_SAMPLES:,} "
        "samples: write a shorter text or smaller letters, faster (peak_speed, min_speed), or "
        "with a longer sample time ([control] sample_time)"
    )


def check_path_length(path: WritingPath, spec: WritingSpec) -> None:
    """Refuse a path longer than MAX_PATH_LENGTH (BadInputError)."""
    if path.length <= MAX_PATH_LENGTH:
        return
    raise BadInputError(
        f"text {short_text(spec.text)}: the tip path (pen lifts included) would be "
        f"{path.length:.1f} m long at letter_height {spec.letter_height} m; one run is bounded "
        f"to {MAX_PATH_LENGTH:g} m (the planning grids have 0.1 mm steps): write a shorter text "
        "or smaller letters"
    )


def timing_law(path: WritingPath, spec: WritingSpec) -> TimingLaw:
    """The timing law along a path (steps 1-3 of the module doc); refuses a path or a duration
    beyond the bounds of one run before the expensive steps."""
    check_path_length(path, spec)
    n = max(3, math.ceil(path.length / _PATH_GRID) + 1)
    s = np.linspace(0.0, path.length, n)
    ds = float(s[1] - s[0])
    norm1 = np.linalg.norm(path.evaluate(s)[1], axis=1)
    acc = spec.tangential_acc / np.maximum(norm1, 1e-3)
    v = _rest_to_rest(_speed_limit(path, s, spec), ds, acc)
    t = np.concatenate([[0.0], np.cumsum(2.0 * ds / (v[1:] + v[:-1]))])
    half = math.ceil(spec.smoothing / _TIME_GRID)
    pad = half + math.ceil(spec.rest / _TIME_GRID) + 8
    check_reference_size(float(t[-1]) + 2 * pad * _TIME_GRID, spec)
    tau = np.arange(-pad, math.ceil(t[-1] / _TIME_GRID) + pad + 1) * _TIME_GRID
    s_smooth = _hann_smooth(np.interp(tau, t, s), half)
    still_before = tau <= -half * _TIME_GRID           # the window sees s0 = 0 only
    still_after = tau >= t[-1] + half * _TIME_GRID     # ... s0 = length only
    s_smooth[still_before] = 0.0
    s_smooth[still_after] = path.length
    t_out = tau - tau[0]
    from scipy.interpolate import make_interp_spline

    return TimingLaw(
        spline=make_interp_spline(t_out, s_smooth, k=5),
        t_start=float(t_out[still_before][-1]),
        t_stop=float(t_out[still_after][0]),
        duration=float(t_out[-1]),
        length=path.length,
    )


def _joint_path(model: Model, x: FloatArray, spec: WritingSpec) -> FloatArray:
    q0 = model.ik_branch(x[0], spec.shoulder, spec.elbow)
    return model.ik_nearest(x, q0)


def _singularities(model: Model, q: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """The elbow margin ``|sin q3|``, the shoulder margin (m) and ``det J`` of each row of ``q``
    (n, 3): those of :meth:`Model.singularity` row by row, bit for bit (librrr's
    ``rrr_singularity_classify``: the same libm sines and cosines, through :mod:`math`, and the
    same products and sums in the same order), in one pass instead of one call per row.
    NumericError for a row that is not finite."""
    q = np.asarray(q, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 3:
        raise BadInputError(f"_singularities: joint rows (n, 3) expected, got shape {q.shape}")
    if not np.all(np.isfinite(q)):
        raise NumericError("_singularities: a joint position is not finite")
    dh = model.dh
    a2, a3 = dh["a2"], dh["a3"]
    q2, q3 = q[:, 1].tolist(), q[:, 2].tolist()
    s2 = np.array([math.sin(v) for v in q2])
    c2 = np.array([math.cos(v) for v in q2])
    s3 = np.array([math.sin(v) for v in q3])
    c3 = np.array([math.cos(v) for v in q3])
    r = a2 * c2 + a3 * (c2 * c3 - s2 * s3)
    return np.abs(s3), np.abs(r), -a2 * a3 * s3 * r


def _singular_margins(model: Model, q: FloatArray, spec: WritingSpec) -> tuple[float, float]:
    elbow, shoulder, det = _singularities(model, q)
    det_sign = np.sign(det)
    if np.any(det_sign != det_sign[0]):
        raise BadInputError(
            f"text {short_text(spec.text)}: the joint path changes posture branch at t = "
            f"{np.argmax(det_sign != det_sign[0]) * spec.dt:.3f} s (passes a singularity)"
        )
    if elbow.min() < spec.min_elbow_margin:
        raise BadInputError(
            f"text {short_text(spec.text)}: the elbow comes within |sin q3| = "
            f"{elbow.min():.3f} of a "
            f"singular configuration (required {spec.min_elbow_margin})"
        )
    return float(elbow.min()), float(shoulder.min())


def tip_plan(spec: WritingSpec,
             check: Callable[[FloatArray], object] | None = None) -> TipPlan:
    """The tip motion of a (fitted) spec: steps 1-4 of the module doc. ``check`` is called with
    the workspace samples before the timing law is built (a text the robot cannot reach fails
    before the expensive steps)."""
    path = writing_path(spec)
    check_path_length(path, spec)
    ws_x = workspace_samples(path)
    if check is not None:
        check(ws_x)
    law = timing_law(path, spec)
    check_reference_size(law.duration, spec)
    t = np.arange(math.floor(law.duration / spec.dt + 1e-9) + 1, dtype=np.float64) * spec.dt
    s, sd, sdd = law.evaluate(t)
    c, c1, c2 = path.evaluate(s)
    return TipPlan(t=t, s=s, x=c, xd=c1 * sd[:, None],
                   xdd=c2 * sd[:, None] ** 2 + c1 * sdd[:, None], pen_down=path.pen_down(s),
                   ws_x=ws_x, path_length=path.length, letter_height=spec.letter_height)


def make_reference(model: Model, spec: WritingSpec | None = None, *,
                   cache: bool = True) -> Reference:
    """Build the reference motion of the writing task (see the module doc); ``spec`` is fitted
    to the writing area (:func:`fitted_spec`). With ``cache``, the robot-independent tip plan
    (and the fitted letter height) is read from (or added to) the plan cache
    (:mod:`rrr_robot.writing.plan_cache`: the same numbers, bit for bit, without the spline
    fits); the robot-dependent part (workspace margin, IK, singular margins, joint motion) is
    computed every time."""
    asked = WritingSpec() if spec is None else spec
    start = time.perf_counter()
    plan = plan_cache.load(asked) if cache else None  # keyed by the spec as asked
    cached = plan is not None
    if plan is None:
        fitted = spec = fitted_spec(asked)
        plan = tip_plan(fitted, lambda ws_x: workspace_margin(model, ws_x, fitted))
        if cache:
            plan_cache.store(asked, plan)
    else:  # the fitted height is the plan's: the font is not even read
        spec = _at_height(asked, plan.letter_height)
    margin = workspace_margin(model, plan.ws_x, spec)
    q = _joint_path(model, plan.x, spec)
    elbow, shoulder = _singular_margins(model, q, spec)
    qd, qdd = model.joint_motion(q, plan.xd, plan.xdd)
    ref = Reference(
        t=plan.t, x=plan.x, xd=plan.xd, xdd=plan.xdd, q=q, qd=qd, qdd=qdd,
        pen_down=plan.pen_down, speed=np.hypot(plan.xd[:, 0], plan.xd[:, 2]), s=plan.s,
        min_margin_m=margin, min_elbow_margin=elbow, min_shoulder_margin_m=shoulder, spec=spec,
    )
    logger.info(
        "writing %r: %.2f s, path %.3f m, peak speed %.3f m/s, margins %.3f m / %.3f / %.3f m, "
        "built in %.2f s%s", spec.text, ref.duration, plan.path_length, ref.speed.max(), margin,
        elbow, shoulder, time.perf_counter() - start, " (tip plan cached)" if cached else "",
    )
    return ref
