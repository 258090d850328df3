"""Robot files (TOML): the one reader. Format: data/default_robot.toml (README, "The default
robot"); :func:`read_robot_file` reads and checks a file (or its parsed tables) ONCE and hands
on a frozen :class:`RobotFile`: the :class:`~rrr_robot.core.model.Model` and the checked tables
([control], [writing], the link tables, ...) as :class:`RobotData`. Every reader of robot files
in the package goes through here; ``RobotData.tables()`` and
:func:`~rrr_robot.core.checked.write_toml` write one back.

Every table is checked: unknown tables and keys are errors that name them (with the allowed
ones), and every value is checked for type, shape, finiteness and range. The model parameters'
names, shapes and lower bounds come from the C parameter table (``rrr_params.h``, through
:mod:`.param_names`), with :data:`MAX_MAGNITUDE` as upper bound; link inertias must be
physically consistent (mass > 0, principal moments > 0 obeying the triangle inequality); the
model as a whole must pass ``rrr_model_validate`` (D(q) positive definite everywhere). Errors
(:class:`RobotFileError`) name the file, the table and the key, and the index in an array::

    robot.toml: [control] kp[2] must be a finite number >= 0 and <= 1e6, got "abc"

Tables: [kinematics], [gravity], [motors], [friction] (required); [link1..3] with [motors]
rotor_inertia, or [base_parameters] (one of the two); [control] (kp, kd, sample_time: the
sample period of the writing task's reference and of the co-simulation, default
:data:`DEFAULT_SAMPLE_TIME`); [writing] (:data:`WRITING_FIELDS`, built into a WritingSpec by
rrr_robot.writing); [identification] (written by ``rrr identify``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

from ..errors import RobotFileError, RrrError
from . import _lib
from ._lib import _ext
from .checked import Document, Field, Flag, Matrix, Number, Text, Vector, load_toml, show
from .model import DEFAULT_ROBOT_TOML, Model
from .param_names import PARAMS, ParamInfo, group_shape, param
from .stiffness import Stiffness, stiffness

__all__ = [
    "DEFAULT_SAMPLE_TIME",
    "MAX_GAIN",
    "MAX_MAGNITUDE",
    "MAX_TEXT",
    "PARAM_TABLES",
    "SAMPLE_TIME",
    "WRITING_FIELDS",
    "ControlGains",
    "LinkInertia",
    "RobotData",
    "RobotFile",
    "param_check",
    "read_robot_file",
    "writing_values",
]

#: The control period (s) when a robot file gives no [control] sample_time, and wherever the
#: package needs a default (the writing task's reference, the co-simulation step, the
#: identification experiments): RRR_SAMPLE_TIME_DEFAULT of librrr (rrr_control.h, 1 ms), the
#: FMUs' default step and the CAN bench's period.
DEFAULT_SAMPLE_TIME = _lib.sample_time_default()
#: [control] sample_time: from 10 us to 10 ms.
SAMPLE_TIME = Number(lo=1e-5, hi=1e-2)
#: Upper bound of the magnitude of every model number of a robot file (SI units): beyond it
#: products in the dynamics lose their meaning long before they overflow.
MAX_MAGNITUDE = 1e6
#: Upper bound of the PD gains kp (V/rad) and kd (V s/rad).
MAX_GAIN = 1e6
#: Characters of the text of one writing-task run (joining strokes costs O(n^2) in the text).
MAX_TEXT = 200

GAIN = Number(lo=0.0, hi=MAX_GAIN)
_ANY = Number(lo=-MAX_MAGNITUDE, hi=MAX_MAGNITUDE)
_POSITIVE = Number(lo=0.0, lo_open=True, hi=MAX_MAGNITUDE)
_NONNEGATIVE = Number(lo=0.0, hi=MAX_MAGNITUDE)

#: Where each group of the C parameter table lives in a robot file: table -> groups (= keys).
PARAM_TABLES: dict[str, tuple[str, ...]] = {
    "kinematics": ("d1", "a2", "a3", "d2", "d3"),
    "gravity": ("g",),
    "base_parameters": ("p",),
    "motors": ("kt", "u_max"),
    "friction": ("f", "w", "b"),
}
LINKS = ("link1", "link2", "link3")
TABLES = ("kinematics", "gravity", *LINKS, "base_parameters", "motors", "friction", "control",
          "writing", "identification")

LINK_FIELDS: dict[str, Field] = {
    "mass": _POSITIVE,                  # kg
    "com": Vector(3, _ANY),             # m, in DH frame i
    "inertia_com": Vector(3, _POSITIVE),  # kg m^2, principal moments about the COM
}
ROTOR_INERTIA = Vector(3, _NONNEGATIVE)   # kg m^2
CONTROL_FIELDS: dict[str, Field] = {
    "kp": Vector(3, GAIN),
    "kd": Vector(3, GAIN),
    "sample_time": SAMPLE_TIME,
}

_LENGTH = Number(lo=-10.0, hi=10.0)               # m: a place in the writing area
_SIZE = Number(lo=0.0, lo_open=True, hi=10.0)
_SPEED = Number(lo=0.0, lo_open=True, hi=10.0)    # m/s
_ACC = Number(lo=0.0, lo_open=True, hi=1000.0)    # m/s^2
_RADIUS = Number(lo=0.0, lo_open=True, hi=1.0)    # m
_MARGIN = Number(lo=0.0, hi=1.0)
_FONT = Text(max_len=64, pattern=r"[A-Za-z0-9_.-]+",
             pattern_text="a font name (letters, digits, _ . -; at most 64 characters)")

#: The [writing] table: the fields of rrr_robot.writing.WritingSpec a robot file may set, with
#: their checks (the same checks guard a WritingSpec built in code); ``duration_hint`` is read
#: and ignored. The sample period is [control] sample_time, not a [writing] key.
WRITING_FIELDS: dict[str, Field] = {
    "text": Text(max_len=MAX_TEXT, nonblank=True),
    "plane_y": _LENGTH,
    "x_range": Vector(2, _LENGTH, increasing=True),
    "z_range": Vector(2, _LENGTH, increasing=True),
    "letter_height": _SIZE,
    "fit_to_area": Flag(),
    "min_letter_height": _SIZE,
    "peak_speed": _SPEED,
    "min_speed": _SPEED,
    "lateral_acc": _ACC,
    "max_acc": _ACC,
    "lift_acc": _ACC,
    "max_jerk": Number(lo=0.0, lo_open=True, hi=1e6),
    "tangential_acc": _ACC,
    "lift": Number(lo=-1.0, hi=1.0),
    "corner_radius": _RADIUS,
    "lift_radius": _RADIUS,
    "corner_angle_deg": Number(lo=0.0, lo_open=True, hi=180.0),
    "smoothing": Number(lo=0.0, lo_open=True, hi=1.0),
    "rest": Number(lo=0.0, hi=10.0),
    "line_spacing": _SIZE,
    "latin_font": _FONT,
    "greek_font": _FONT,
    "min_workspace_margin": _MARGIN,
    "min_elbow_margin": _MARGIN,
    "shoulder": Text(choices=("front", "back")),
    "elbow": Text(choices=("up", "down")),
    "duration_hint": Number(lo=0.0, hi=1e6),
}

_P16 = Vector(16, Number())
_J3 = Vector(3, Number())
#: The [identification] table written by ``rrr identify`` (figures of merit, carried along).
IDENTIFICATION_FIELDS: dict[str, Field] = {
    "p": _P16, "p_std": _P16, "estimator": Text(max_len=80), "cond": Number(lo=0.0),
    "rows": Number(lo=0.0, integer=True), "residual_std_Nm": _J3,
    "p_ls": _P16, "p_std_ls": _P16, "p_wls": _P16, "p_std_wls": _P16,
    "friction_method": Text(max_len=80), "friction_residual_rms_V": _J3,
    "friction_residual_max_V": _J3,
    # against the truth of a simulated experiment (rrr identify --truth)
    "truth": Text(max_len=4096), "p_true": _P16, "p_inside_95": Number(lo=0.0, hi=16.0,
                                                                      integer=True),
    "friction_curve_error_max_V": _J3,
}

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class LinkInertia:
    """One [linkN] table: mass (kg), COM in DH frame i (m), principal moments of inertia about
    the COM along the axes of frame i (kg m^2)."""

    mass: float
    com: Vec3
    inertia_com: Vec3


@dataclass(frozen=True)
class ControlGains:
    """The [control] table: PD gains of eq 15 and the sample period (s)."""

    kp: Vec3
    kd: Vec3
    sample_time: float = DEFAULT_SAMPLE_TIME


@dataclass(frozen=True)
class RobotData:
    """A checked robot file. ``params``: every scalar of the C parameter table by its name (p
    computed from the link tables by eq 12 unless [base_parameters] gives it); ``links`` and
    ``rotor_inertia``: the link tables (None with [base_parameters]); ``control``: None without
    a [control] table; ``writing``: the [writing] values given (checked, not yet a WritingSpec);
    ``identification``: the [identification] values."""

    source: str
    params: Mapping[str, float]
    links: tuple[LinkInertia, LinkInertia, LinkInertia] | None
    rotor_inertia: Vec3 | None
    control: ControlGains | None
    writing: Mapping[str, Any]
    identification: Mapping[str, Any]

    @property
    def sample_time(self) -> float:
        """[control] sample_time, or DEFAULT_SAMPLE_TIME."""
        return self.control.sample_time if self.control is not None else DEFAULT_SAMPLE_TIME

    def raw_model(self) -> _lib.RawModel:
        """A new C model struct holding ``params``."""
        raw = _lib.RawModel()
        for info in PARAMS:
            _lib.param_set(raw, info.row, self.params[info.name])
        return raw

    def group(self, group: str) -> Any:
        """A parameter group as the robot file writes it: a number, a list or a list of lists."""
        return _group_value(self.params, group)

    def tables(self) -> dict[str, dict[str, Any]]:
        """The file's tables as checked (numbers as floats, arrays as lists), ready for
        ``write_toml``."""
        out: dict[str, dict[str, Any]] = {}
        for table, groups in PARAM_TABLES.items():
            if table == "base_parameters" and self.links is not None:
                continue
            out[table] = {g: self.group(g) for g in groups}
            if table == "gravity" and self.links is not None:
                for name, link in zip(LINKS, self.links, strict=True):
                    out[name] = {"mass": link.mass, "com": list(link.com),
                                 "inertia_com": list(link.inertia_com)}
        if self.rotor_inertia is not None:
            out["motors"]["rotor_inertia"] = list(self.rotor_inertia)
        if self.control is not None:
            out["control"] = {"kp": list(self.control.kp), "kd": list(self.control.kd),
                              "sample_time": self.control.sample_time}
        for name, entries in (("writing", self.writing),
                              ("identification", self.identification)):
            if entries:
                out[name] = {k: list(v) if isinstance(v, tuple) else v
                             for k, v in entries.items()}
        return out


def _group_value(params: Mapping[str, float], group: str) -> Any:
    shape = group_shape(group)
    if not shape:
        return params[group]
    if len(shape) == 1:
        return [params[f"{group}[{i}]"] for i in range(1, shape[0] + 1)]
    return [[params[f"{group}[{i},{k}]"] for k in range(1, shape[1] + 1)]
            for i in range(1, shape[0] + 1)]


def _bound(info: ParamInfo) -> Number:
    """A C table row's check: finite, its lower bound, magnitude <= MAX_MAGNITUDE."""
    if info.bound == _lib.PARAM_POS:
        return Number(lo=0.0, lo_open=True, hi=MAX_MAGNITUDE, extra=info.in_range)
    if info.bound == _lib.PARAM_NONNEG:
        return Number(lo=0.0, hi=MAX_MAGNITUDE, extra=info.in_range)
    return Number(lo=-MAX_MAGNITUDE, hi=MAX_MAGNITUDE, extra=info.in_range)


