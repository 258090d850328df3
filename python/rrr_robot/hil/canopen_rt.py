"""The CANopen master in real time (``rrr hil canopen --realtime``, docs/canopen.md "Real
time"): SYNC by the clock every 1 ms period, the master's heartbeat for the drives' consumer
0x1016, and the timing statistics of a run, measured where the drives see it (the plant node's
frame log) and, for the clock's own SYNC, at the master.

Two SYNC sources: ``clock`` (the master's loop: absolute release times on CLOCK_MONOTONIC, a
sleep to ``spin_us`` before each release and then a spin, as the C nodes' rrr_hil_rt_wait; the
SYNC is sent at the release, then the TPDOs of that SYNC are awaited, the law computed and the
RPDOs sent before the next release) or ``canopen`` (the package's own producer,
``network.sync.start(period)``: python-can's thread with absolute due times and a sleep only;
the master reacts to each SYNC's TPDOs). docs/canopen.md gives the measured jitter of both
(bench/bench_canopen_sync.py); ``clock`` is the default.
"""

from __future__ import annotations

import gc
import os
import sys
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, NoReturn

import numpy as np

from ..errors import BadInputError
from .protocol import PERIOD, HilError
from .results import latency_stats

__all__ = ["SYNC_SOURCES", "CanopenRealTime", "PeriodClock", "RtRecord", "frame_log_timing",
           "realtime_summary"]

#: The SYNC producers of a real-time run.
SYNC_SOURCES = ("clock", "canopen")
#: The master's own node id (its heartbeat 0x700 + id; CiA 301 leaves 0x7F to no slave here).
MASTER_ID = 0x7F
#: The master's heartbeat producer period (ms) and the drives' consumer time 0x1016 (ms): CiA
#: 301 wants the consumer time above the producer's; 5 heartbeats may be lost before a fault.
HEARTBEAT_MS = 20
CONSUMER_MS = 100
_SW_MASK, _SW_ENABLED = 0x6F, 0x27  # statusword: OPERATION ENABLED


def decode_feedback(k: int, node_ids: Sequence[int], tpdos: dict[int, bytes]
                    ) -> list[tuple[int, int, int]]:
    """(statusword, position 0x6064, velocity 0x606C) of each drive from its TPDO1 and TPDO2
    (``tpdos`` by COB-ID); HilError naming SYNC ``k`` if a drive left OPERATION ENABLED."""
    out = []
    for node in node_ids:
        t1, t2 = tpdos[0x180 + node], tpdos[0x280 + node]
        sw = int.from_bytes(t1[0:2], "little")
        if sw & _SW_MASK != _SW_ENABLED:
            raise HilError(f"SYNC {k}: drive {node} left OPERATION ENABLED (statusword "
                           f"0x{sw:04X})")
        out.append((sw, int.from_bytes(t1[2:6], "little", signed=True),
                    int.from_bytes(t2[0:4], "little", signed=True)))
    return out


#: us before the next release: the clock's master stops waiting for a SYNC's TPDOs, runs the law
#: on the newest there are and sends the RPDOs (they must reach the drives before the SYNC)
RPDO_GUARD_US = 200


@dataclass(frozen=True)
class CanopenRealTime:
    """A real-time run of the Python master: the SYNC source (SYNC_SOURCES), the SCHED_FIFO
    priority of the master's threads (0: the default scheduler; applied when permitted, a
    warning otherwise), the spin before each release (us; 0: sleep only), the heartbeat
    producer period and the drives' consumer time (ms), and ``heartbeat_stop_at``: fault
    injection, the master's heartbeat stops at that SYNC (the drives must fault)."""

    sync_source: str = "clock"
    fifo: int = 80
    spin_us: int = 100
    heartbeat_ms: int = HEARTBEAT_MS
    consumer_ms: int = CONSUMER_MS
    heartbeat_stop_at: int | None = None

    def __post_init__(self) -> None:
        if self.sync_source not in SYNC_SOURCES:
            raise BadInputError(f"SYNC source must be one of {', '.join(SYNC_SOURCES)}, got "
                                f"{self.sync_source!r}")
        if not 0 <= self.fifo <= 99 or not 0 <= self.spin_us <= 250:
            raise BadInputError(f"SCHED_FIFO priority 0..99 and spin 0..250 us expected, got "
                                f"{self.fifo} and {self.spin_us}")
        if not 1 <= self.heartbeat_ms < self.consumer_ms <= 0xFFFF:
            raise BadInputError(f"heartbeat {self.heartbeat_ms} ms must be shorter than the "
                                f"consumer time {self.consumer_ms} ms (at most 65535)")


