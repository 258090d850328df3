"""ctypes binding of the CAN bench's command supervisor and frame decoder (C, hil_supervisor.h and
hil_codec.h), for the Python plant (:mod:`rrr_robot.hil.dbc.plant`).

The safety policy (hold, timeout to 0 V, CRC / counter / range / DLC faults, latch, reset)
exists once, in C: this module only mirrors the structures and forwards calls. The library is
``librrr_hil_supervisor.so`` (CMake target ``rrr_hil_supervisor``), found in
``$RRR_HIL_LIBRARY``, else ``$RRR_HIL_BIN_DIR`` (a CMake build's ``c_src/hil``), else in the
package folder ``rrr_robot/`` (``pip install``). The structure mirrors are checked against the
library when it is loaded (:func:`library`), so a layout change in C fails loudly instead of
misreading memory.
"""

from __future__ import annotations

import ctypes as ct
import functools
import os
from pathlib import Path
from typing import Any

from ...core._package import PACKAGE_DIR
from ...errors import RrrError

LIB_NAME = "librrr_hil_supervisor.so"

# rrr_hil_rx
RX_OK, RX_UNKNOWN_ID, RX_BAD_DLC, RX_BAD_CRC, RX_OUT_OF_RANGE, RX_COUNT = range(6)
RX_NAMES = ("ok", "unknown_id", "bad_dlc", "bad_crc", "out_of_range")
# rrr_hil_kind
KIND_SYNC, KIND_VOLTAGE_CMD, KIND_JOINT_STATE, KIND_PLANT_STATUS, KIND_HEARTBEAT, KIND_STOP_CMD = (
    range(6))
FAULT_SYNC, FAULT_BUS = 32, 64


class SupConfig(ct.Structure):
    """Mirror of ``rrr_hil_sup_config``."""

    _fields_ = [("max_missed", ct.c_uint), ("max_delta_counter", ct.c_uint)]


#: The event counters of ``rrr_hil_sup_err``, in order.
SUP_ERR_NAMES = ("crc", "counter", "range", "format", "sync", "bus", "timeout", "cmd_missed",
                 "fault_events", "resets", "zero_periods", "stop_rejected")


class SupErr(ct.Structure):
    """Mirror of ``rrr_hil_sup_err`` (event counters, only grow)."""

    _fields_ = [(n, ct.c_uint32) for n in SUP_ERR_NAMES]


class VoltageCmd(ct.Structure):
    """Mirror of ``rrr_hil_voltage_cmd``."""

    _fields_ = [("counter", ct.c_uint8), ("enable", ct.c_uint8), ("reset_fault", ct.c_uint8),
                ("u_V", ct.c_double * 3)]


class StopCmd(ct.Structure):
    """Mirror of ``rrr_hil_stop_cmd``."""

    _fields_ = [("counter", ct.c_uint8), ("reason", ct.c_uint8)]


class Sup(ct.Structure):
    """Mirror of ``rrr_hil_sup``."""

    _fields_ = [("cfg", SupConfig), ("faults", ct.c_uint8), ("have_counter", ct.c_uint8),
                ("last_counter", ct.c_uint8), ("pending", ct.c_uint8),
                ("reset_step", ct.c_uint8), ("reset_enables", ct.c_uint8), ("stop", ct.c_uint8),
                ("stop_reason", ct.c_uint8), ("cmd", VoltageCmd),
                ("u_hold_V", ct.c_double * 3), ("missed_in_row", ct.c_uint),
                ("zero_applied", ct.c_uint8), ("err", SupErr)]


class PlantStatus(ct.Structure):
    """Mirror of ``rrr_hil_plant_status``."""

    _fields_ = [("counter", ct.c_uint8), ("state", ct.c_uint8), ("faults", ct.c_uint8),
                ("zero_voltage", ct.c_uint8), ("fault_count", ct.c_uint16),
                ("cmd_missed", ct.c_uint16)]


class Frame(ct.Structure):
    """Mirror of ``rrr_hil_frame``."""

    _fields_ = [("id", ct.c_uint32), ("extended", ct.c_uint8), ("dlc", ct.c_uint8),
                ("data", ct.c_uint8 * 8)]


class _JointState(ct.Structure):
    _fields_ = [("joint", ct.c_uint8), ("counter", ct.c_uint8), ("q_rad", ct.c_double),
                ("qd_rad_s", ct.c_double)]


