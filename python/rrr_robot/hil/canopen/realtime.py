"""The CANopen master in real time (``rrr hil canopen --realtime``, docs/canopen.md "Real
time"): the SYNC every 1 ms period from python-can's periodic sender (the thread canopen's
SyncProducer starts: absolute due times and a sleep only; the master counts each SYNC it sends,
so that a second TPDO of a drive in one SYNC is seen), the master's heartbeat for the drives'
consumer 0x1016, the drives' watchdogs (their consumer time and their RPDO timeout 0x2001, both
settable), and the timing statistics of a run, measured where the drives see it (the plant
node's frame log). The C master (``--master c``) SYNCs on its own clock (rrr_hil_rt), with its
own heartbeat and the same settable watchdogs.
"""

from __future__ import annotations

import gc
import os
import sys
import time
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import BadInputError, EmcyError, HilError
from ..nodes import PERIOD

__all__ = ["CanopenRealTime", "frame_log_timing", "realtime_summary"]

#: The master's heartbeat producer period (ms) and the drives' consumer time 0x1016 (ms): CiA
#: 301 wants the consumer time above the producer's; 5 heartbeats may be lost before a fault.
HEARTBEAT_MS = 20
CONSUMER_MS = 100
#: The drives' RPDO timeout (0x2001, UNSIGNED8): SYNC periods without an RPDO before a fault.
RPDO_TIMEOUT_MAX = 255
_SW_MASK, _SW_ENABLED = 0x6F, 0x27  # statusword: OPERATION ENABLED
#: SYNC periods the master goes on after an EMCY (reading and dropping the frames: the drives
#: report their reaction in their TPDOs and the plant logs the periods at 0 V) before it ends
#: the run.
EMCY_GRACE_PERIODS = 20
#: s: at the end of a run, how long the master reads the TPDOs still on their way.
DRAIN_S = 0.1


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


@dataclass(frozen=True)
class CanopenRealTime:
    """A real-time run of a master: the SCHED_FIFO priority of its threads (0: the default
    scheduler; applied when permitted, a warning otherwise), the spin before each release of
    the C master's clock (us; 0: sleep only), the heartbeat producer period and the drives'
    consumer time (ms), the drives' RPDO timeout 0x2001 (SYNC periods; None: the EDS's, 3), and
    ``heartbeat_stop_at``: fault injection, the master's heartbeat stops at that SYNC (the drives
    must fault). The C master takes the consumer time and the RPDO timeout (its --consumer-ms,
    --rpdo-timeout), its own heartbeat period, and no heartbeat_stop_at."""

    fifo: int = 80
    spin_us: int = 100
    heartbeat_ms: int = HEARTBEAT_MS
    consumer_ms: int = CONSUMER_MS
    rpdo_timeout: int | None = None
    heartbeat_stop_at: int | None = None

    def __post_init__(self) -> None:
        if not 0 <= self.fifo <= 99 or not 0 <= self.spin_us <= 250:
            raise BadInputError(f"SCHED_FIFO priority 0..99 and spin 0..250 us expected, got "
                                f"{self.fifo} and {self.spin_us}")
        if not 1 <= self.heartbeat_ms < self.consumer_ms <= 0xFFFF:
            raise BadInputError(f"heartbeat {self.heartbeat_ms} ms must be shorter than the "
                                f"consumer time {self.consumer_ms} ms (at most 65535)")
        if self.rpdo_timeout is not None and not 1 <= self.rpdo_timeout <= RPDO_TIMEOUT_MAX:
            raise BadInputError(f"the drives' RPDO timeout is 1..{RPDO_TIMEOUT_MAX} SYNC "
                                f"periods, got {self.rpdo_timeout}")


@contextmanager
def realtime_process(rt: CanopenRealTime) -> Iterator[str]:
    """SCHED_FIFO for the calling thread (and the threads it starts after), the garbage
    collector off and a short GIL switch interval for the run: each as permitted (a warning
    otherwise); yields what was applied."""
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
    notes += ["gc off", "GIL switch 100 us", "python-can SYNC thread"]
    try:
        yield ", ".join(notes)
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


