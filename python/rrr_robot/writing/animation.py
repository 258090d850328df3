"""Animations of the writing task: the arm in 3-D writing, one file per scenario
(``rrr writing --animate``; :func:`animate_result` for a result of your own).

Each frame shows the links (the DH chain from the base through the shoulder and elbow offsets to
the pen tip, at the co-simulated joint angles), the pen trace written so far (the executed tip
where the pen touches the paper) and the reference path, in the writing plane's outline. Frames
are taken every 1/``fps`` s of simulated time (default :data:`FPS`; the last sample is always a
frame), drawn with matplotlib on an Agg canvas and encoded as an animated GIF by Pillow, or as
MP4 (H.264) by the ffmpeg that the ``imageio-ffmpeg`` package ships (``pip install
'rrr_robot[mp4]'``); the file appears complete or not at all (rrr_robot.core.outputs).
"""

from __future__ import annotations

import importlib.util
import logging
import math
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any, cast

import numpy as np

from ..core._arrays import FloatArray
from ..core.inertial import dh_links, dh_transform
from ..core.model import Model
from ..core.outputs import atomic_open, atomic_path
from ..errors import BadInputError
from ..sim.cosim import CosimResult
from .trajectory import Reference

log = logging.getLogger(__name__)

__all__ = ["ANIMATION_FORMATS", "FPS", "LINK_COLOR", "MAX_FRAMES", "animate_result",
           "animation_format", "frame_indices", "link_points", "max_fps", "mp4_available"]

#: Frames per second of simulated time (the default 5.9 s run: 90 frames per scenario).
FPS = 15.0
#: Formats: "gif" (Pillow), "mp4" (imageio-ffmpeg), "auto" (mp4 when available, else gif).
ANIMATION_FORMATS = ("auto", "gif", "mp4")
#: Colour of the links (RGB), of the pen trace and of the reference path.
LINK_COLOR = (31, 78, 156)
TRACE_COLOR = (214, 39, 40)
REFERENCE_COLOR = (150, 150, 150)
_SIZE = (6.4, 4.8)          # in
_DPI = 80                   # 512 x 384 pixels
#: Frames of one animation at most (of 512 x 384 pixels: about 600 MB of frames for a GIF).
MAX_FRAMES = 3000


def mp4_available() -> bool:
    """Whether MP4 can be written (the ``imageio-ffmpeg`` package is installed)."""
    return importlib.util.find_spec("imageio_ffmpeg") is not None


def animation_format(fmt: str) -> str:
    """The format a request stands for ("auto": mp4 when imageio-ffmpeg is installed, else
    gif); BadInputError for an unknown one or mp4 without imageio-ffmpeg."""
    if fmt not in ANIMATION_FORMATS:
        raise BadInputError(f"unknown animation format {fmt!r}: one of "
                            f"{', '.join(ANIMATION_FORMATS)}")
    if fmt == "auto":
        return "mp4" if mp4_available() else "gif"
    if fmt == "mp4" and not mp4_available():
        raise BadInputError("MP4 animations need imageio-ffmpeg (pip install "
                            "'rrr_robot[mp4]'); --animate gif needs nothing more")
    return fmt


def link_points(model: Model, q: FloatArray) -> FloatArray:
    """The arm as a polyline per joint configuration, (n, 7, 3): the base, then for each joint
    the point d_i along its axis and the next frame's origin (a_i along x), so the last point is
    the tip (the forward kinematics)."""
    q = np.atleast_2d(np.asarray(q, dtype=float))
    n = q.shape[0]
    rot = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    pos = np.zeros((n, 3))
    points = [pos.copy()]
    for i, (d, a, alpha) in enumerate(dh_links(model.dh)):
        c, s = np.cos(q[:, i]), np.sin(q[:, i])
        rz = np.zeros((n, 3, 3))
        rz[:, 0, 0], rz[:, 0, 1], rz[:, 1, 0], rz[:, 1, 1], rz[:, 2, 2] = c, -s, s, c, 1.0
        turned = rot @ rz
        points.append(pos + turned @ np.array([0.0, 0.0, d]))
        link_rot, link_pos = dh_transform(d, a, alpha)
        pos = pos + turned @ link_pos
        points.append(pos.copy())
        rot = turned @ link_rot
    return np.stack(points, axis=1)