class _MsgUnion(ct.Union):
    _fields_ = [("sync", ct.c_uint32), ("cmd", VoltageCmd), ("joint", _JointState),
                ("status", PlantStatus), ("heartbeat", ct.c_uint8 * 3), ("stop", StopCmd)]


class Msg(ct.Structure):
    """Mirror of ``rrr_hil_msg`` (only ``cmd`` of the union is read here)."""

    _fields_ = [("kind", ct.c_int), ("u", _MsgUnion)]


_SIGNATURES: dict[str, tuple[list[Any], Any]] = {
    "rrr_hil_sup_config_default": ([], SupConfig),
    "rrr_hil_sup_init": ([ct.POINTER(Sup), ct.POINTER(SupConfig)], ct.c_int),
    "rrr_hil_sup_on_command": ([ct.POINTER(Sup), ct.c_int, ct.POINTER(VoltageCmd)], None),
    "rrr_hil_sup_on_stop": ([ct.POINTER(Sup), ct.c_int, ct.POINTER(StopCmd)], ct.c_int),
    "rrr_hil_sup_raise": ([ct.POINTER(Sup), ct.c_uint8], None),
    "rrr_hil_sup_next_period": ([ct.POINTER(Sup), ct.c_double * 3], ct.c_int),
    "rrr_hil_sup_status": ([ct.POINTER(Sup), ct.POINTER(PlantStatus)], None),
    "rrr_hil_decode": ([ct.POINTER(Frame), ct.POINTER(Msg)], ct.c_int),
}


def library_path() -> Path:
    """$RRR_HIL_LIBRARY, else $RRR_HIL_BIN_DIR/librrr_hil_supervisor.so, else the package copy."""
    env = os.environ.get("RRR_HIL_LIBRARY")
    if env:
        return Path(env)
    bin_dir = os.environ.get("RRR_HIL_BIN_DIR")
    if bin_dir and (Path(bin_dir) / LIB_NAME).exists():
        return Path(bin_dir) / LIB_NAME
    return PACKAGE_DIR / LIB_NAME


@functools.cache
def library() -> ct.CDLL:
    """The loaded supervisor library, signatures declared and structure layout checked."""
    path = library_path()
    if not path.exists():
        raise RrrError(f"{path} not found: install with 'pip install .' or point "
                       "RRR_HIL_LIBRARY at a CMake build's c_src/hil/" + LIB_NAME)
    lib = ct.CDLL(str(path))
    for name, (argtypes, restype) in _SIGNATURES.items():
        fn = getattr(lib, name)
        fn.argtypes, fn.restype = argtypes, restype
    _check_layout(lib)
    return lib


def _check_layout(lib: ct.CDLL) -> None:
    """Drive the C functions through fields at the start, middle and end of ``rrr_hil_sup`` and
    check that the mirror reads back what C wrote."""
    cfg = SupConfig(7, 5)
    s = Sup()
    ct.memset(ct.byref(s), 0xA5, ct.sizeof(s))
    u = (ct.c_double * 3)()
    ok = lib.rrr_hil_sup_init(ct.byref(s), ct.byref(cfg)) == 0
    lib.rrr_hil_sup_raise(ct.byref(s), FAULT_BUS)
    zero = lib.rrr_hil_sup_next_period(ct.byref(s), u)
    st = PlantStatus()
    lib.rrr_hil_sup_status(ct.byref(s), ct.byref(st))
    ok = ok and (s.cfg.max_missed, s.cfg.max_delta_counter, s.faults) == (7, 5, FAULT_BUS)
    ok = ok and (s.err.bus, s.err.fault_events, s.err.cmd_missed, s.err.zero_periods) == (1,) * 4
    ok = ok and zero == 1 and s.zero_applied == 1 and s.missed_in_row == 1
    ok = ok and (st.faults, st.zero_voltage, st.fault_count, st.cmd_missed) == (FAULT_BUS, 1, 1, 1)
    # the fields of the reset sequence and the stop (padding and the end of err in C)
    cmd = VoltageCmd(3, 0, 1)  # a reset request: arms the reset of the latched bus fault
    lib.rrr_hil_sup_on_command(ct.byref(s), RX_OK, ct.byref(cmd))
    ok = ok and (s.reset_step, s.reset_enables, s.last_counter) == (1, 0, 3)
    ok = ok and lib.rrr_hil_sup_on_stop(ct.byref(s), RX_BAD_CRC, None) == 0
    stop = StopCmd(4, 2)
    ok = ok and lib.rrr_hil_sup_on_stop(ct.byref(s), RX_OK, ct.byref(stop)) == 1
    ok = ok and (s.stop, s.stop_reason, s.err.stop_rejected) == (1, 2, 1)
    if not ok:
        raise RrrError(f"{library_path()}: rrr_hil_sup does not match the ctypes mirror in "
                       f"{__file__} (rebuild, or update the mirror after a change in C)")


