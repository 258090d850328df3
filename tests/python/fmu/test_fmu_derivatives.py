"""Directional and adjoint derivatives of the plant and controller FMUs, through FMPy, against
central finite differences of the FMUs' own outputs (Model Exchange and Co-Simulation, FMI 2.0
and 3.0), and the ModelStructure's dependencies and kinds against the numbers.

Acceptance of issue 25: on random states and seeds, fmiXGetDirectionalDerivative equals the
central differences (a step per variable, h = 1e-6 max(1, |x|)) to 1e-6 relative; the FMI 3
adjoint equals the transpose of the forward derivatives.
"""

from __future__ import annotations

import ctypes as ct
import shutil
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest
import rrr_robot as rr
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Model, FMU2Slave
from fmpy.fmi3 import FMU3Model, FMU3Slave
from fmpy.model_description import ModelDescription

N_SAMPLES = 1000
H_REL = 1e-6
TOL = 1e-6
RNG_SEED = 25


@dataclass
class Fmu:
    """One instance of an FMU through FMPy, with the variables by name."""

    which: str
    version: int
    interface: str  # "ME" or "CS"
    md: ModelDescription
    fmu: Any
    vr: dict[str, int]

    def set(self, names: list[str], values: np.ndarray) -> None:
        refs = [self.vr[n] for n in names]
        vals = [float(v) for v in values]
        if self.version == 2:
            self.fmu.setReal(refs, vals)
        else:
            self.fmu.setFloat64(refs, vals)

    def get(self, names: list[str]) -> np.ndarray:
        refs = [self.vr[n] for n in names]
        return np.array(self.fmu.getReal(refs) if self.version == 2
                        else self.fmu.getFloat64(refs))

    def set_states(self, x: np.ndarray) -> None:
        self.fmu.setContinuousStates((ct.c_double * len(x))(*map(float, x)), len(x))

    def dd(self, unknowns: list[str], knowns: list[str], seed: np.ndarray) -> np.ndarray:
        u = [self.vr[n] for n in unknowns]
        k = [self.vr[n] for n in knowns]
        return np.array(self.fmu.getDirectionalDerivative(u, k, list(map(float, seed))))

    def adjoint(self, unknowns: list[str], knowns: list[str], seed: np.ndarray) -> np.ndarray:
        u = [self.vr[n] for n in unknowns]
        k = [self.vr[n] for n in knowns]
        # seed: one per unknown, sensitivity: one per known (FMI 3.0; FMPy's default
        # nSensitivity is the number of unknowns, so it is given)
        return np.array(self.fmu.getAdjointDerivative(u, k, list(map(float, seed)),
                                                      nSensitivity=len(k)))


_DIRS: dict[tuple[str, int], str] = {}


def _unzipped(which: str, version: int) -> str:
    key = (which, version)
    if key not in _DIRS:
        _DIRS[key] = extract(str(rr.fmu_path(which, version)), tempfile.mkdtemp())
    return _DIRS[key]


@pytest.fixture(scope="module", autouse=True)
def _cleanup() -> Iterator[None]:
    yield
    for folder in _DIRS.values():
        shutil.rmtree(folder, ignore_errors=True)


def open_fmu(which: str, version: int, interface: str,
             start: dict[str, float] | None = None, initialize: bool = True) -> Fmu:
    """Instantiated, the start values set (before initialization), and initialized."""
    folder = _unzipped(which, version)
    md = read_model_description(folder)
    kind = {(2, "ME"): FMU2Model, (2, "CS"): FMU2Slave, (3, "ME"): FMU3Model,
            (3, "CS"): FMU3Slave}[(version, interface)]
    ident = (md.modelExchange if interface == "ME" else md.coSimulation).modelIdentifier
    fmu = kind(guid=md.guid, unzipDirectory=folder, modelIdentifier=ident,
               instanceName=f"{which}_{version}_{interface}")
    fmu.instantiate()
    f = Fmu(which, version, interface, md, fmu, {v.name: v.valueReference
                                                  for v in md.modelVariables})
    if start:
        f.set(list(start), np.array(list(start.values())))
    if initialize:
        if version == 2:
            fmu.setupExperiment(startTime=0.0)
            fmu.enterInitializationMode()
            fmu.exitInitializationMode()
            if interface == "ME":
                fmu.enterContinuousTimeMode()
        else:
            fmu.enterInitializationMode(startTime=0.0)
            fmu.exitInitializationMode()
            if interface == "ME":
                fmu.enterContinuousTimeMode()
    return f


