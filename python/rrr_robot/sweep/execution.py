"""The runs of a sweep on Dask (``distributed``): a local cluster of worker processes, or any
running Dask cluster by its scheduler's address.

- :func:`dask_client`: without an address, a ``distributed.LocalCluster`` of ``workers``
  processes (default: one per core) with one thread each, started and stopped with the sweep;
  with one (``tcp://host:port``), a client of that cluster, whose workers must have rrr_robot
  installed (the same version as the client: it is checked before anything runs). The address
  is probed first (:func:`probe_scheduler`): a peer that does not send a Dask handshake within
  HANDSHAKE_TIMEOUT s (one that accepts and never speaks, an HTTP server) is a one-line error.
- :func:`execute`: the runs go out in batches (one Dask task runs a batch, so the scheduling
  cost is paid per batch, not per run); the shared part of every run (:class:`SweepPlan`) is
  sent to each worker once. Each finished batch is handed to ``on_rows`` on the client as it
  arrives. A batch whose task is lost (its worker died more often than Dask retries, or the
  cluster went away) is reported, not recorded: ``--resume`` runs it again.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.metadata
import logging
import math
import os
import secrets
import socket
import struct
import time
from collections.abc import Callable, Iterator, Sequence
from typing import Any

from .. import __version__
from ..errors import BadInputError, RrrError, one_line
from .runs import SweepPlan, run_batch
from .sampling import RunInput

log = logging.getLogger(__name__)

__all__ = ["batch_size", "batches", "dask_client", "execute", "probe_scheduler",
           "worker_threads"]

#: Seconds to connect to a scheduler, and to wait for its first worker.
CONNECT_TIMEOUT = 20.0
WORKER_TIMEOUT = 60.0
#: Seconds for a scheduler's first message (the handshake a Dask scheduler sends as it accepts
#: a connection), and its largest size in bytes.
HANDSHAKE_TIMEOUT = 10.0
MAX_HANDSHAKE_BYTES = 65536
#: Most runs in one batch, per engine (a batch of the most takes about a second or two here:
#: the native loop of the writing task ~15 ms, the FMUs through FMPy ~150 ms).
MAX_BATCH = {"native": 100, "fmpy": 10}
#: Batches per worker thread at least, so that the last batches spread over the workers.
BATCHES_PER_THREAD = 4


@contextlib.contextmanager
def _quiet_distributed() -> Iterator[None]:
    """distributed logs every start, connection and shutdown at INFO; keep them at WARNING
    unless the user asked for debug messages."""
    loggers = [logging.getLogger(n) for n in ("distributed", "dask")]
    levels = [lg.level for lg in loggers]
    if not logging.getLogger().isEnabledFor(logging.DEBUG):
        for lg in loggers:
            lg.setLevel(logging.WARNING)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)


def _check_workers(client: Any, where: str) -> None:
    try:
        client.wait_for_workers(1, timeout=WORKER_TIMEOUT)
    except TimeoutError:
        raise RrrError(f"no Dask worker joined {where} within {WORKER_TIMEOUT:.0f} s (start "
                       "one: dask worker <scheduler address>)") from None
    versions = client.run(importlib.metadata.version, "rrr_robot", on_error="return")
    for worker, version in sorted(versions.items()):
        if isinstance(version, BaseException):
            raise RrrError(f"the Dask worker {worker} cannot run rrr_robot "
                           f"({type(version).__name__}: {version}): install the package on "
                           "every worker machine (pip install 'rrr_robot[sweep]')")
        if version != __version__:
            raise RrrError(f"the Dask worker {worker} has rrr_robot {version}, this client "
                           f"{__version__}: install the same version on every machine")
    client.run(_import_runs)


def _worker_environ() -> dict[str, Any]:
    """The environment Dask gives the local cluster's worker processes, without
    MALLOC_TRIM_THRESHOLD_: Dask sets it (to 64 KiB, against fragmentation), which turns off
    glibc's adaptive mmap threshold, so that every run's half-megabyte arrays are mapped and
    unmapped again; the runs took 10 % more CPU time with it (bench/bench_sweep.py). A run
    allocates the same sizes each time, which the adaptive threshold serves from the heap."""
    import dask

    environ = dict(dask.config.get("distributed.nanny.pre-spawn-environ", default={}) or {})
    environ.pop("MALLOC_TRIM_THRESHOLD_", None)
    return environ


def _import_runs() -> None:
    """Run on each worker before the first batch: import what a run needs (numpy, scipy, the
    binding, the writing job), so that the first batch's runs do not pay for it."""
    importlib.import_module("rrr_robot.sweep.runs")


def _host_port(address: str) -> tuple[str, int]:
    rest = address.split("://", 1)[-1]
    host, _, port = rest.rpartition(":")
    return host.strip("[]"), int(port)


def _recv_exactly(sock: socket.socket, n: int, deadline: float) -> bytes:
    data = b""
    while len(data) < n:
        sock.settimeout(max(0.01, deadline - time.monotonic()))
        block = sock.recv(n - len(data))
        if not block:
            raise ConnectionError("the peer closed the connection")
        data += block
    return data