def frame_of(message: Any) -> Frame:
    """A ``rrr_hil_frame`` from a ``can.Message``."""
    data = bytes(message.data)[:8]
    f = Frame(id=message.arbitration_id, extended=int(bool(message.is_extended_id)),
              dlc=min(int(message.dlc), 15))
    ct.memmove(f.data, data, len(data))
    return f


class Supervisor:
    """One ``rrr_hil_sup`` (C) with the calls the DBC plant loop (dbc/hil_dbc_plant.c) makes."""

    def __init__(self, max_missed: int = 3, max_delta_counter: int = 3) -> None:
        self._lib = library()
        self._s = Sup()
        self._u = (ct.c_double * 3)()
        self._msg = Msg()
        cfg = SupConfig(max_missed, max_delta_counter)
        if self._lib.rrr_hil_sup_init(ct.byref(self._s), ct.byref(cfg)) != 0:
            raise ValueError(f"supervisor settings rejected: max_missed {max_missed} (>= 1), "
                             f"max_delta_counter {max_delta_counter} (1..15)")

    def on_command_frame(self, message: Any) -> int:
        """Decode a frame with the VoltageCmd id in C (CRC, DLC, DBC range) and feed the result
        to the supervisor, as hil_dbc_plant.c does; returns the ``RX_*`` result."""
        rx = int(self._lib.rrr_hil_decode(ct.byref(frame_of(message)), ct.byref(self._msg)))
        cmd = ct.byref(self._msg.u.cmd) if rx == RX_OK else None
        self._lib.rrr_hil_sup_on_command(ct.byref(self._s), rx, cmd)
        return rx

    def on_stop_frame(self, message: Any) -> tuple[int, bool]:
        """Decode a frame with the StopCmd id in C and feed it to the supervisor, as
        hil_dbc_plant.c does; returns the ``RX_*`` result and whether the stop is honoured
        (E2E-valid, counter 1..max_delta_counter above the last command's)."""
        rx = int(self._lib.rrr_hil_decode(ct.byref(frame_of(message)), ct.byref(self._msg)))
        stop = ct.byref(self._msg.u.stop) if rx == RX_OK else None
        return rx, bool(self._lib.rrr_hil_sup_on_stop(ct.byref(self._s), rx, stop))

    @property
    def stop_reason(self) -> int | None:
        """StopCmd.Reason of the honoured stop, None before one."""
        return int(self._s.stop_reason) if self._s.stop else None

    def raise_fault(self, fault: int) -> None:
        """Latch an external fault (``FAULT_SYNC``, ``FAULT_BUS``)."""
        self._lib.rrr_hil_sup_raise(ct.byref(self._s), fault)

    def next_period(self) -> tuple[tuple[float, float, float], bool]:
        """Close the period: the voltage for the next one and whether 0 V is forced."""
        zero = self._lib.rrr_hil_sup_next_period(ct.byref(self._s), self._u)
        return (self._u[0], self._u[1], self._u[2]), bool(zero)

    def status(self) -> dict[str, int]:
        """PlantStatus signals (without AliveCounter) from ``rrr_hil_sup_status``."""
        st = PlantStatus()
        self._lib.rrr_hil_sup_status(ct.byref(self._s), ct.byref(st))
        return {"State": st.state, "Faults": st.faults, "ZeroVoltage": st.zero_voltage,
                "FaultCount": st.fault_count, "CmdMissed": st.cmd_missed}

    @property
    def faults(self) -> int:
        """Latched fault bits."""
        return int(self._s.faults)

    @property
    def zero_applied(self) -> bool:
        """0 V was forced over the last period."""
        return bool(self._s.zero_applied)

    def counters(self) -> dict[str, int]:
        """The event counters (``rrr_hil_sup_err``)."""
        return {name: int(getattr(self._s.err, name)) for name in SUP_ERR_NAMES}