def names(prefix: str, n: int = 3) -> list[str]:
    return [f"{prefix}[{i + 1}]" for i in range(n)]


PLANT_UNKNOWNS = [*names("q"), *names("qd"), *names("qdd"), "tip.x", "tip.y", "tip.z"]
PLANT_INPUTS = names("u")
PLANT_STATES = [*names("q"), *names("qd")]
CTRL_UNKNOWNS = [*names("u"), *names("u_n"), *names("u_c")]
CTRL_INPUTS = [*names("q_ref"), *names("qd_ref"), *names("qdd_ref"), *names("q"), *names("qd"),
               *names("qdd")]
CTRL_LEAD = 1e-3


def relative_error(dd: np.ndarray, jac_fd: np.ndarray, seed: np.ndarray) -> float:
    """|dd - J_fd seed| per unknown, relative to the size of the terms of J_fd seed."""
    ref = jac_fd @ seed
    scale = np.abs(jac_fd) @ np.abs(seed)
    tiny = 1e-300
    return float(np.max(np.abs(dd - ref) / np.maximum(scale, tiny)))


def central_columns(f: Fmu, unknowns: list[str], knowns: list[str], x: np.ndarray,
                    apply: Any) -> np.ndarray:
    """J_fd[:, j] = (y(x + h_j e_j) - y(x - h_j e_j)) / (2 h_j), with apply(x) setting x."""
    cols = []
    for j in range(len(knowns)):
        h = H_REL * max(1.0, abs(x[j]))
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        apply(xp)
        yp = f.get(unknowns)
        apply(xm)
        ym = f.get(unknowns)
        cols.append((yp - ym) / (xp[j] - xm[j]))
    apply(x)
    return np.array(cols).T


def random_u(rng: np.random.Generator, n: int, u_max: float) -> np.ndarray:
    """Inputs inside the limit, every fourth sample beyond it (away from the kink)."""
    u = rng.uniform(-0.95, 0.95, 3) * u_max
    if n % 4 == 3:
        u = np.sign(u) * rng.uniform(1.05, 1.5, 3) * u_max
    return u


# ---- the plant -------------------------------------------------------------------------------

def _start(f: Fmu, name: str) -> float:
    var = next(v for v in f.md.modelVariables if v.name == name)
    return float(var.start)


@pytest.mark.parametrize("version", [2, 3])
def test_plant_me_directional_derivatives_equal_central_differences(version: int) -> None:
    f = open_fmu("plant", version, "ME")
    u_max = _start(f, "u_max")
    rng = np.random.default_rng(RNG_SEED + version)
    knowns = [*PLANT_INPUTS, *PLANT_STATES]
    worst = 0.0
    for n in range(N_SAMPLES):
        x = np.concatenate([random_u(rng, n, u_max), rng.uniform(-np.pi, np.pi, 3),
                            rng.uniform(-2.0, 2.0, 3)])

        def apply(v: np.ndarray) -> None:
            f.set(PLANT_INPUTS, v[:3])
            f.set_states(v[3:])

        jac = central_columns(f, PLANT_UNKNOWNS, knowns, x, apply)
        seed = rng.normal(size=len(knowns))
        worst = max(worst, relative_error(f.dd(PLANT_UNKNOWNS, knowns, seed), jac, seed))
    print(f"plant ME FMI {version}: worst relative error {worst:.2e} over {N_SAMPLES} samples")
    assert worst <= TOL
    f.fmu.terminate()
    f.fmu.freeInstance()