@dataclass
class RtRecord:
    """What the master measured of a real-time run: per SYNC its wake-up latency after the
    release (ns; clock only) and the work time to the last RPDO sent (ns), the periods whose
    RPDOs went out after the next release (misses), those whose TPDOs had not all come by then
    (late: no RPDO sent, the drives hold their last target torque), releases skipped, what was
    applied (setup) and the SYNC and heartbeat times."""

    latency_ns: list[int] = field(default_factory=list)
    work_ns: list[int] = field(default_factory=list)
    misses: int = 0
    late: int = 0
    skipped: int = 0
    setup: str = ""
    heartbeat_stopped_ns: int | None = None


class PeriodClock:
    """Absolute release times every ``period_ns`` on CLOCK_MONOTONIC: ``wait()`` sleeps to
    ``spin_ns`` before the next release and then spins up to it (rrr_hil_rt_wait's scheme),
    records the wake-up latency, and skips the releases already past (counted) after a late
    period."""

    def __init__(self, period_ns: int, spin_ns: int, rec: RtRecord) -> None:
        self.period_ns, self.spin_ns, self.rec = period_ns, spin_ns, rec
        self.next_ns = time.monotonic_ns() + 5 * period_ns
        self.release_ns = self.next_ns

    def wait(self) -> int:
        """Wait for the next release; its time (ns)."""
        target = self.next_ns
        left = target - self.spin_ns - time.monotonic_ns()
        if left > 0:
            time.sleep(left * 1e-9)
        now = time.monotonic_ns()
        while now < target:
            now = time.monotonic_ns()
        self.rec.latency_ns.append(now - target)
        self.release_ns = target
        self.next_ns = target + self.period_ns
        behind = (now - self.next_ns) // self.period_ns + 1 if now >= self.next_ns else 0
        if behind > 0:  # woke after the next release: those releases are skipped
            self.rec.skipped += int(behind)
            self.next_ns += int(behind) * self.period_ns
        return target

    def done(self) -> None:
        """The period's work ended: its time, a miss when after the next release."""
        now = time.monotonic_ns()
        self.rec.work_ns.append(now - self.release_ns)
        if now > self.release_ns + self.period_ns:
            self.rec.misses += 1


@contextmanager
def realtime_process(rt: CanopenRealTime, rec: RtRecord) -> Iterator[None]:
    """SCHED_FIFO for the calling thread (and the threads it starts after), the garbage
    collector off and a short GIL switch interval for the run: each as permitted (a warning
    otherwise); ``rec.setup`` says what was applied."""
    notes = []
    old_policy = None
    if rt.fifo and hasattr(os, "sched_setscheduler"):
        try:
            old_policy = (os.sched_getscheduler(0), os.sched_getparam(0))
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(rt.fifo))
            notes.append(f"SCHED_FIFO {rt.fifo}")
        except OSError as exc:
            old_policy = None
            warnings.warn(f"SCHED_FIFO {rt.fifo} refused ({exc.strerror}): the default "
                          "scheduler", RuntimeWarning, stacklevel=3)
            notes.append("SCHED_OTHER (SCHED_FIFO refused)")
    else:
        notes.append("SCHED_OTHER")
    switch = sys.getswitchinterval()
    sys.setswitchinterval(1e-4)
    enabled = gc.isenabled()
    gc.disable()
    notes += ["gc off", "GIL switch 100 us",
              f"spin {rt.spin_us} us" if rt.sync_source == "clock" else "canopen SYNC thread"]
    rec.setup = ", ".join(notes)
    try:
        yield
    finally:
        if enabled:
            gc.enable()
        sys.setswitchinterval(switch)
        if old_policy is not None:
            try:
                os.sched_setscheduler(0, old_policy[0], old_policy[1])
            except OSError:
                pass


def _us_stats(v: Any) -> dict[str, float | None]:
    if len(v) == 0:
        return {"min_us": None, "median_us": None, "p99_us": None, "max_us": None}
    a = np.sort(np.asarray(v, dtype=float)) * 1e-3
    return {"min_us": float(a[0]), "median_us": float(np.median(a)),
            "p99_us": float(a[min(a.size, max(1, int(np.ceil(0.99 * a.size)))) - 1]),
            "max_us": float(a[-1])}