def frame_indices(t: FloatArray, fps: float = FPS) -> np.ndarray:
    """Sample indices of the frames: the first sample at or after each multiple of 1/fps, and
    the last sample."""
    if not (math.isfinite(fps) and fps > 0):
        raise BadInputError(f"fps must be a positive number, got {fps!r}")
    t = np.asarray(t, dtype=float)
    marks = np.arange(t[0], t[-1], 1.0 / fps)
    idx = np.unique(np.concatenate([np.searchsorted(t, marks - 1e-12), [t.size - 1]]))
    if idx.size > MAX_FRAMES:
        raise BadInputError(f"an animation of {idx.size} frames ({t[-1] - t[0]:.1f} s at {fps:g} "
                            f"frames per simulated second): at most {MAX_FRAMES}; lower --fps "
                            f"to {max_fps(t):.3g} or less")
    return idx


def max_fps(t: FloatArray) -> float:
    """The largest frame rate (frames per simulated second) that keeps an animation of the
    times ``t`` within MAX_FRAMES frames."""
    span = float(t[-1] - t[0])
    return (MAX_FRAMES - 2) / span if span > 0 else FPS


def _rgb(color: tuple[int, int, int]) -> tuple[float, float, float]:
    return (color[0] / 255.0, color[1] / 255.0, color[2] / 255.0)


class _Scene:
    """The figure and the artists one frame updates. The view does not move, so everything but
    the links, the trace and the time is drawn once; each frame restores that background and
    draws the moving artists over it (blitting on the Agg canvas)."""

    def __init__(self, model: Model, ref: Reference, result: CosimResult, title: str) -> None:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        self.ref, self.result, self.title = ref, result, title
        self.arm = link_points(model, result.q)
        self.fig = Figure(figsize=_SIZE, dpi=_DPI)
        self.canvas: Any = cast(Any, FigureCanvasAgg(self.fig))  # matplotlib is untyped here
        ax: Any = self.fig.add_subplot(projection="3d")
        self.ax = ax
        down = ref.pen_down
        ax.plot(*np.where(down, ref.x.T, np.nan), "--", color=_rgb(REFERENCE_COLOR), lw=1.0,
                label="reference")
        spec = ref.spec
        (x0, x1), (z0, z1), y = spec.x_range, spec.z_range, spec.plane_y
        ax.plot([x0, x1, x1, x0, x0], [y] * 5, [z0, z0, z1, z1, z0], color="0.8", lw=0.8)
        (self.trace,) = ax.plot([], [], [], "-", color=_rgb(TRACE_COLOR), lw=2.0,
                                label="pen trace", animated=True)
        (self.links,) = ax.plot([], [], [], "-o", color=_rgb(LINK_COLOR), lw=5, ms=6,
                                label="arm", animated=True)
        self.time = self.fig.text(0.5, 0.96, "", ha="center", va="top", fontsize=10,
                                  animated=True)
        everything = np.vstack([self.arm.reshape(-1, 3), ref.x])
        lo, hi = everything.min(axis=0), everything.max(axis=0)
        mid, half = 0.5 * (lo + hi), 0.5 * float(np.max(hi - lo)) + 0.02
        z_lo = max(0.0, mid[2] - half)
        ax.set(xlim=(mid[0] - half, mid[0] + half), ylim=(mid[1] - half, mid[1] + half),
               zlim=(z_lo, mid[2] + half), xlabel="x [m]", ylabel="y [m]", zlabel="z [m]")
        ax.set_box_aspect((1.0, 1.0, (mid[2] + half - z_lo) / (2 * half)))
        ax.view_init(elev=18.0, azim=-62.0)   # from the paper's side: the text reads left to right
        ax.legend(loc="upper left", fontsize=8)
        self.fig.subplots_adjust(left=0.0, right=1.0, bottom=0.02, top=0.95)
        self.canvas.draw()   # the static part, and the projection the moving artists use
        self.background = self.canvas.copy_from_bbox(self.fig.bbox)

    def draw(self, k: int) -> np.ndarray:
        """Frame at sample k as an (h, w, 3) uint8 array."""
        arm = self.arm[k]
        self.links.set_data_3d(arm[:, 0], arm[:, 1], arm[:, 2])
        tip = np.where(self.ref.pen_down[: k + 1, None], self.result.tip[: k + 1], np.nan)
        self.trace.set_data_3d(tip[:, 0], tip[:, 1], tip[:, 2])
        self.time.set_text(f"{self.title}   t = {self.result.t[k]:.2f} s".strip())
        self.canvas.restore_region(self.background)
        self.ax.draw_artist(self.trace)
        self.ax.draw_artist(self.links)
        self.fig.draw_artist(self.time)
        rgba = np.asarray(self.canvas.buffer_rgba())
        return np.array(rgba[:, :, :3])


