"""A run in the browser: ``rrr view DIR`` writes one self-contained HTML page (docs/viewing.md).

The page holds everything it shows (no CDN, no request: a Content-Security-Policy of
``default-src 'none'`` with the hashes of its one script and one style block): per scenario the
world pose of every URDF link at each frame, computed here by librrr (``Model.fk_frames``: the
link k frame is DH frame k-1 turned by q_k, the tool is frame 3), the URDF's link visuals (the
cylinders of :func:`robot_urdf`), the pen trace and the reference (``tip``, ``x_ref``), and the
joint signals (q against q_ref, the voltages u, u_n, u_c, the tip error). The page's script only
draws: an orthographic 3-D view on a canvas, a time slider, play/pause, plots with a time cursor.

Hostile folders: the tables are read only inside the folder, by plain names (a scenario name
from summary.json or ``--scenario`` that is not one plain file name, or a table that is a link
out of the folder, is refused); the page's data is JSON with ``<``, ``>``, ``&`` and the line
separators escaped (no ``</script``, no ``<!--`` in its script element), its title is
HTML-escaped where it lands (``<title>``, ``<h1>``), and the template's placeholders are filled
in one pass, so no value (a folder named ``{{DATA}}``) can become another placeholder.
"""

from __future__ import annotations

import base64
import hashlib
import html
import json
import math
import re
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from ..core._arrays import FloatArray
from ..core.fmu_vars import JOINTS
from ..core.outputs import atomic_write_text, check_name
from ..core.robot import RobotFile
from ..core.tables import read_table
from ..core.urdf import robot_urdf
from ..errors import BadInputError

__all__ = ["MAX_FRAMES", "MAX_POINTS", "read_run", "view_html", "write_view"]

#: Most arm poses per scenario in a page (evenly spaced samples of the run, first and last kept).
MAX_FRAMES = 1500
#: Most samples of each plotted signal and of the trace.
MAX_POINTS = 3000
COLORS = {"link": "#e65100", "linkEdge": "#8d3000", "joint": "#263238", "pen": "#1565c0",
          "trace": "#1565c0", "ref": "#9e9e9e", "grid": "#eceff1", "cursor": "#d32f2f",
          "axisX": "#e53935", "axisY": "#43a047", "axisZ": "#1e88e5"}
_JOINT_COLORS = ("#1565c0", "#2e7d32", "#c62828")


def _asset(name: str) -> str:
    return (resources.files("rrr_robot") / "data" / "view" / name).read_text(encoding="utf-8")


def _even(n: int, most: int) -> np.ndarray:
    """Indices of at most ``most`` evenly spaced samples of n, the first and the last included."""
    if n <= most:
        return np.arange(n)
    return np.unique(np.rint(np.linspace(0, n - 1, most)).astype(np.int64))