def param_check(name: str) -> Number:
    """The check of one scalar model parameter by its C name ("kt[2]", "f[1,3]"), as a robot
    file checks it: finite, its lower bound, magnitude <= MAX_MAGNITUDE (BadInputError for a
    name that is no model parameter)."""
    return _bound(param(name))


def param_field(group: str) -> Field:
    """The check of one parameter group's key (its shape and bounds from the C table)."""
    rows = [p for p in PARAMS if p.group == group]
    shape = group_shape(group)
    if not shape:
        return _bound(rows[0])
    if len(shape) == 1:
        return Vector(shape[0], [_bound(r) for r in sorted(rows, key=lambda r: r.index)])
    checks = {r.index: _bound(r) for r in rows}
    return Matrix(shape[0], shape[1], lambda i, k: checks[(i + 1, k + 1)])


def _flat(group: str, value: Any) -> dict[str, float]:
    """A checked group value under the C names of its scalars."""
    shape = group_shape(group)
    if not shape:
        return {group: float(value)}
    if len(shape) == 1:
        return {f"{group}[{i + 1}]": float(v) for i, v in enumerate(value)}
    return {f"{group}[{i + 1},{k + 1}]": float(v)
            for i, row in enumerate(value) for k, v in enumerate(row)}


def _link(doc: Document, name: str) -> LinkInertia:
    entries = doc.table(name, LINK_FIELDS, required=tuple(LINK_FIELDS), must_exist=True)
    assert entries is not None
    moments = entries["inertia_com"]
    for k in range(3):
        others = sum(moments) - moments[k]
        if moments[k] > others * (1.0 + 1e-12):
            a, b = (moments[j] for j in range(3) if j != k)
            doc.fail(name, "inertia_com", f"[{name}] inertia_com = {show(list(moments))} are "
                     "not the principal moments of a rigid body: each must be at most the sum "
                     f"of the other two (triangle inequality), but {moments[k]!r} > {a!r} + "
                     f"{b!r}")
    return LinkInertia(entries["mass"], entries["com"], entries["inertia_com"])