def _frames(scene: _Scene, idx: np.ndarray,
            progress: Callable[[int, int], None] | None) -> Iterator[np.ndarray]:
    for j, k in enumerate(idx):
        yield scene.draw(int(k))
        if progress is not None:
            progress(j + 1, idx.size)


def _write_gif(path: Path, scene: _Scene, frames: Iterator[np.ndarray], fps: float) -> None:
    from PIL import Image

    # one palette for every frame: the colours of the links, the trace and the reference
    # exactly, then those of the finished picture (every other colour is in it): no flicker,
    # no dithering noise, and the frames compress well
    finished = Image.fromarray(scene.draw(scene.result.t.size - 1)).quantize(
        colors=120, method=Image.Quantize.MEDIANCUT)
    colors = [c for rgb in (LINK_COLOR, TRACE_COLOR, REFERENCE_COLOR) for c in rgb]
    palette = Image.new("P", (1, 1))
    palette.putpalette(colors + (finished.getpalette() or [])[: 3 * 120])
    images = [Image.fromarray(f).quantize(palette=palette, dither=Image.Dither.NONE)
              for f in frames]
    hold = [images[-1]] * round(fps)   # rest a second on the finished text
    with atomic_open(path, "wb") as fh:
        images[0].save(fh, format="GIF", save_all=True, append_images=images[1:] + hold,
                       duration=round(1000.0 / fps), loop=0, optimize=False)


def _write_mp4(path: Path, frames: Iterator[np.ndarray], fps: float) -> None:
    import imageio_ffmpeg

    first = next(frames)
    h, w = first.shape[:2]
    with atomic_path(path) as tmp:
        writer = imageio_ffmpeg.write_frames(
            str(tmp), (w, h), fps=fps, codec="libx264", quality=6, macro_block_size=16,
            pix_fmt_out="yuv420p", output_params=["-f", "mp4"], ffmpeg_log_level="error")
        writer.send(None)   # start ffmpeg
        try:
            last = first
            writer.send(first)
            for frame in frames:
                writer.send(frame)
                last = frame
            for _ in range(round(fps)):
                writer.send(last)
        finally:
            writer.close()


def animate_result(path: str | Path, model: Model, ref: Reference, result: CosimResult,
                   title: str = "", fps: float = FPS, fmt: str = "auto",
                   progress: Callable[[int, int], None] | None = None) -> Path:
    """Write the animation of one co-simulated (or native) result along its reference to
    ``path`` (``fmt``: gif, mp4 or auto, see :func:`animation_format`); ``progress(done,
    total)`` after each frame. Returns the path."""
    kind = animation_format(fmt)
    if result.q.shape[0] != ref.t.shape[0]:
        raise BadInputError(f"the result has {result.q.shape[0]} samples, the reference "
                            f"{ref.t.shape[0]}: animate a result along its own reference")
    idx = frame_indices(result.t, fps)
    scene = _Scene(model, ref, result, title)
    frames = _frames(scene, idx, progress)
    out = Path(path)
    if kind == "gif":
        _write_gif(out, scene, frames, fps)
    else:
        _write_mp4(out, frames, fps)
    log.info("animated %s: %d frames at %g fps", out.name, idx.size, fps)
    return out