def _rpy_matrix(rpy: Sequence[float]) -> FloatArray:
    r, p, y = rpy
    cr, sr, cp, sp, cy, sy = (math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y),
                              math.sin(y))
    return np.array([[cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
                     [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
                     [-sp, cp * sr, cp * cr]])


def urdf_visuals(urdf: str) -> list[dict[str, Any]]:
    """The cylinders of the URDF's links link1..3 and tool (in the link's frame): centre, axis,
    radius and length, with ``link`` 0..3."""
    root = ET.fromstring(urdf)
    names = ["link1", "link2", "link3", "tool"]
    out: list[dict[str, Any]] = []
    for link in root.iter("link"):
        name = link.get("name", "")
        if name not in names:
            continue
        for visual in link.iter("visual"):
            cyl = visual.find("geometry/cylinder")
            origin = visual.find("origin")
            if cyl is None:
                continue
            xyz = [float(v) for v in (origin.get("xyz", "0 0 0") if origin is not None
                                      else "0 0 0").split()]
            rpy = [float(v) for v in (origin.get("rpy", "0 0 0") if origin is not None
                                      else "0 0 0").split()]
            axis = _rpy_matrix(rpy)[:, 2]
            out.append({"link": names.index(name), "center": xyz, "axis": axis.tolist(),
                        "radius": float(cyl.get("radius", "0")),
                        "length": float(cyl.get("length", "0"))})
    return out


def link_poses(robot: RobotFile, q: FloatArray) -> FloatArray:
    """World pose of link1..3 and the tool for each row of q: (n, 4, 12), rotation row-major
    then position, from ``Model.fk_frames`` (link k = DH frame k-1 turned by q_k about z)."""
    frames = robot.model.fk_frames(q)                       # (n, 4, 4, 4)
    n = q.shape[0]
    c, s = np.cos(q), np.sin(q)
    rz = np.zeros((n, 3, 3, 3))
    rz[:, :, 0, 0], rz[:, :, 0, 1], rz[:, :, 1, 0], rz[:, :, 1, 1] = c, -s, s, c
    rz[:, :, 2, 2] = 1.0
    out = np.empty((n, 4, 12))
    for k in range(3):
        rot = frames[:, k, :3, :3] @ rz[:, k]
        out[:, k, :9] = rot.reshape(n, 9)
        out[:, k, 9:] = frames[:, k, :3, 3]
    out[:, 3, :9] = frames[:, 3, :3, :3].reshape(n, 9)
    out[:, 3, 9:] = frames[:, 3, :3, 3]
    return out


def _rounded(a: FloatArray, digits: int = 7) -> list[Any]:
    """Values for the page's JSON: rounded (1e-7 m is below a pixel), NaN as null."""
    r = np.round(np.asarray(a, dtype=np.float64), digits)
    return [None if not math.isfinite(v) else v for v in r.ravel().tolist()] if r.ndim == 1 \
        else [_rounded(row, digits) for row in r]


def _column3(columns: Mapping[str, FloatArray], name: str, sep: str) -> FloatArray | None:
    keys = [f"{name}[{i}]" for i in JOINTS] if sep == "[" else \
        [f"{name}.{a}" for a in "xyz"]
    if not all(k in columns for k in keys):
        return None
    return np.stack([np.asarray(columns[k], dtype=np.float64) for k in keys], axis=1)


def scenario_data(name: str, columns: Mapping[str, FloatArray], robot: RobotFile
                  ) -> dict[str, Any]:
    """What the page needs of one run's table (``t``, ``q[1..3]`` required)."""
    if "t" not in columns:
        raise BadInputError(f"{name}: the table has no column 't'")
    t = np.asarray(columns["t"], dtype=np.float64)
    q = _column3(columns, "q", "[")
    if q is None or t.ndim != 1 or t.size < 1 or q.shape[0] != t.size:
        raise BadInputError(f"{name}: the table needs the columns t and q[1], q[2], q[3]")
    finite = np.all(np.isfinite(q), axis=1) & np.isfinite(t)
    if not np.any(finite):
        raise BadInputError(f"{name}: no row with finite t and q to show")
    rows = np.flatnonzero(finite)          # a diverged run is shown up to its last finite row
    frames = rows[_even(rows.size, MAX_FRAMES)]
    poses = link_poses(robot, q[frames])
    points = rows[_even(rows.size, MAX_POINTS)]
    trace: dict[str, Any] = {"t": _rounded(t[points], 9)}
    tip, ref = _column3(columns, "tip", "."), _column3(columns, "x_ref", ".")
    if tip is not None:
        trace["tip"] = _rounded(tip[points])
    if ref is not None:
        trace["ref"] = _rounded(ref[points])
    series: list[dict[str, Any]] = []
    q_ref = _column3(columns, "q_ref", "[")
    for i in range(3):
        lines: list[dict[str, Any]] = [{"label": f"q{i + 1}", "color": _JOINT_COLORS[i],
                                        "values": _rounded(q[points, i])}]
        if q_ref is not None:
            lines.append({"label": "q_ref", "color": "#757575", "dash": True,
                          "values": _rounded(q_ref[points, i])})
        series.append({"title": f"joint {i + 1} angle (rad)", "lines": lines})
    for group, title in (("u", "voltage u (V)"), ("u_c", "feedback u_c (V)")):
        arr = _column3(columns, group, "[")
        if arr is not None:
            series.append({"title": title, "lines": [
                {"label": f"{group}{i + 1}", "color": _JOINT_COLORS[i],
                 "values": _rounded(arr[points, i], 6)} for i in range(3)]})
    if tip is not None and ref is not None:
        err = 1e3 * np.linalg.norm(tip[points] - ref[points], axis=1)
        series.append({"title": "tip error |tip - x_ref| (mm)", "lines": [
            {"label": "error", "color": "#6a1b9a", "values": _rounded(err, 5)}]})
    return {"name": name, "t": _rounded(t[frames], 9),
            "links": [_rounded(p.ravel()) for p in poses], "trace": trace,
            "signals": {"t": _rounded(t[points], 9), "series": series}}


def _view_box(scenarios: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """The fixed camera target: the centre and radius of every link origin and trace point."""
    pts = [np.zeros((1, 3))]
    for s in scenarios:
        links = np.asarray(s["links"], dtype=np.float64).reshape(-1, 4, 12)
        pts.append(links[:, :, 9:].reshape(-1, 3))
        for key in ("tip", "ref"):
            if key in s["trace"]:
                arr = np.asarray(s["trace"][key], dtype=np.float64)
                pts.append(arr[np.all(np.isfinite(arr), axis=1)])
    allp = np.concatenate(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    center = 0.5 * (lo + hi)
    radius = max(0.05, float(np.max(np.linalg.norm(allp - center, axis=1))))
    half = max(0.2, math.ceil(float(np.max(np.abs(allp[:, :2]))) * 10.0) / 10.0)
    return {"center": center.tolist(), "radius": radius, "azimuth": -0.9, "elevation": 0.45,
            "ground": {"half": half, "step": 0.1}}


def _sha256(text: str) -> str:
    return "'sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode() + "'"


#: What the page's JSON holds as escapes (valid JSON, and never markup inside its script
#: element: no "</script", no "<!--", no "]]>").
_JSON_ESCAPES = {"<": "\\u003c", ">": "\\u003e", "&": "\\u0026", "\u2028": "\\u2028",
                 "\u2029": "\\u2029"}
#: The template's placeholders, filled in one pass.
_PLACEHOLDER = re.compile(r"\{\{(CSP|TITLE|STYLE|SCRIPT|DATA)\}\}")


def script_json(data: Any) -> str:
    """``data`` as JSON for an HTML ``<script type="application/json">`` element."""
    text = json.dumps(data, separators=(",", ":"), allow_nan=False)
    return re.sub("[<>&\u2028\u2029]", lambda m: _JSON_ESCAPES[m.group(0)], text)


def view_html(runs: Mapping[str, Mapping[str, FloatArray]], robot: RobotFile,
              title: str = "rrr view") -> str:
    """The page for ``runs`` (scenario name -> its table's columns)."""
    if not runs:
        raise BadInputError("no run to show")
    scenarios = [scenario_data(name, cols, robot) for name, cols in runs.items()]
    data = {"colors": COLORS, "visuals": urdf_visuals(robot_urdf(robot)),
            "view": _view_box(scenarios), "scenarios": scenarios}
    script, style = _asset("view.js"), _asset("view.css")
    csp = (f"default-src 'none'; script-src {_sha256(script)}; style-src {_sha256(style)}; "
           "img-src 'none'; connect-src 'none'; base-uri 'none'; form-action 'none'")
    values = {"CSP": csp, "TITLE": html.escape(title, quote=True), "STYLE": style,
              "SCRIPT": script, "DATA": script_json(data)}
    return _PLACEHOLDER.sub(lambda m: values[m.group(1)], _asset("view.html"))


def _table(root: Path, name: str, source: str) -> Path | None:
    """The table of scenario ``name`` in ``root``: ``<name>.csv`` or ``.parquet`` (None: no
    such file), read only inside ``root``: BadInputError for a name that is not one plain file
    name (``source`` names where it came from) or a table that leads out of the folder."""
    try:
        check_name(f"{name}.csv")
    except BadInputError:
        raise BadInputError(f"{source}: the scenario {name!r} cannot name a table in {root} "
                            "(one plain file name: no folder, not hidden)") from None
    inside = root.resolve()
    for path in (root / f"{name}.csv", root / f"{name}.parquet"):
        if not path.is_file():
            continue
        if path.resolve().parent != inside:
            raise BadInputError(f"{path} leads out of {root} (to {path.resolve()}): rrr view "
                                "reads the tables inside the folder only")
        return path
    return None


def read_run(folder: str | Path, scenarios: Sequence[str] | None = None
             ) -> dict[str, dict[str, FloatArray]]:
    """The tables of a result folder: ``<name>.csv`` (or ``.parquet``) for each scenario of its
    summary.json (or of ``scenarios``), name -> columns; only files inside the folder, by plain
    names."""
    root = Path(folder)
    if not root.is_dir():
        raise BadInputError(f"{root} is not a folder of results")
    names = list(scenarios or [])
    source = "--scenario"
    if not names:
        summary = root / "summary.json"
        source = str(summary)
        if summary.is_file():
            try:
                doc = json.loads(summary.read_text(encoding="utf-8"))
                names = [str(k) for k in doc.get("scenarios", {})]
            except (ValueError, AttributeError) as exc:
                raise BadInputError(f"{summary}: not a summary of a run ({exc})") from None
        else:
            names = sorted(p.stem for p in root.glob("*.csv"))
            source = str(root)
    runs: dict[str, dict[str, FloatArray]] = {}
    for name in names:
        path = _table(root, name, source)
        if path is None:
            raise BadInputError(f"{root}: no table {name}.csv or {name}.parquet")
        runs[name] = read_table(path)
    if not runs:
        raise BadInputError(f"{root}: no result table (<scenario>.csv) to show")
    return runs


def write_view(folder: str | Path, robot: RobotFile, out: str | Path | None = None,
               scenarios: Sequence[str] | None = None) -> Path:
    """Write the page of the run in ``folder`` to ``out`` (default ``folder/view.html``),
    atomically; returns its path."""
    runs = read_run(folder, scenarios)
    target = Path(out) if out is not None else Path(folder) / "view.html"
    title = f"rrr view: {Path(folder).resolve().name}"
    return atomic_write_text(target, view_html(runs, robot, title))