def frame_log_timing(records: np.ndarray, node_ids: Sequence[int],
                     period_s: float = PERIOD) -> dict[str, Any]:
    """The timing of a CANopen run as the drives saw it, from the plant node's frame log: the
    SYNC periods received (min, median, p99, max, us), the jitter |period - nominal| (median,
    p99, max), and the deadline misses: the SYNC periods (after the first) before which not
    every drive had received its RPDO since the previous SYNC (that drive applied its last
    target torque again)."""
    rx = records[records["dir"] == 0]
    ids = rx["id"] & 0x1FFFFFFF
    t_sync = rx["t_ns"][ids == 0x080].astype(np.int64)
    d = np.diff(t_sync)
    jitter = np.abs(d - round(period_s * 1e9))
    missing = np.zeros(max(0, t_sync.size - 1), dtype=bool)
    for node in node_ids:
        t_rpdo = rx["t_ns"][ids == 0x200 + node].astype(np.int64)
        # the RPDOs that arrived between SYNC i-1 and SYNC i, for i = 1 ..
        bins = np.searchsorted(t_sync, t_rpdo, side="right")
        counts = np.bincount(bins, minlength=t_sync.size + 1)[1:t_sync.size]
        missing |= counts == 0
    return {"syncs": int(t_sync.size), "nominal_period_us": period_s * 1e6,
            "sync_period": _us_stats(d), "sync_jitter": _us_stats(jitter),
            "deadline_misses": int(np.count_nonzero(missing)),
            "deadline_miss_periods": [int(i) + 1 for i in np.flatnonzero(missing)[:20]]}


def realtime_summary(rt: CanopenRealTime, rec: RtRecord | None, plant_view: dict[str, Any],
                     c_master: dict[str, Any] | None = None,
                     plant_setup: str | None = None) -> dict[str, Any]:
    """The ``realtime`` section of summary.json: the SYNC source and heartbeat times, the
    drives' view (frame_log_timing) and the master's own (wake-up latency p50/p99/p99.9/max,
    work time, misses, late TPDO sets, skipped releases, what was applied)."""
    out: dict[str, Any] = {"sync_source": rt.sync_source, "sync_period_ms": PERIOD * 1e3,
                           "master_heartbeat_ms": rt.heartbeat_ms,
                           "drive_consumer_ms": rt.consumer_ms, "drives": plant_view,
                           "plant_setup": plant_setup}
    if rec is not None:
        master: dict[str, Any] = {"setup": rec.setup, "rt_deadline_misses": rec.misses,
                                  "late_tpdos": rec.late, "skipped_releases": rec.skipped,
                                  "work": _us_stats(rec.work_ns)}
        if rec.latency_ns:
            master["wake_up"] = latency_stats(np.asarray(rec.latency_ns, dtype=float))
        out["master"] = master
    elif c_master is not None:  # the C master's rrr_hil_rt report, in the same keys
        rep = c_master.get("rt", {})
        out["master"] = {
            "setup": rep.get("rt_setup"), "rt_deadline_misses": rep.get("rt_deadline_misses"),
            "late_tpdos": c_master.get("late_tpdos"), "skipped_releases": rep.get("rt_skipped"),
            "work": {"max_us": rep.get("rt_work_max_us")},
            "wake_up": {k: rep.get(f"rt_latency_{k}") for k in ("p50_us", "p99_us", "p999_us",
                                                                "max_us")},
            "heartbeats": c_master.get("heartbeats")}
    return out


class _Emcy(HilError):
    """An EMCY of a drive during the run."""


#: SYNC periods the clock's master goes on after an EMCY (SYNC only: the drives report their
#: reaction in their TPDOs and the plant logs the periods at 0 V) before it ends the run.
EMCY_GRACE_PERIODS = 20


def _after_emcy(master: Any, clock: PeriodClock, k: int, emcy: _Emcy) -> NoReturn:
    """EMCY_GRACE_PERIODS more SYNCs on the clock (the frames read and dropped), then the EMCY
    as HilError."""
    for _ in range(EMCY_GRACE_PERIODS):
        release = clock.wait()
        master.send_sync(k)
        while master.next_frame(max(0.0, (release + clock.period_ns - time.monotonic_ns())
                                    * 1e-9), "frames after an EMCY") is not None:
            pass
    raise HilError(str(emcy)) from None


