"""Geometry of the writing path: pen strokes and pen lifts as one C2 curve C(s) in 3-D.

The path parameter s runs through consecutive pieces, each a C2 curve in the writing plane with
s close to its arc length:

* pen-down pieces: a stroke split at its sharp corners (turn > ``corner_angle``); each piece is a
  cubic smoothing spline through the font's polyline (the Hershey fonts are digitised on an
  integer grid, so the vertices are smoothed by about a third of a font unit);
* pen-up pieces: a straight move from the end of one stroke to the start of the next, while the
  pen rises by ``lift`` out of the plane (y) and comes back down, along a C2 plateau bump.

Pieces meet at joins, each smoothed by blending the two neighbours, extended beyond the join by
their second-order Taylor expansions, with a quintic smoothstep over a window around the join:
C = (1 - phi) A + phi B. The blend passes through the corner point itself and is C2 at the window
edges. At a pen lift the window lies wholly in the pen-up piece, so pen-down strokes are written
exactly as fitted; at a reversal (the stem of 'm') the blend's tangent vanishes, a true cusp.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..core._arrays import FloatArray

if TYPE_CHECKING:  # scipy.interpolate is imported where a path is built (about 0.4 s)
    from scipy.interpolate import BSpline

__all__ = ["PathOptions", "WritingPath", "build_path"]

_LIFT_RAMP = 0.35            # fraction of a pen-up move spent rising (and as much descending)


@dataclass(frozen=True)
class PathOptions:
    """Geometric options, lengths in metres."""

    plane_y: float
    lift: float
    corner_radius: float      # half-width of the blend window at a sharp corner
    lift_radius: float        # length of the blend window at either end of a pen-up move
    corner_angle: float       # rad: a vertex turning more than this is a sharp corner
    noise: float              # std of the vertex digitisation error, m (smoothing spline)


@dataclass(frozen=True)
class _Piece:
    spline: BSpline           # (x, z) as a function of the local parameter u in [0, length]
    length: float
    pen_down: bool


@dataclass(frozen=True)
class _Blend:
    s: float                  # the join
    left: float               # window [s - left, s + right]
    right: float
    a: int                    # piece indices before / after the join
    b: int


def _smoothstep(u: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Quintic smoothstep on [0, 1] (clamped outside) and its first two derivatives."""
    u = np.clip(u, 0.0, 1.0)
    return (
        u**3 * (10.0 - 15.0 * u + 6.0 * u**2),
        30.0 * u**2 * (1.0 - u) ** 2,
        60.0 * u * (1.0 - u) * (1.0 - 2.0 * u),
    )


def _bump(u: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """C2 plateau on [0, 1]: rises over [0, r], 1 in the middle, falls over [1 - r, 1]."""
    r = _LIFT_RAMP
    up = _smoothstep(u / r)
    down = _smoothstep((1.0 - u) / r)
    val = up[0] * down[0]
    d1 = up[1] / r * down[0] - up[0] * down[1] / r
    d2 = up[2] / r**2 * down[0] - 2.0 * up[1] * down[1] / r**2 + up[0] * down[2] / r**2
    return val, d1, d2


def _fit_piece(pts: FloatArray, noise: float) -> BSpline:
    """C2 curve through / near the vertices, parameterised by chord length."""
    from scipy.interpolate import BSpline, make_interp_spline, splprep

    u = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])
    m = len(pts)
    if m <= 3:
        return make_interp_spline(u, pts, k=m - 1)
    w = np.full(m, 1.0 / noise)
    w[[0, -1]] = 1e3 / noise                 # pin the ends
    (t, c, k), _ = splprep(pts.T, u=u, w=w, k=3, s=float(m - 2), quiet=2)
    return BSpline(t, np.column_stack(c), k)


def _split_corners(pts: FloatArray, corner_angle: float) -> list[FloatArray]:
    seg = np.diff(pts, axis=0)
    ang = np.arctan2(seg[:, 1], seg[:, 0])
    turn = np.abs((np.diff(ang) + np.pi) % (2.0 * np.pi) - np.pi)
    cuts = np.flatnonzero(turn > corner_angle) + 1
    bounds = [0, *cuts.tolist(), len(pts) - 1]
    return [pts[i : j + 1] for i, j in itertools.pairwise(bounds)]


def _line(p0: FloatArray, p1: FloatArray) -> BSpline:
    from scipy.interpolate import make_interp_spline

    return make_interp_spline([0.0, float(np.hypot(*(p1 - p0)))], np.vstack([p0, p1]), k=1)


def _pieces(strokes: list[FloatArray], opt: PathOptions) -> list[_Piece]:
    pieces: list[_Piece] = []
    for stroke in strokes:
        if pieces:
            end = pieces[-1].spline(pieces[-1].length)
            fitted = [_fit_piece(p, opt.noise) for p in _split_corners(stroke, opt.corner_angle)]
            start = fitted[0](0.0)
            hop = _line(end, start)
            pieces.append(_Piece(hop, float(hop.t[-1]), pen_down=False))
        else:
            fitted = [_fit_piece(p, opt.noise) for p in _split_corners(stroke, opt.corner_angle)]
        pieces.extend(_Piece(f, float(f.t[-1]), pen_down=True) for f in fitted)
    return pieces