@pytest.mark.parametrize("version", [2, 3])
def test_plant_cs_directional_derivatives_equal_central_differences(version: int) -> None:
    """Co-Simulation: the knowns that can be moved in Step Mode are the inputs (d qdd / d u, the
    feedthrough), at random states reached through q0 and qd0; d / d(q, qd) are compared with
    differences of re-initialized instances on a few states."""
    f = open_fmu("plant", version, "CS", initialize=False)
    u_max = _start(f, "u_max")
    rng = np.random.default_rng(RNG_SEED + 10 + version)
    worst = 0.0
    n_state_checks = 20
    for n in range(N_SAMPLES):
        q0, qd0 = rng.uniform(-np.pi, np.pi, 3), rng.uniform(-2.0, 2.0, 3)
        u = random_u(rng, n, u_max)
        f.fmu.reset()
        start = np.concatenate([q0, qd0])
        f.set([*names("q0"), *names("qd0")], start)
        _initialize(f)
        jac = central_columns(f, PLANT_UNKNOWNS, PLANT_INPUTS, u,
                              lambda v: f.set(PLANT_INPUTS, v))
        seed = rng.normal(size=3)
        worst = max(worst, relative_error(f.dd(PLANT_UNKNOWNS, PLANT_INPUTS, seed), jac, seed))
        if n < n_state_checks:
            seed6 = rng.normal(size=6)
            dd = f.dd(PLANT_UNKNOWNS, PLANT_STATES, seed6)
            jac6 = _reinit_columns(f, start, u)
            worst = max(worst, relative_error(dd, jac6, seed6))
    print(f"plant CS FMI {version}: worst relative error {worst:.2e} over {N_SAMPLES} samples")
    assert worst <= TOL
    f.fmu.terminate()
    f.fmu.freeInstance()


def _initialize(f: Fmu) -> None:
    if f.version == 2:
        f.fmu.setupExperiment(startTime=0.0)
        f.fmu.enterInitializationMode()
    else:
        f.fmu.enterInitializationMode(startTime=0.0)
    f.fmu.exitInitializationMode()


def _reinit_columns(f: Fmu, start: np.ndarray, u: np.ndarray) -> np.ndarray:
    """d outputs / d (q, qd) by central differences of q0, qd0 through re-initialization."""
    def apply(v: np.ndarray) -> None:
        f.fmu.reset()
        f.set([*names("q0"), *names("qd0")], v)
        _initialize(f)
        f.set(PLANT_INPUTS, u)

    return central_columns(f, PLANT_UNKNOWNS, PLANT_STATES, start, apply)


# ---- the controller ----------------------------------------------------------------------------

def controller_point(rng: np.random.Generator) -> np.ndarray:
    q_ref = rng.uniform(-np.pi, np.pi, 3)
    qd_ref = rng.uniform(-1.5, 1.5, 3)
    qdd_ref = rng.uniform(-3.0, 3.0, 3)
    q = q_ref + rng.uniform(-0.02, 0.02, 3)
    qd = qd_ref + rng.uniform(-0.1, 0.1, 3)
    qdd = qdd_ref + rng.uniform(-1.0, 1.0, 3)
    return np.concatenate([q_ref, qd_ref, qdd_ref, q, qd, qdd])


@pytest.mark.parametrize("version", [2, 3])
@pytest.mark.parametrize("interface", ["ME", "CS"])
def test_controller_directional_derivatives_equal_central_differences(version: int,
                                                                      interface: str) -> None:
    f = open_fmu("controller", version, interface, start={"lead": CTRL_LEAD})
    u_max = _start(f, "u_max")
    rng = np.random.default_rng(RNG_SEED + 20 + version + (interface == "CS"))
    worst = 0.0
    done = 0
    while done < N_SAMPLES:
        x = controller_point(rng)
        f.set(CTRL_INPUTS, x)
        # away from the voltage limit's kink by more than the differences move u
        if np.min(np.abs(np.abs(f.get(names("u_n")) + f.get(names("u_c"))) - u_max)) < 1e-3:
            continue
        jac = central_columns(f, CTRL_UNKNOWNS, CTRL_INPUTS, x,
                              lambda v: f.set(CTRL_INPUTS, v))
        seed = rng.normal(size=len(CTRL_INPUTS))
        worst = max(worst, relative_error(f.dd(CTRL_UNKNOWNS, CTRL_INPUTS, seed), jac, seed))
        done += 1
    print(f"controller {interface} FMI {version}: worst relative error {worst:.2e}")
    assert worst <= TOL
    f.fmu.terminate()
    f.fmu.freeInstance()


