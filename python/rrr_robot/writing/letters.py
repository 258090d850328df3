"""Text to pen strokes with the Hershey vector fonts, for the writing task.

Latin characters (printable ASCII) come from one Hershey font (default ``scripts``, a cursive
whose lower-case letters join), Greek letters from a Greek Hershey font (default ``greek``, whose
ASCII slots hold the Greek alphabet: 'w' is omega, 'g' gamma, ...). Coordinates: x to the right
and z up, in metres, the base line of the first text line at z = 0 and its left edge at x = 0.

Consecutive strokes are joined the way a hand writes them: a stroke that starts where the last
one ended continues it; a stroke that starts on the last few millimetres of the previous one (the
stems of 'm' and 'n') is reached by running back along it, and a stroke whose head passes through
the pen's position (the spike of omega) is reached by running up its head and back. Both give
cusps where the pen reverses. Every other gap becomes a pen lift.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from ..core._arrays import FloatArray
from ..errors import BadInputError

__all__ = ["GREEK_KEYS", "join_strokes", "text_strokes"]

#: Unicode Greek letter -> the ASCII slot holding it in the Hershey Greek fonts.
GREEK_KEYS: dict[str, str] = {
    **dict(zip("αβγδεζηθικλμνξοπρστυφχψω", "abgdezhqiklmnxoprstufcyw", strict=True)),
    **dict(zip("ΑΒΓΔΕΖΗΘΙΚΛΜΝΞΟΠΡΣΤΥΦΧΨΩ", "ABGDEZHQIKLMNXOPRSTUFCYW", strict=True)),
}
CAP_HEIGHT_UNITS = 21.0          # Hershey 'normal' size: base line y = 9, cap line y = -12
_ON_TOL = 1e-6                   # font units: a point lies on a polyline


@functools.lru_cache(maxsize=8)
def _font(name: str) -> dict[str, Any]:
    from HersheyFonts import HersheyFonts

    font = HersheyFonts()
    try:
        font.load_default_font(name)
    except ValueError as exc:
        raise BadInputError(
            f"unknown Hershey font {name!r}; available: {', '.join(font.default_font_names)}"
        ) from exc
    glyphs: dict[str, Any] = font.all_glyphs
    return glyphs


def _glyph(ch: str, latin_font: str, greek_font: str) -> Any:
    if ch in GREEK_KEYS:
        return _font(greek_font)[GREEK_KEYS[ch]]
    if " " <= ch <= "~":
        return _font(latin_font)[ch]
    raise BadInputError(
        f"character {ch!r} (U+{ord(ch):04X}) has no glyph: the writing fonts cover printable "
        "ASCII and the Greek alphabet"
    )


def _line_strokes(line: str, latin_font: str, greek_font: str) -> tuple[list[FloatArray], float]:
    """Strokes of one text line in font units (y down, base line y = 9), and its advance."""
    strokes: list[FloatArray] = []
    x0 = 0.0
    for ch in line:
        glyph = _glyph(ch, latin_font, greek_font)
        for stroke in glyph.strokes:
            pts = np.asarray(stroke, dtype=float)
            pts[:, 0] += x0 - glyph.left_offset
            strokes.append(pts)
        x0 += glyph.char_width
    return strokes, x0


def text_strokes(
    text: str,
    letter_height: float,
    latin_font: str = "scripts",
    greek_font: str = "greek",
    line_spacing: float = 1.6,
) -> list[FloatArray]:
    """Pen-down polylines (m_i, 2) of a text, in metres (x right, z up), joined as by hand.

    ``letter_height`` is the height of a capital letter (base line to cap line); lines are
    ``line_spacing * letter_height`` apart ('\\n' starts a new line).
    Raises BadInputError for a character without a glyph or a text that draws nothing.
    """
    scale = letter_height / CAP_HEIGHT_UNITS
    out: list[FloatArray] = []
    for k, line in enumerate(text.split("\n")):
        strokes, _ = _line_strokes(line, latin_font, greek_font)
        for pts in join_strokes(strokes, retrace_max=0.6 * CAP_HEIGHT_UNITS):
            xz = np.column_stack([pts[:, 0], 9.0 - pts[:, 1]]) * scale
            xz[:, 1] -= k * line_spacing * letter_height
            out.append(xz)
    if not out:
        raise BadInputError(f"text {text!r} draws nothing")
    return out


def _dedupe(pts: FloatArray) -> FloatArray:
    keep = np.ones(len(pts), dtype=bool)
    keep[1:] = np.any(np.abs(np.diff(pts, axis=0)) > _ON_TOL, axis=1)
    return pts[keep]


def _locate(poly: FloatArray, p: FloatArray, from_end: bool) -> tuple[int, float] | None:
    """Segment index k and the polyline length between p (on segment k) and the polyline's
    end (from_end) or start; None if p is not on the polyline."""
    seg = np.diff(poly, axis=0)
    seg_len = np.hypot(seg[:, 0], seg[:, 1])
    rel = p - poly[:-1]
    u = np.clip(np.einsum("ij,ij->i", rel, seg) / np.maximum(seg_len**2, 1e-300), 0.0, 1.0)
    dist = np.hypot(*(poly[:-1] + u[:, None] * seg - p).T)
    hits = np.flatnonzero(dist < _ON_TOL)
    if hits.size == 0:
        return None
    k = int(hits[-1] if from_end else hits[0])
    if from_end:
        return k, float((1.0 - u[k]) * seg_len[k] + seg_len[k + 1 :].sum())
    return k, float(u[k] * seg_len[k] + seg_len[:k].sum())


def _join_pair(a: FloatArray, b: FloatArray, retrace_max: float) -> FloatArray | None:
    """a and b as one pen-down polyline, or None if the pen has to be lifted."""
    if np.all(np.abs(b[0] - a[-1]) < _ON_TOL):
        return _dedupe(np.vstack([a, b]))
    tail = _locate(a, b[0], from_end=True)
    if tail is not None and tail[1] <= retrace_max:
        back = a[tail[0] + 1 :][::-1]
        return _dedupe(np.vstack([a, back, b]))
    head = _locate(b, a[-1], from_end=False)
    if head is not None and head[1] <= retrace_max:
        up = b[: head[0] + 1][::-1]
        return _dedupe(np.vstack([a, up, b[1:]]))
    return None


def join_strokes(strokes: list[FloatArray], retrace_max: float) -> list[FloatArray]:
    """Merge consecutive strokes the pen can draw without lifting (see the module doc)."""
    out: list[FloatArray] = []
    for stroke in strokes:
        pts = _dedupe(np.asarray(stroke, dtype=float))
        if len(pts) < 2:
            continue
        joined = _join_pair(out[-1], pts, retrace_max) if out else None
        if joined is None:
            out.append(pts)
        else:
            out[-1] = joined
    return out