def _base_parameters_from_links(doc: Document, params: dict[str, float],
                                links: tuple[LinkInertia, ...], rotor: Vec3) -> None:
    raw = _lib.RawModel()
    for info in PARAMS:
        if info.group != "p":
            _lib.param_set(raw, info.row, params[info.name])
    inertial = _lib.RawInertial()
    for i, link in enumerate(links):
        inertial.link[i].mass = link.mass
        for r in range(3):
            inertial.link[i].com[r] = link.com[r]
            inertial.link[i].inertia_com[r][r] = link.inertia_com[r]
        inertial.rotor_inertia[i] = rotor[i]
    try:
        _ext.bps_from_inertia(raw, inertial, raw.p)
    except RrrError as exc:
        doc.fail("link1", "", f"the link tables ([link1..3] mass, com, inertia_com) and [motors] "
                 f"rotor_inertia give no finite base parameters ({exc})")
    params |= _flat("p", raw.p[:])


def _validate(doc: Document, data: RobotData) -> None:
    """rrr_model_validate on the whole model; the error names the table and key."""
    raw = data.raw_model()
    status, field = _ext.model_validate(raw)
    if status == 0:
        try:
            stiffness(raw, data.params)
        except Stiffness as exc:
            doc.fail("friction", exc.field.split("[")[0], f"[friction] {exc}")
        return
    name = field or "?"
    status_name = _lib.STATUS_NAMES[status] if 0 <= status < len(_lib.STATUS_NAMES) else "?"
    if name == "p" and data.links is None:
        doc.fail("base_parameters", "p", "[base_parameters] p gives an inertia matrix D(q) that "
                 f"is not positive definite for every q ({status_name})")
    if name == "p":
        doc.fail("link1", "inertia_com", "the link tables ([link1..3] mass, com, inertia_com) "
                 "and [motors] rotor_inertia give an inertia matrix D(q) that is not positive "
                 f"definite for every q ({status_name})")
    group = name.split("[")[0]
    table = next((t for t, groups in PARAM_TABLES.items() if group in groups), "?")
    doc.fail(table, group, f"[{table}] {name} = {data.params.get(name)!r} is rejected by "
             f"rrr_model_validate ({status_name})")