# ---- FMI 3 adjoint ---------------------------------------------------------------------------

@pytest.mark.parametrize("which", ["plant", "controller"])
@pytest.mark.parametrize("interface", ["ME", "CS"])
def test_adjoint_is_the_transpose_of_the_forward_derivatives(which: str, interface: str) -> None:
    f = open_fmu(which, 3, interface, start={"lead": CTRL_LEAD} if which == "controller" else None)
    rng = np.random.default_rng(RNG_SEED + 30)
    unknowns = PLANT_UNKNOWNS if which == "plant" else CTRL_UNKNOWNS
    knowns = [*PLANT_INPUTS, *PLANT_STATES] if which == "plant" else CTRL_INPUTS
    for _ in range(50):
        if which == "plant":
            f.set(PLANT_INPUTS, rng.uniform(-5.0, 5.0, 3))
            if interface == "ME":
                f.set_states(np.concatenate([rng.uniform(-3, 3, 3), rng.uniform(-2, 2, 3)]))
        else:
            f.set(CTRL_INPUTS, controller_point(rng))
        jac = np.array([f.dd(unknowns, knowns, e) for e in np.eye(len(knowns))]).T
        w = rng.normal(size=len(unknowns))
        adj = f.adjoint(unknowns, knowns, w)
        np.testing.assert_allclose(adj, jac.T @ w, rtol=1e-13,
                                   atol=1e-13 * float(np.abs(jac).max()))
        # a subset in another order: the same entries
        sub_u, sub_k = unknowns[::-2], knowns[1::3]
        wu = rng.normal(size=len(sub_u))
        ref = np.array([[jac[unknowns.index(a), knowns.index(b)] for b in sub_k] for a in sub_u])
        np.testing.assert_allclose(f.adjoint(sub_u, sub_k, wu), ref.T @ wu, rtol=1e-13,
                                   atol=1e-13 * float(np.abs(jac).max()))


# ---- ModelStructure: dependencies and kinds equal the numbers ------------------------------------

def declared(md: ModelDescription, group: str) -> dict[str, dict[str, str]]:
    """{unknown: {known: kind}} of ModelStructure's outputs, derivatives or initialUnknowns."""
    out: dict[str, dict[str, str]] = {}
    for unk in getattr(md, group):
        deps = unk.dependencies or []
        kinds = unk.dependenciesKind or ["dependent"] * len(deps)
        out[unk.variable.name] = {d.name: k for d, k in zip(deps, kinds, strict=True)}
    return out


@pytest.mark.parametrize("which", ["plant", "controller"])
@pytest.mark.parametrize("version", [2, 3])
def test_output_dependencies_and_kinds_are_exact(which: str, version: int) -> None:
    start = {"lead": CTRL_LEAD} if which == "controller" else None
    f = open_fmu(which, version, "ME", start=start)
    unknowns = PLANT_UNKNOWNS if which == "plant" else CTRL_UNKNOWNS
    knowns = [*PLANT_INPUTS, *PLANT_STATES] if which == "plant" else CTRL_INPUTS
    rng = np.random.default_rng(RNG_SEED + 40)
    jacs = []
    for _ in range(20):
        if which == "plant":
            f.set(PLANT_INPUTS, rng.uniform(-5.0, 5.0, 3))
            f.set_states(np.concatenate([rng.uniform(-3, 3, 3), rng.uniform(-2, 2, 3)]))
        else:
            f.set(CTRL_INPUTS, controller_point(rng))
        jacs.append(np.array([f.dd(unknowns, knowns, e) for e in np.eye(len(knowns))]).T)
    stack = np.array(jacs)
    nonzero = np.any(stack != 0.0, axis=0)
    dec = declared(f.md, "outputs")
    if which == "plant":
        for a, b in zip(declared(f.md, "derivatives").items(),
                        [(n, dec[n]) for n in [*names("qd"), *names("qdd")]], strict=True):
            assert a == b  # the derivatives are the outputs qd, qdd: the same lists
    for i, unk in enumerate(unknowns):
        listed = dec[unk]
        for j, kn in enumerate(knowns):
            assert (kn in listed) == bool(nonzero[i, j]), (unk, kn, listed.get(kn))
            if listed.get(kn) in ("constant", "fixed"):  # the same factor at every state
                assert np.all(stack[:, i, j] == stack[0, i, j]), (unk, kn)
            if listed.get(kn) == "constant":
                assert stack[0, i, j] == 1.0