def _blends(pieces: list[_Piece], starts: FloatArray, opt: PathOptions) -> list[_Blend]:
    out = []
    for j in range(1, len(pieces)):
        a, b = pieces[j - 1], pieces[j]
        if a.pen_down and b.pen_down:
            left = right = min(opt.corner_radius, 0.45 * a.length, 0.45 * b.length)
        elif a.pen_down:
            left, right = 0.0, min(opt.lift_radius, 0.45 * b.length)
        else:
            left, right = min(opt.lift_radius, 0.45 * a.length), 0.0
        out.append(_Blend(float(starts[j]), left, right, j - 1, j))
    return out


@dataclass(frozen=True)
class WritingPath:
    """The whole writing path C(s), s in [0, length]; see ``build_path``."""

    pieces: tuple[_Piece, ...]
    starts: FloatArray
    blends: tuple[_Blend, ...]
    options: PathOptions

    @property
    def length(self) -> float:
        return float(self.starts[-1] + self.pieces[-1].length)

    def lifts(self) -> list[tuple[float, float]]:
        """Parameter intervals (s0, s1) of the pen-up moves."""
        return [
            (float(s), float(s + p.length))
            for s, p in zip(self.starts, self.pieces, strict=True)
            if not p.pen_down
        ]

    def pen_down(self, s: FloatArray) -> np.ndarray:
        """True where the pen touches the writing plane."""
        down = np.ones(np.shape(s), dtype=bool)
        for s0, s1 in self.lifts():
            down &= ~((s > s0) & (s < s1))
        return down

    def evaluate(self, s: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """C(s), C'(s), C''(s), each (n, 3), in metres and per unit s."""
        s = np.asarray(s, dtype=float)
        planar = self._planar(s)
        out = [np.zeros((s.size, 3)) for _ in range(3)]
        for d in range(3):
            out[d][:, 0] = planar[d][:, 0]
            out[d][:, 2] = planar[d][:, 1]
        out[0][:, 1] = self.options.plane_y
        for s0, s1 in self.lifts():
            mask = (s > s0) & (s < s1)
            span = s1 - s0
            val, d1, d2 = _bump((s[mask] - s0) / span)
            out[0][mask, 1] += self.options.lift * val
            out[1][mask, 1] = self.options.lift * d1 / span
            out[2][mask, 1] = self.options.lift * d2 / span**2
        return out[0], out[1], out[2]

    def _planar(self, s: FloatArray) -> list[FloatArray]:
        idx = np.clip(np.searchsorted(self.starts, s, side="right") - 1, 0, len(self.pieces) - 1)
        out = [np.empty((s.size, 2)) for _ in range(3)]
        for j in np.unique(idx):
            mask = idx == j
            u = s[mask] - self.starts[j]
            for d in range(3):
                out[d][mask] = self.pieces[j].spline(u, nu=d)
        for blend in self.blends:
            mask = (s > blend.s - blend.left) & (s < blend.s + blend.right)
            if np.any(mask):
                vals = self._blend(blend, s[mask])
                for d in range(3):
                    out[d][mask] = vals[d]
        return out

    def _extended(self, j: int, s: FloatArray, at_end: bool) -> list[FloatArray]:
        """Piece j on s, continued past its end (or before its start) by its Taylor series."""
        piece = self.pieces[j]
        u = s - self.starts[j]
        u0 = piece.length if at_end else 0.0
        outside = (u > u0) if at_end else (u < u0)
        vals = [piece.spline(np.clip(u, 0.0, piece.length), nu=d) for d in range(3)]
        p0, p1, p2 = (piece.spline(u0, nu=d) for d in range(3))
        h = (u - u0)[outside][:, None]
        vals[0][outside] = p0 + p1 * h + 0.5 * p2 * h**2
        vals[1][outside] = p1 + p2 * h
        vals[2][outside] = np.broadcast_to(p2, (h.shape[0], 2))
        return vals

    def _blend(self, blend: _Blend, s: FloatArray) -> list[FloatArray]:
        a = self._extended(blend.a, s, at_end=True)
        b = self._extended(blend.b, s, at_end=False)
        width = blend.left + blend.right
        phi, dphi, ddphi = _smoothstep((s - blend.s + blend.left) / width)
        phi, dphi, ddphi = phi[:, None], dphi[:, None] / width, ddphi[:, None] / width**2
        diff = [b[d] - a[d] for d in range(3)]
        return [
            a[0] + phi * diff[0],
            a[1] + dphi * diff[0] + phi * diff[1],
            a[2] + ddphi * diff[0] + 2.0 * dphi * diff[1] + phi * diff[2],
        ]


def build_path(strokes: list[FloatArray], options: PathOptions) -> WritingPath:
    """The C2 writing path through pen-down polylines (in x, z), with pen lifts between them."""
    pieces = _pieces(strokes, options)
    lengths = np.array([p.length for p in pieces])
    starts = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    blends = _blends(pieces, starts, options)
    return WritingPath(tuple(pieces), starts, tuple(blends), options)