def _writing(doc: Document) -> dict[str, Any]:
    hints = {"dt": " (the sample period is [control] sample_time)"}
    return doc.table("writing", WRITING_FIELDS, hints=hints) or {}


def writing_values(table: Mapping[str, Any], source: str = "robot file") -> dict[str, Any]:
    """The checked values of a [writing] table alone (as :func:`read_robot_file` checks them)."""
    return _writing(Document({"writing": table}, source, "robot file", RobotFileError))


def _parse(data: Mapping[str, Any], source: str) -> RobotData:
    """Check the parsed tables of a robot file (see the module doc); ``source`` names it in
    messages. Raises RobotFileError."""
    doc = Document(data, source, "robot file", RobotFileError)
    doc.only_tables(TABLES)
    params: dict[str, float] = {}
    rotor: Vec3 | None = None
    for table, groups in PARAM_TABLES.items():
        if table == "base_parameters":
            continue
        schema = {g: param_field(g) for g in groups}
        if table == "motors":
            schema["rotor_inertia"] = ROTOR_INERTIA
        entries = doc.table(table, schema, required=groups, must_exist=True)
        assert entries is not None
        for group in groups:
            params |= _flat(group, entries[group])
        if table == "motors":
            rotor = entries.get("rotor_inertia")
    links: tuple[LinkInertia, LinkInertia, LinkInertia] | None = None
    given = [name for name in LINKS if doc.has(name)]
    if doc.has("base_parameters"):
        if given:
            doc.fail(given[0], "", f"[base_parameters] and [{given[0]}] are both given: p comes "
                     "either from [base_parameters] or from the link tables; remove one")
        entries = doc.table("base_parameters", {"p": param_field("p")}, required=("p",))
        assert entries is not None
        params |= _flat("p", entries["p"])
    else:
        if not given:
            doc.fail("link1", "", "missing table [link1] (keys: mass, com, inertia_com; the "
                     "link tables [link1..3] give the inertial data, or [base_parameters] p "
                     "replaces them)")
        links = (_link(doc, LINKS[0]), _link(doc, LINKS[1]), _link(doc, LINKS[2]))
        if rotor is None:
            doc.fail("motors", "rotor_inertia", "missing key 'rotor_inertia' in [motors] (needed "
                     "with the link tables [link1..3])")
        _base_parameters_from_links(doc, params, links, rotor)
    control_entries = doc.table("control", CONTROL_FIELDS, required=("kp", "kd"))
    control = None if control_entries is None else ControlGains(
        control_entries["kp"], control_entries["kd"],
        control_entries.get("sample_time", DEFAULT_SAMPLE_TIME))
    writing = _writing(doc)
    ident = doc.table("identification", IDENTIFICATION_FIELDS) or {}
    result = RobotData(
        source=source, params=MappingProxyType(params), links=links, rotor_inertia=rotor,
        control=control, writing=MappingProxyType(writing),
        identification=MappingProxyType(ident),
    )
    _validate(doc, result)
    return result