@pytest.mark.parametrize("which", ["plant", "controller"])
def test_initial_unknown_dependencies_are_exact(which: str) -> None:
    """Each input and parameter moved alone before initialization: the initial unknowns that
    change are those listed (FMI 2 and 3 list the same)."""
    # velocities where every tanh of the friction has a slope (w qd near 1 for w = 100 s/rad),
    # voltages inside the limit
    slow = [0.012, -0.009, 0.015]
    point = ({"u[1]": 0.7, "u[2]": -1.1, "u[3]": 0.4, "q0[1]": 0.3, "q0[2]": 0.8, "q0[3]": -1.2,
              "qd0[1]": slow[0], "qd0[2]": slow[1], "qd0[3]": slow[2]}
             if which == "plant" else
             {"lead": CTRL_LEAD, **dict(zip(CTRL_INPUTS, [
                 0.3, 0.8, -1.2, *slow, 0.2, -0.3, 0.1, 0.301, 0.801, -1.199, 0.013, -0.008,
                 0.016, 0.1, 0.1, 0.1], strict=True))})
    base_start: dict[str, float] = point
    f = open_fmu(which, 2, "ME", initialize=False)
    dec = declared(f.md, "initialUnknowns")
    dec3 = declared(read_model_description(_unzipped(which, 3)), "initialUnknowns")
    assert dec == dec3
    unknowns = list(dec)
    movable = [v for v in f.md.modelVariables
               if v.causality in ("input", "parameter") and v.type == "Real"]

    def initial(change: dict[str, float]) -> np.ndarray:
        f.fmu.reset()
        values = {**base_start, **change}
        f.set(list(values), np.array(list(values.values())))
        f.fmu.setupExperiment(startTime=0.0)
        f.fmu.enterInitializationMode()
        y = f.get(unknowns)
        return y

    y0 = initial({})
    # u_max acts only on a clamped input: moved at a point beyond the limit
    clamp = ({"u[1]": 40.0, "u[2]": -40.0, "u[3]": 40.0} if which == "plant"
             else {"kp[1]": 1e5, "kp[2]": 1e5, "kp[3]": 1e5})
    y_clamped = initial(clamp)
    for var in movable:
        if var.name == "u_max":
            u_max = float(var.start)
            y1 = initial({**clamp, "u_max": u_max * 1.001})
            for i, unk in enumerate(unknowns):
                assert (var.name in dec[unk]) == (y1[i] != y_clamped[i]), (unk, var.name)
            continue
        x0 = base_start.get(var.name, float(var.start) if var.start is not None else 0.0)
        step = 1e-3 * max(1.0, abs(x0))
        y1 = initial({var.name: x0 + step})
        for i, unk in enumerate(unknowns):
            assert (var.name in dec[unk]) == (y1[i] != y0[i]), (unk, var.name)
    # Booleans: feedforward and adaptive, listed exactly where switching them changes a value
    for var in f.md.modelVariables:
        if var.type == "Boolean" and var.causality == "parameter":
            f.fmu.reset()
            f.set(list(base_start), np.array(list(base_start.values())))
            f.fmu.setBoolean([var.valueReference], [var.start not in ("true", True)])
            f.fmu.setupExperiment(startTime=0.0)
            f.fmu.enterInitializationMode()
            y1 = f.get(unknowns)
            for i, unk in enumerate(unknowns):
                assert (var.name in dec[unk]) == (y1[i] != y0[i]), (unk, var.name)


# ---- Initialization Mode: the parameters are knowns too ------------------------------------------

