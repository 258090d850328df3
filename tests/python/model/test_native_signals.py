"""The native closed loop honours signals and bounds its cost (issue 21, N2 and N3): librrr's loop
runs in parts of about 50 ms (``rrr_sim_closed_loop_part``), so SIGTERM and Ctrl-C end
``rrr writing --engine native`` in its loop, between two parts, with their exit status and
nothing in --out (how long that took is printed: the tests assert no speed);
a plant too stiff for its integrator (``rrr_plant_stiffness``) is refused at once, naming the
friction parameters, instead of running for hours."""

from __future__ import annotations

import fcntl
import itertools
import os
import pty
import re
import signal
import struct
import subprocess
import sys
import termios
import threading
import time
from pathlib import Path

import numpy as np
import pytest
import rrr_robot as rr
from rrr_robot.cli.app import main
from rrr_robot.core import _lib
from rrr_robot.core.robot import read_robot_file
from rrr_robot.core.stiffness import STIFFNESS_MAX, Stiffness, stiffness
from rrr_robot.errors import RobotFileError
from rrr_robot.sim.cosim import CosimOptions
from support import default_signals

DEFAULT_ROBOT = Path(rr.__file__).parent / "data" / "default_robot.toml"
J = (1, 2, 3)
#: The default text nine times (41.5 s of writing): about 2.8 s of the costly loop on a quiet
#: machine (15x real time measured), in parts of about 50 ms, each reported as progress.
LONG_TEXT = "\\n".join(["a\u03c9m\u03b3 a\u03c9m\u03b3 a\u03c9m\u03b3"] * 3)


def _robot(tmp_path: Path, f11: float, w11: float, joints: tuple[int, ...] = (1, 2, 3)) -> Path:
    """The default robot with f[i,1] and w[i,1] of the given joints replaced."""
    text = DEFAULT_ROBOT.read_text()
    f_rows = [f"[{f11!r}, 0.04, -0.02]" if i in joints else "[0.08, 0.04, -0.02]" for i in J]
    w_rows = [f"[{w11!r}, 10.0, 1.0]" if i in joints else "[100.0, 10.0, 1.0]" for i in J]
    text, nf = re.subn(r"(?m)^f = \[.*$", f"f = [{', '.join(f_rows)}]", text)
    text, nw = re.subn(r"(?m)^w = \[.*$", f"w = [{', '.join(w_rows)}]", text)
    assert nf == 1 and nw == 1
    path = tmp_path / "robot.toml"
    path.write_text(text)
    return path


def test_the_reporters_friction_is_refused_at_once_naming_it(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str],
                                                             monkeypatch: pytest.MonkeyPatch
                                                             ) -> None:
    """f[1][1] = w[1][1] = 1e4 (within the robot file's bounds) ran for over 12 minutes: now one
    line, exit 2, and the closed loop never starts."""
    import rrr_robot.sim.native as native

    loops: list[int] = []
    monkeypatch.setattr(native, "_run_in_parts", lambda n, *args: loops.append(n))
    robot = _robot(tmp_path, 1e4, 1e4, joints=(1,))
    rc = main(["writing", "--engine", "native", "--robot", str(robot), "--scenario", "ctc",
               "--no-figures", "--out", str(tmp_path / "out"), "-q"])
    err = capsys.readouterr().err.strip().splitlines()
    assert rc == 2 and len(err) == 1, err
    assert "f[1,1] = 10000" in err[0] and "w[1,1] = 10000" in err[0] and "too stiff" in err[0]
    assert "[friction]" in err[0] and str(robot) in err[0]
    assert loops == []  # a refusal, not a simulation
    assert not (tmp_path / "out").exists()


def test_stiffness_names_the_parameter_and_bounds() -> None:
    raw = read_robot_file(DEFAULT_ROBOT).data.raw_model()
    assert 100.0 < stiffness(raw) < STIFFNESS_MAX / 100
    raw.f[1][2] = 1e3
    raw.w[1][2] = 1e3
    with pytest.raises(Stiffness, match=r"f\[2,3\] = 1000 and w\[2,3\] = 1000 make") as info:
        stiffness(raw)
    assert info.value.field == "w[2,3]" and info.value.value > STIFFNESS_MAX
    assert info.value.status == "RRR_TOO_STIFF"
    raw = read_robot_file(DEFAULT_ROBOT).data.raw_model()
    raw.b[0] = 1e6
    with pytest.raises(Stiffness, match=r"b\[1\] = 1e\+06 makes the plant too stiff"):
        stiffness(raw)
    assert _lib.STATUS_NAMES[7] == "RRR_TOO_STIFF"


def test_a_robot_file_too_stiff_is_a_robot_file_error(tmp_path: Path) -> None:
    with pytest.raises(RobotFileError, match=r"\[friction\] f\[1,1\] = 5000 and w\[1,1\] = 2000"):
        read_robot_file(_robot(tmp_path, 5000.0, 2000.0, joints=(1,)))


def test_the_native_engine_refuses_a_stiff_plant_of_its_values() -> None:
    """rr.simulate with plant values that make it too stiff (no robot file in between)."""
    t = np.arange(0.0, 0.01, 1e-3)
    z = np.zeros((t.shape[0], 3))
    opts = CosimOptions(plant_values={"f[3,1]": 1e4, "w[3,1]": 1e4})
    with pytest.raises(Stiffness, match=r"f\[3,1\] = 10000 and w\[3,1\] = 10000"):
        rr.simulate(t, z, z, z, z, opts)