@dataclass(frozen=True)
class RobotFile:
    """A checked robot file and the model built from it.

    ``model``: the validated :class:`~rrr_robot.core.model.Model`; ``control``: the [control]
    gains and sample period (None without a [control] table); ``sample_time``: the sample
    period of the writing task's reference and of the co-simulation (s); ``writing``: the
    checked [writing] values, built into a WritingSpec by ``rrr_robot.writing``
    (``WritingSpec.from_robot``); ``links``, ``rotor_inertia``: the link tables (None when the
    file gives [base_parameters]); ``data``: everything, as :class:`RobotData`
    (``data.tables()`` writes it back)."""

    source: str
    model: Model
    data: RobotData

    @property
    def control(self) -> ControlGains | None:
        return self.data.control

    @property
    def sample_time(self) -> float:
        return self.data.sample_time

    @property
    def writing(self) -> Mapping[str, Any]:
        return self.data.writing

    @property
    def links(self) -> tuple[LinkInertia, LinkInertia, LinkInertia] | None:
        return self.data.links

    @property
    def rotor_inertia(self) -> tuple[float, float, float] | None:
        return self.data.rotor_inertia

    def require_control(self) -> ControlGains:
        """[control], or RobotFileError naming the file when it has none."""
        if self.data.control is None:
            raise RobotFileError(f"{self.source}: missing table [control] (kp, kd; the writing "
                                 "task's PD gains)", self.source, "control", "")
        return self.data.control

    @classmethod
    def from_data(cls, data: RobotData) -> RobotFile:
        return cls(data.source, Model(data.raw_model(), validate=False), data)


def read_robot_file(robot: str | Path | Mapping[str, Any] = DEFAULT_ROBOT_TOML,
                    source: str | None = None) -> RobotFile:
    """Read and check a robot file once: ``robot`` is its path (default: the packaged default
    robot) or its parsed tables (a mapping, e.g. a robot embedded in another file); ``source``
    names it in messages (default: the path, or "robot data"). Raises RobotFileError naming
    the file, the table and the key."""
    if isinstance(robot, Mapping):
        data = _parse(robot, source if source is not None else "robot data")
    else:
        data = _parse(load_toml(robot, "robot file", RobotFileError),
                      source if source is not None else str(robot))
    return RobotFile.from_data(data)