def probe_scheduler(address: str, timeout: float | None = None) -> None:
    """Check that a Dask scheduler answers at ``address`` before distributed is handed it:
    within ``timeout`` s (default HANDSHAKE_TIMEOUT) the connection is accepted and the
    scheduler's handshake arrives (distributed's TCP framing: an 8-byte length of at most
    MAX_HANDSHAKE_BYTES, then the frames of a message naming its compression and Python).
    BadInputError otherwise (a peer that never speaks, an HTTP server, a closed port). For
    tls://, ws:// and wss:// only the connection is checked (their handshake is encrypted or
    an HTTP upgrade)."""
    timeout = HANDSHAKE_TIMEOUT if timeout is None else timeout
    where = f"the Dask scheduler at {address}"
    deadline = time.monotonic() + timeout
    try:
        host, port = _host_port(address)
        sock = socket.create_connection((host, port), timeout=timeout)
    except TimeoutError:
        raise BadInputError(f"cannot connect to {where}: no answer within {timeout:g} s"
                            ) from None
    except (OSError, ValueError) as exc:
        raise BadInputError(f"cannot connect to {where}: "
                            f"{one_line(exc)}") from None
    try:
        with sock:
            if "://" in address and not address.startswith("tcp://"):
                return
            (n,) = struct.unpack("<Q", _recv_exactly(sock, 8, deadline))
            if not 16 <= n <= MAX_HANDSHAKE_BYTES:
                raise BadInputError(f"{where} does not speak Dask: its first message claims "
                                    f"{n} bytes (a Dask handshake has at most "
                                    f"{MAX_HANDSHAKE_BYTES})")
            body = _recv_exactly(sock, n, deadline)
    except TimeoutError:
        raise BadInputError(f"{where} does not speak Dask: no handshake within {timeout:g} s "
                            "(is it a Dask scheduler, e.g. not its dashboard's HTTP port?)"
                            ) from None
    except OSError as exc:
        raise BadInputError(f"{where} does not speak Dask: "
                            f"{one_line(exc)} before its "
                            "handshake") from None
    if b"compression" not in body or b"python" not in body:
        raise BadInputError(f"{where} does not speak Dask: its first message is no Dask "
                            "handshake")


@contextlib.contextmanager
def dask_client(workers: int | None = None, scheduler: str | None = None) -> Iterator[Any]:
    """A Dask client: of a new local cluster of ``workers`` processes (default: one per core),
    or of the running cluster whose scheduler is at ``scheduler``. Closed (the local cluster
    stopped) when the block ends."""
    import dask
    from distributed import Client, LocalCluster

    with _quiet_distributed(), contextlib.ExitStack() as stack:
        if scheduler is None:
            n = workers or os.cpu_count() or 1
            with dask.config.set({"distributed.nanny.pre-spawn-environ": _worker_environ()}):
                cluster = stack.enter_context(LocalCluster(  # its web server on a free port
                    n_workers=n, threads_per_worker=1, processes=True, dashboard_address=":0",
                    silence_logs=logging.ERROR))
            client = stack.enter_context(Client(cluster))
            where = f"the local cluster of {n} worker processes"
        else:
            probe_scheduler(scheduler)  # a peer that never speaks or speaks HTTP: refused
            try:
                client = stack.enter_context(Client(scheduler, timeout=CONNECT_TIMEOUT))
            except (OSError, TimeoutError, ValueError) as exc:
                raise BadInputError(f"cannot connect to the Dask scheduler at {scheduler}: "
                                    f"{one_line(exc)}"
                                    ) from None
            where = f"the Dask scheduler at {scheduler}"
        _check_workers(client, where)
        log.info("running on %s: %d workers, %d threads (dashboard: %s)", where,
                 len(client.scheduler_info()["workers"]), worker_threads(client),
                 client.dashboard_link)
        yield client


def worker_threads(client: Any) -> int:
    """The threads of the cluster's workers (the runs that can run at once)."""
    info = client.scheduler_info()["workers"]
    return max(1, sum(int(w.get("nthreads", 1)) for w in info.values()))


def batch_size(runs: int, threads: int, engine: str) -> int:
    """Runs per batch: at least BATCHES_PER_THREAD batches per worker thread, at most
    MAX_BATCH[engine] runs per batch."""
    return max(1, min(MAX_BATCH.get(engine, 10), math.ceil(runs / (BATCHES_PER_THREAD * threads))))


def batches(inputs: Sequence[RunInput], size: int) -> list[list[RunInput]]:
    """``inputs`` cut into consecutive batches of ``size``."""
    return [list(inputs[i:i + size]) for i in range(0, len(inputs), size)]


def execute(client: Any, plan: SweepPlan, work: Sequence[Sequence[RunInput]],
            on_rows: Callable[[list[dict[str, Any]]], None]) -> list[tuple[list[int], str]]:
    """Run the batches ``work`` on the cluster; ``on_rows(rows)`` receives each finished
    batch's rows on the client, in the order they finish. Returns the batches that were lost
    (their runs and why)."""
    from distributed import as_completed

    with _quiet_distributed():
        token = secrets.token_hex(4)
        [plan_future] = client.scatter([plan], broadcast=True, hash=False)
        pending = {client.submit(run_batch, plan_future, list(batch), pure=False,
                                 key=f"rrr-sweep-{token}-{batch[0].run}"): batch
                   for batch in work}
        lost: list[tuple[list[int], str]] = []
        try:
            for future in as_completed(pending):
                batch = pending.pop(future)
                try:
                    rows = future.result()
                except Exception as exc:  # the task is lost, not a run's failure
                    reason = f"{type(exc).__name__}: {one_line(exc)}"
                    log.error("batch of runs %d-%d lost: %s", batch[0].run, batch[-1].run,
                              reason)
                    lost.append(([inp.run for inp in batch], reason))
                    continue
                finally:
                    future.release()
                on_rows(rows)
        finally:
            for future in pending:
                future.cancel()
            plan_future.release()
    return lost