def realtime_summary(rt: CanopenRealTime, master_setup: str | None, plant_view: dict[str, Any],
                     c_master: dict[str, Any] | None = None,
                     plant_setup: str | None = None) -> dict[str, Any]:
    """The ``realtime`` section of summary.json: the SYNC source (the canopen package's
    producer, or the C master's clock), the heartbeat times and the drives' watchdogs, the
    drives' view (frame_log_timing) and the master's own (the Python master: what was applied;
    the C master: its wake-up latency p50/p99/p99.9/max, work time, misses, late TPDO sets,
    skipped releases)."""
    out: dict[str, Any] = {"sync_source": "clock" if c_master is not None else "canopen",
                           "sync_period_ms": PERIOD * 1e3,
                           "master_heartbeat_ms": rt.heartbeat_ms,
                           "drive_consumer_ms": rt.consumer_ms,
                           "drive_rpdo_timeout_syncs": rt.rpdo_timeout, "drives": plant_view,
                           "plant_setup": plant_setup}
    if c_master is not None:  # the C master's rrr_hil_rt report
        rep = c_master.get("rt", {})
        out["master"] = {
            "setup": rep.get("rt_setup"), "rt_deadline_misses": rep.get("rt_deadline_misses"),
            "late_tpdos": c_master.get("late_tpdos"), "skipped_releases": rep.get("rt_skipped"),
            "work": {"max_us": rep.get("rt_work_max_us")},
            "wake_up": {k: rep.get(f"rt_latency_{k}") for k in ("p50_us", "p99_us", "p999_us",
                                                                "max_us")},
            "heartbeats": c_master.get("heartbeats")}
    elif master_setup is not None:
        out["master"] = {"setup": master_setup}
    return out


Law = Callable[[int, list[tuple[int, int, int]]], Sequence[int]]


def run_periods(master: Any, n: int, law: Law, rt: CanopenRealTime,
                progress: Callable[[int, int], None] | None = None) -> None:
    """``n`` SYNC periods in real time on ``master`` (master._Master, its drives in OPERATION
    ENABLED and NMT operational, the master's heartbeat running), the SYNCs from the canopen
    master's producer (python-can's periodic sender, sleep only): the master answers the newest
    complete set of TPDOs, ``law(k, feedback)`` (per drive: statusword, position, velocity)
    gives the target torques, sent in the RPDOs. The SYNCs it did not answer before the next
    are the drives' deadline misses (:func:`frame_log_timing`). EmcyError on an EMCY (after
    EMCY_GRACE_PERIODS more SYNCs), HilError on a drive that left OPERATION ENABLED or no TPDOs
    for ``master.timeout``."""
    nodes = master.nodes
    ids = [node.id for node in nodes]
    newest: dict[int, bytes] = {}
    counts = {cob: 0 for i in ids for cob in (0x180 + i, 0x280 + i)}

    def take(want: int, k: int) -> None:
        """Frames until every TPDO has come ``want`` times; HilError after master.timeout."""
        deadline = time.monotonic() + master.timeout
        while min(counts.values()) < want:
            got = master.next_frame(max(0.0, deadline - time.monotonic()),
                                    f"the TPDOs of SYNC {k}")
            if got is None:
                raise HilError(f"SYNC {k}: TPDOs missing after {master.timeout:g} s")
            cob, data = got
            if 0x80 < cob < 0x100:
                raise EmcyError(k, cob - 0x80, int.from_bytes(data[:2], "little"))
            if cob in counts:
                master.check_tpdo(cob, data, k)
                counts[cob] += 1
                newest[cob] = data

    def after_emcy(emcy: EmcyError) -> EmcyError:
        """EMCY_GRACE_PERIODS more SYNCs (their frames read and dropped), then the EMCY."""
        want = min(counts.values()) + EMCY_GRACE_PERIODS
        deadline = time.monotonic() + master.timeout
        while min(counts.values()) < want:
            got = master.next_frame(max(0.0, deadline - time.monotonic()), "frames after an EMCY")
            if got is None:
                break
            if got[0] in counts:
                counts[got[0]] += 1
        return emcy

    heartbeat_on = True
    master.send_rpdos([0, 0, 0], 0)
    master.start_sync(PERIOD)
    try:
        k = -1
        while k < n - 1:
            want = k + 2
            if heartbeat_on and rt.heartbeat_stop_at is not None \
                    and want - 1 >= rt.heartbeat_stop_at:
                master.stop_heartbeat()
                heartbeat_on = False
            try:
                take(want, want - 1)
            except EmcyError as emcy:
                raise after_emcy(emcy) from None
            k = min(n - 1, min(counts.values()) - 1)
            if k == n - 1:
                master.stop_sync()
            torques = law(k, decode_feedback(k, ids, newest))
            if k < n - 1:
                master.send_rpdos(torques, k)
            if progress is not None:
                progress(k + 1, n)
        # the answers still on their way (the drives' TPDOs may lag behind the SYNCs, and a
        # repeat among them shows only once each count can pass the SYNCs sent)
        deadline = time.monotonic() + DRAIN_S
        while min(master.tpdos.get(cob, 0) for cob in counts) < master.syncs:
            got = master.next_frame(max(0.0, deadline - time.monotonic()), "the last TPDOs")
            if got is None:
                break
            if got[0] in counts:
                master.check_tpdo(got[0], got[1], master.syncs - 1)
    finally:
        master.stop_sync()
