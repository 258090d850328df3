"""Velocities and accelerations from measured positions by zero-phase filtering.

``butter``: 4th-order Butterworth low-pass applied forwards and backwards (scipy filtfilt, no
phase lag), then central differences. ``savgol``: Savitzky-Golay derivative filters (local
polynomial fits). The voltages go through the same low-pass ("parallel filtering") so that the
regression u <-> R(q, qd, qdd) sees both sides with the same distortion. The log's u[k] is
held from t_k to t_k+1 (a digital controller's zero-order hold), so the voltage acting around
t_k is (u[k-1] + u[k]) / 2: without this half-sample shift the estimates are biased by about
1 % at 1 kHz.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core._arrays import FloatArray
from ..errors import BadInputError
from .logs import Log

METHODS = ("butter", "savgol", "log")


@dataclass(frozen=True)
class Filtered:
    """Filtered signals of one log, same rows as the log."""

    t: FloatArray
    q: FloatArray
    qd: FloatArray
    qdd: FloatArray
    u: FloatArray


def _butter(t: FloatArray, q: FloatArray, u: FloatArray, cutoff: float) -> Filtered:
    from scipy.signal import butter, filtfilt  # imported when a log is filtered: it is slow

    dt = float(t[1] - t[0])
    nyq = 0.5 / dt
    if not 0 < cutoff < nyq:
        raise BadInputError(f"cutoff {cutoff} Hz must lie in (0, {nyq:g}) Hz (Nyquist)")
    b, a = butter(4, cutoff / nyq)
    pad = min(3 * max(len(a), len(b)) * 50, q.shape[0] - 1)
    qf = filtfilt(b, a, q, axis=0, padlen=pad)
    qd = np.gradient(qf, dt, axis=0)
    qdd = np.gradient(qd, dt, axis=0)
    return Filtered(t, qf, qd, qdd, filtfilt(b, a, u, axis=0, padlen=pad))


def _savgol(t: FloatArray, q: FloatArray, u: FloatArray, cutoff: float) -> Filtered:
    from scipy.signal import savgol_filter

    dt = float(t[1] - t[0])
    # a quartic Savitzky-Golay filter has its -3 dB point near f = (order + 1) / (3.2 N dt)
    window = int(np.clip(round(5.0 / (3.2 * cutoff * dt)), 7, q.shape[0] - 1)) | 1
    kw = {"window_length": window, "polyorder": 4, "axis": 0}
    return Filtered(t, savgol_filter(q, **kw), savgol_filter(q, deriv=1, delta=dt, **kw),
                    savgol_filter(q, deriv=2, delta=dt, **kw), savgol_filter(u, **kw))


def derivatives(lg: Log, method: str = "butter", cutoff: float = 15.0) -> Filtered:
    """Filtered q, qd, qdd and u of a log (method 'butter', 'savgol' or 'log' = take the
    logged qd and qdd columns as they are)."""
    if method == "log":
        if lg.qd is None or lg.qdd is None:
            raise BadInputError(f"{lg.source}: derivatives='log' needs columns qd[1..3] and "
                                "qdd[1..3]")
        return Filtered(lg.t, lg.q, lg.qd, lg.qdd, lg.u)
    u = np.vstack([lg.u[:1], 0.5 * (lg.u[1:] + lg.u[:-1])])   # zero-order hold, see module
    if method == "butter":
        return _butter(lg.t, lg.q, u, cutoff)
    if method == "savgol":
        return _savgol(lg.t, lg.q, u, cutoff)
    raise BadInputError(f"unknown derivative method {method!r} (choose from {METHODS})")