def test_parts_give_the_same_result_and_report_progress() -> None:
    """The loop in parts is the one call's loop bit for bit (the C test checks every part size);
    progress comes between the parts, the last call at sample n - 1."""
    t = np.arange(0.0, 3.0, 1e-3)
    q = np.stack([0.1 * np.sin(t), 0.3 + 0.1 * np.cos(t), 0.5 + 0.0 * t], axis=1)
    qd = np.stack([0.1 * np.cos(t), -0.1 * np.sin(t), 0.0 * t], axis=1)
    qdd = np.stack([-0.1 * np.sin(t), -0.1 * np.cos(t), 0.0 * t], axis=1)
    seen: list[tuple[int, int]] = []
    a = rr.simulate(t, q, qd, qdd, q, CosimOptions(progress=lambda k, n: seen.append((k, n))))
    import rrr_robot.sim.native as native
    previous = native.PART_SECONDS
    try:
        native.PART_SECONDS = 1e-6  # as small as it gets: parts of a sample or a few
        b = rr.simulate(t, q, qd, qdd, q, CosimOptions())
    finally:
        native.PART_SECONDS = previous
    assert np.array_equal(a.q, b.q) and np.array_equal(a.u, b.u) and np.array_equal(a.qdd, b.qdd)
    assert seen[-1] == (t.shape[0] - 1, t.shape[0])
    assert all(k1 > k0 for (k0, _), (k1, _) in itertools.pairwise(seen))


class _Terminal:
    """The stderr of a process on a terminal (a pty, so that the command shows its progress
    bar), read by a thread: each line or bar update (ended by ``\\n`` or ``\\r``) with the time it
    arrived."""

    def __init__(self) -> None:
        self.master, self.slave = pty.openpty()
        # a size: tqdm draws nothing on a terminal of no columns
        fcntl.ioctl(self.slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 120, 0, 0))
        self.lines: list[tuple[float, str]] = []
        self._thread = threading.Thread(target=self._read, daemon=True)

    def start(self) -> None:
        os.close(self.slave)  # the child has its copy
        self._thread.start()

    def _read(self) -> None:
        buf = b""
        while True:
            try:
                chunk = os.read(self.master, 4096)
            except OSError:  # EIO: the child closed the terminal
                chunk = b""
            if not chunk:
                break
            buf += chunk
            *done, buf = re.split(rb"[\r\n]", buf)
            now = time.monotonic()
            self.lines += [(now, d.decode(errors="replace").strip()) for d in done if d.strip()]
        if buf.strip():
            self.lines.append((time.monotonic(), buf.decode(errors="replace").strip()))

    def wait_for(self, pattern: str, timeout: float) -> tuple[float, re.Match[str]]:
        """The first line that matches (its time and match); a timeout that only ends a hang
        (the lines come well before it on any machine)."""
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            for stamp, line in list(self.lines):
                m = re.search(pattern, line)
                if m:
                    return stamp, m
            if not self._thread.is_alive():
                break
            time.sleep(0.01)
        raise AssertionError(f"no line {pattern!r} in {[line for _, line in self.lines]}")

    def close(self) -> None:
        self._thread.join(timeout=60)
        os.close(self.master)


#: A bar of the writing task's native loop (tqdm's "ctc:  3%|...| 1113/41503 [..."): the samples
#: done and in all; STARTED: a bar past the loop's first part.
BAR = r"ctc:.*\|\s*(\d+)/(\d+)\s*\["
STARTED = r"ctc:.*\|\s*([1-9]\d*)/(\d+)\s*\["


@pytest.mark.parametrize(("sig", "status", "line"), [(signal.SIGTERM, 143, "rrr: terminated"),
                                                     (signal.SIGINT, 130, "rrr: interrupted")])
def test_a_signal_ends_a_long_native_run_in_its_loop(tmp_path: Path, sig: signal.Signals,
                                                     status: int, line: str) -> None:
    """A plant near the stiffness limit makes each simulated second cost about a second of C:
    the loop is one long C call no more. The signal is sent once the loop has reported progress
    (its bar: it is running, with most of its work still ahead), and the command stops in the
    loop: its stop line, its exit status, nothing in --out, the bar never at its end. How long
    the stop took is printed, not asserted (a loaded machine takes longer)."""
    robot = _robot(tmp_path, 40.0, 100.0)  # about 7e5 1/s: accepted, costly
    assert 1e5 < stiffness(read_robot_file(robot).data.raw_model()) < STIFFNESS_MAX
    out = tmp_path / "out"
    term = _Terminal()
    proc = subprocess.Popen([sys.executable, "-m", "rrr_robot", "writing", "--engine", "native",
                             "--robot", str(robot), "--scenario", "ctc", "--no-figures",
                             "--text", LONG_TEXT, "--out", str(out)],
                            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=term.slave,
                            env={**os.environ, "PYTHONUNBUFFERED": "1"},
                            preexec_fn=default_signals)
    term.start()
    try:
        _, first = term.wait_for(STARTED, 600)
        assert 0 < int(first[1]) < int(first[2]) and proc.poll() is None, term.lines
        sent = time.monotonic()
        proc.send_signal(sig)
        stopped, _ = term.wait_for(re.escape(line), 600)
        assert proc.wait(timeout=600) == status
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        term.close()
    print(f"{sig.name}: {stopped - sent:.3f} s from the signal to {line!r}")
    bars = [re.search(BAR, text) for _, text in term.lines]
    done = [(int(m[1]), int(m[2])) for m in bars if m]
    assert max(k for k, _ in done) < done[0][1], done[-3:]  # stopped before the loop's end
    assert term.lines[-1][1] == line
    assert not out.exists() or list(out.iterdir()) == []