Law = Callable[[int, list[tuple[int, int, int]]], Sequence[int]]


def run_periods(master: Any, n: int, law: Law, rt: CanopenRealTime, rec: RtRecord,
                progress: Callable[[int, int], None] | None = None) -> None:
    """``n`` SYNC periods in real time on ``master`` (canopen_master._Master, its drives in
    OPERATION ENABLED and NMT operational, the master's heartbeat running): per SYNC k the
    newest TPDOs, ``law(k, feedback)`` (per drive: statusword, position, velocity) gives the
    target torques, sent in the RPDOs before the next SYNC. HilError on an EMCY, a drive that
    left OPERATION ENABLED, or no TPDOs for ``master.timeout``."""
    period_ns = round(PERIOD * 1e9)
    nodes = master.nodes
    newest: dict[int, bytes] = {}
    counts = {cob: 0 for node in nodes for cob in (0x180 + node.id, 0x280 + node.id)}
    every = max(1, n // 100)

    def take(deadline_ns: int, want: int, k: int) -> bool:
        """Frames until every TPDO has come ``want`` times (True) or the deadline (False)."""
        while min(counts.values()) < want:
            left = deadline_ns - time.monotonic_ns()
            if left <= 0:
                return False
            got = master.next_frame(left * 1e-9, f"the TPDOs of SYNC {k}")
            if got is None:
                return False
            cob, data = got
            if 0x80 < cob < 0x100:
                raise _Emcy(f"SYNC {k}: EMCY 0x{int.from_bytes(data[:2], 'little'):04X} "
                            f"from drive {cob - 0x80}")
            if cob in counts:
                counts[cob] += 1
                newest[cob] = data
        return True

    def feedback(k: int) -> list[tuple[int, int, int]]:
        return decode_feedback(k, [node.id for node in nodes], newest)

    def maybe_stop_heartbeat(k: int) -> None:
        if (rt.heartbeat_stop_at is not None and k >= rt.heartbeat_stop_at
                and rec.heartbeat_stopped_ns is None):
            master.stop_heartbeat()
            rec.heartbeat_stopped_ns = time.monotonic_ns()

    master.send_rpdos([0, 0, 0], 0)
    if rt.sync_source == "clock":
        clock = PeriodClock(period_ns, rt.spin_us * 1000, rec)
        for k in range(n):
            release = clock.wait()
            maybe_stop_heartbeat(k)
            master.send_sync(k)
            # the TPDOs of this SYNC until RPDO_GUARD_US before the next release (the first
            # SYNC's: within the timeout); an SYNC whose TPDOs come later is late: the law runs
            # on the newest TPDOs there are, the RPDOs go out before the next SYNC all the same
            try:
                complete = take(release + period_ns - RPDO_GUARD_US * 1000 if k
                                else release + round(master.timeout * 1e9), k + 1, k)
            except _Emcy as emcy:
                _after_emcy(master, clock, k, emcy)
            if not complete:
                if k == 0:
                    raise HilError(f"SYNC 0: TPDOs missing after {master.timeout:g} s")
                rec.late += 1
            torques = law(k, feedback(k))
            if k < n - 1:
                master.send_rpdos(torques, k)
            clock.done()
            if progress is not None and (k % every == 0 or k == n - 1):
                progress(k + 1, n)
        return
    # the canopen package's SYNC producer (a python-can thread, sleep only): the master
    # answers the newest complete set of TPDOs; the SYNCs it did not answer in time are the
    # drives' deadline misses (frame_log_timing)
    master.network.sync.start(PERIOD)
    try:
        k = -1
        while k < n - 1:
            want = k + 2
            maybe_stop_heartbeat(want - 1)
            if not take(time.monotonic_ns() + round(master.timeout * 1e9), want, want - 1):
                raise HilError(f"SYNC {want - 1}: TPDOs missing after {master.timeout:g} s")
            k = min(n - 1, min(counts.values()) - 1)
            if k == n - 1:
                master.network.sync.stop()
            torques = law(k, feedback(k))
            if k < n - 1:
                master.send_rpdos(torques, k)
            if progress is not None:
                progress(k + 1, n)
    finally:
        master.network.sync.stop()