@pytest.mark.parametrize("which", ["plant", "controller"])
@pytest.mark.parametrize("version", [2, 3])
def test_initialization_mode_derivatives_by_parameters(which: str, version: int) -> None:
    """In Initialization Mode the knowns are the inputs and the parameters (initial = exact):
    the directional derivative of every initial unknown equals central differences of
    re-initialized instances (each input and Real parameter moved alone), at random points."""
    f = open_fmu(which, version, "ME" if version == 2 else "CS", initialize=False)
    unknowns = PLANT_UNKNOWNS if which == "plant" else CTRL_UNKNOWNS
    knowns = [v.name for v in f.md.modelVariables
              if v.causality in ("input", "parameter") and v.type in ("Real", "Float64")]
    start = {v.name: float(v.start) for v in f.md.modelVariables
             if v.name in knowns and v.start is not None}
    rng = np.random.default_rng(RNG_SEED + 60 + version)
    worst = 0.0
    for n in range(5):
        point = dict(start)
        if which == "plant":
            point.update(zip(names("q0"), rng.uniform(-np.pi, np.pi, 3), strict=True))
            point.update(zip(names("qd0"), rng.uniform(-0.05, 0.05, 3), strict=True))
            u = rng.uniform(-0.9, 0.9, 3) * start["u_max"]
            if n % 2:
                u[n % 3] = 1.5 * start["u_max"]  # one input beyond the limit: u_max acts
            point.update(zip(PLANT_INPUTS, u, strict=True))
        else:
            point.update(zip(CTRL_INPUTS, controller_point(rng), strict=True))
            point["lead"] = 0.002
        x = np.array([point[k] for k in knowns])

        def init_at(v: np.ndarray) -> None:
            f.fmu.reset()
            f.set(knowns, v)
            if f.version == 2:
                f.fmu.setupExperiment(startTime=0.0)
                f.fmu.enterInitializationMode()
            else:
                f.fmu.enterInitializationMode(startTime=0.0)

        jac = central_columns(f, unknowns, knowns, x, init_at)
        seed = rng.normal(size=len(knowns))
        worst = max(worst, relative_error(f.dd(unknowns, knowns, seed), jac, seed))
        if version == 3:
            w = rng.normal(size=len(unknowns))
            full = np.array([f.dd(unknowns, knowns, e) for e in np.eye(len(knowns))]).T
            np.testing.assert_allclose(f.adjoint(unknowns, knowns, w), full.T @ w, rtol=1e-12,
                                       atol=1e-12 * float(np.abs(full).max()))
    print(f"{which} FMI {version}, Initialization Mode, {len(knowns)} knowns: worst relative "
          f"error {worst:.2e}")
    assert worst <= TOL
    # after initialization a parameter is not a known any more
    f.fmu.exitInitializationMode()
    with pytest.raises(FMICallException):
        f.fmu.getDirectionalDerivative([f.vr[unknowns[0]]], [f.vr["a2"]], [1.0])
    f.fmu.terminate()
    f.fmu.freeInstance()


# ---- refusals ----------------------------------------------------------------------------------

@pytest.mark.parametrize("version", [2, 3])
def test_refusals(version: int) -> None:
    f = open_fmu("plant", version, "ME")
    vr = f.vr
    for unknowns, knowns, seed in [
        ([vr["qdd[1]"]], [vr["a2"]], [1.0]),        # a parameter is not a known
        ([vr["u[1]"]], [vr["q[1]"]], [1.0]),        # an input is not an unknown
        ([vr["qdd[1]"]], [999], [1.0]),             # no such value reference
        ([vr["qdd[1]"]], [vr["u[1]"]], [float("nan")]),  # seed not finite
        ([vr["qdd[1]"]], [vr["u[1]"]], [float("inf")]),
    ]:
        with pytest.raises(FMICallException):
            f.fmu.getDirectionalDerivative(unknowns, knowns, seed)
    # still usable afterwards
    assert len(f.dd(["qdd[1]"], ["u[1]"], np.ones(1))) == 1
    f.fmu.terminate()
    f.fmu.freeInstance()
