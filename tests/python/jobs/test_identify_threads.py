"""Identification pins the BLAS libraries to one thread in its least-squares phases
(rrr_robot.identify._threads) and restores them afterwards."""

from __future__ import annotations

import numpy as np
import pytest
from rrr_robot.identify import _threads, base_params, excitation, friction, pipeline
from threadpoolctl import threadpool_info, threadpool_limits


def blas_threads_now() -> list[int]:
    return [int(i["num_threads"]) for i in threadpool_info() if i["user_api"] == "blas"]


@pytest.fixture
def two_blas_threads():
    """At least two BLAS threads outside (as on a multi-core machine), whatever this one has."""
    if not blas_threads_now():
        pytest.skip("no BLAS library that threadpoolctl can control")
    with threadpool_limits(limits=2, user_api="blas"):
        yield blas_threads_now()


def test_one_thread_inside_restored_after(two_blas_threads):
    seen: list[list[int]] = []

    @_threads.one_blas_thread
    def inner() -> None:
        seen.append(blas_threads_now())

    @_threads.one_blas_thread
    def outer() -> None:
        inner()  # nested: still one thread
        seen.append(blas_threads_now())

    outer()
    assert seen == [[1] * len(two_blas_threads)] * 2
    assert blas_threads_now() == two_blas_threads


def test_restored_after_an_exception(two_blas_threads):
    @_threads.one_blas_thread
    def fails() -> None:
        raise ZeroDivisionError

    with pytest.raises(ZeroDivisionError):
        fails()
    assert blas_threads_now() == two_blas_threads
    assert _threads._inside.depth == 0


def test_none_leaves_the_libraries_alone(two_blas_threads, monkeypatch):
    monkeypatch.setattr(_threads, "BLAS_THREADS", None)
    with _threads.blas_threads():
        assert blas_threads_now() == two_blas_threads


def test_the_least_squares_phases_are_pinned(two_blas_threads, monkeypatch):
    """scipy's lstsq, called inside the identification's phases, runs with one thread."""
    seen: list[list[int]] = []
    real = base_params.sla.lstsq

    def spy(*args, **kwargs):
        seen.append(blas_threads_now())
        return real(*args, **kwargs)

    monkeypatch.setattr(base_params.sla, "lstsq", spy)  # the scipy.linalg module: every caller
    from rrr_robot.identify.friction import CurvePoints, fit_ls, fit_nls

    v = np.geomspace(0.002, 4.0, 14)
    points = CurvePoints(v, 0.3 * np.tanh(50 * v) + 0.1 * np.tanh(2 * v) + 0.05 * v)
    fit_ls(points, np.array([50.0, 2.0, 0.5]))
    fit_nls(points, w_starts=np.array([[60.0, 3.0, 0.4]]))
    assert seen and all(s == [1] * len(two_blas_threads) for s in seen)
    assert blas_threads_now() == two_blas_threads


def test_public_phases_are_wrapped():
    for fn in (base_params.estimate_base_params, friction.curve_points, friction.fit_ls,
               friction.fit_nls, friction.fit_ekf, excitation.design_excitation,
               pipeline.identify_friction, pipeline.identify):
        assert hasattr(fn, "__wrapped__"), fn.__name__
