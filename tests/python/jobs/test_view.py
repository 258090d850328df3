"""``rrr view DIR`` (rrr_robot.writing.view): the page opened in headless Chromium (Debian's
``chromium``; scripts/run_tests.sh installs it): at two times of a writing run, the screenshot has
the link colour where librrr's FK puts each URDF link (projected with the page's own projection,
read from its DOM), the arm has moved between them and the pen trace has grown; the page logs
nothing to the console (no error, no Content-Security-Policy violation) and asks for nothing
from a network (a strict CSP whose hashes match its one script and style; no URL in it).
Also ``rrr writing --view``, the page's escaping, and bad folders refused.
"""

from __future__ import annotations

import base64
import hashlib
import html
import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import rrr_robot as rr
from PIL import Image
from rrr_robot.core.tables import read_csv_table
from rrr_robot.core.urdf import robot_urdf
from rrr_robot.writing.view import COLORS, link_poses, urdf_visuals, view_html

ROBOT = rr.read_robot_file()
LINK = tuple(int(COLORS["link"][i:i + 2], 16) for i in (1, 3, 5))
TRACE = tuple(int(COLORS["trace"][i:i + 2], 16) for i in (1, 3, 5))


def chromium_path() -> str:
    for name in (os.environ.get("RRR_CHROMIUM", ""), "chromium", "chromium-browser"):
        if name and (found := shutil.which(name)):
            return found
    pytest.fail("the browser view test needs Chromium: apt-get install chromium (the test "
                "command scripts/run_tests.sh installs it when it runs as root), or set "
                "RRR_CHROMIUM to a Chromium or Chrome executable")


@pytest.fixture(scope="module")
def run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("view") / "results"
    subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--scenario", "ctc",
                    "--engine", "native", "--no-figures", "--view", "--out", str(out), "-q"],
                   check=True)
    return out


@pytest.fixture(scope="module")
def page(run: Path) -> Path:
    done = subprocess.run([sys.executable, "-m", "rrr_robot", "view", str(run), "--out",
                           str(run / "page.html")], capture_output=True, text=True, check=True)
    assert "page.html" in done.stdout
    return run / "page.html"


def browse(page: Path, fragment: str, tmp: Path, *extra: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [chromium_path(), "--headless", "--no-sandbox", "--disable-gpu", "--hide-scrollbars",
         "--force-device-scale-factor=1", "--window-size=1280,900", "--no-first-run",
         "--virtual-time-budget=4000", "--enable-logging=stderr", "--v=0",
         f"--user-data-dir={tmp / 'profile'}", *extra, page.as_uri() + fragment],
        capture_output=True, text=True, timeout=180)


def state(page: Path, fragment: str, tmp: Path) -> dict[str, str]:
    """The page's <body> data-* attributes after its script ran, and no console line."""
    done = browse(page, fragment, tmp, "--dump-dom")
    assert done.returncode == 0, done.stderr[-2000:]
    consoles = [line for line in done.stderr.splitlines() if ":CONSOLE" in line]
    assert consoles == [], consoles
    body = re.search(r"<body([^>]*)>", done.stdout)
    assert body is not None, done.stdout[:500]
    return {k: v.replace("&quot;", '"') for k, v in re.findall(r'data-([\w-]+)="([^"]*)"',
                                                                 body.group(1))}


def screenshot(page: Path, fragment: str, tmp: Path, name: str) -> np.ndarray:
    shot = tmp / name
    done = browse(page, fragment, tmp, f"--screenshot={shot}")
    assert done.returncode == 0 and shot.is_file(), done.stderr[-2000:]
    assert [line for line in done.stderr.splitlines() if ":CONSOLE" in line] == []
    return np.asarray(Image.open(shot).convert("RGB"), dtype=np.int16)


def near(pixels: np.ndarray, color: tuple[int, ...], tol: int = 40) -> np.ndarray:
    return np.all(np.abs(pixels - np.array(color)) <= tol, axis=-1)


def arm(pixels: np.ndarray) -> np.ndarray:
    """Pixels of the arm: its link colour, the links' darker outline or a blend of the two (where
    the outline of a nearer link crosses); no other colour of the page is this orange."""
    r, g, b = pixels[..., 0], pixels[..., 1], pixels[..., 2]
    return (r > 120) & (g > 0.28 * r) & (g < 0.42 * r) & (b < 40)


def link_points(q: np.ndarray, proj: np.ndarray, origin: np.ndarray) -> list[np.ndarray]:
    """Pixel positions of the centres of the URDF's link cylinders at q (FK by librrr), the
    cylinders at least 20 px long on the screen."""
    poses = link_poses(ROBOT, q[None, :])[0]
    out = []
    for vis in urdf_visuals(robot_urdf(ROBOT)):
        rot = poses[vis["link"], :9].reshape(3, 3)
        pos = poses[vis["link"], 9:]
        centre = rot @ np.array(vis["center"]) + pos
        axis = rot @ np.array(vis["axis"])
        ends = [centre - 0.5 * vis["length"] * axis, centre + 0.5 * vis["length"] * axis]
        px = [proj @ np.append(p, 1.0) + origin for p in (centre, *ends)]
        if np.linalg.norm(px[2] - px[1]) >= 20:
            out.append(px[0])
    return out


def test_the_arm_is_drawn_where_fk_puts_it_and_moves_with_the_slider(page, run, tmp_path):
    table = read_csv_table(run / "ctc.csv")
    q_all = np.stack([table[f"q[{i}]"] for i in (1, 2, 3)], axis=1)
    shots, points = [], []
    for k, t in enumerate((0.8, 4.5)):
        s = state(page, f"#scenario=ctc&t={t}", tmp_path)
        assert s["state"] == "ready" and s["errors"] == "0" and s["scenario"] == "ctc"
        assert abs(float(s["time"]) - t) < 0.01
        row = int(np.argmin(np.abs(table["t"] - float(s["time"]))))
        assert abs(table["t"][row] - float(s["time"])) < 1e-9
        proj = np.array(json.loads(s["projection"]))          # (2, 4): CSS px of the canvas
        origin = np.array(json.loads(s["canvas"]))
        pts = link_points(q_all[row], proj, origin)
        assert len(pts) >= 3
        img = screenshot(page, f"#scenario=ctc&t={t}", tmp_path, f"shot{k}.png")
        for p in pts:   # the link colour where FK puts each link (a 3x3 patch around it)
            x, y = (int(v) for v in np.rint(p))
            assert arm(img[y - 1:y + 2, x - 1:x + 2]).all(), (t, p, img[y, x])
        shots.append(img)
        points.append(pts)
    moved = np.any(np.abs(shots[0] - shots[1]) > 30, axis=-1).sum()
    assert moved > 2000, moved
    # some link centres of the first time are no longer covered by the arm at the second
    ij = [tuple(int(v) for v in np.rint(p[::-1])) for p in points[0]]
    assert any(not arm(shots[1][i, j]) for i, j in ij)
    assert arm(shots[0]).sum() > 3000    # the arm is drawn big enough to be seen
    # the pen trace grew: more pixels of its colour at the later time
    assert near(shots[1], TRACE, 25).sum() > near(shots[0], TRACE, 25).sum() + 200


def sha(text: str) -> str:
    return "sha256-" + base64.b64encode(hashlib.sha256(text.encode()).digest()).decode()


def test_the_page_is_self_contained_with_a_strict_csp(page, run) -> None:
    html = page.read_text(encoding="utf-8")
    assert re.search(r"https?:|//cdn|<link |src=", html) is None   # nothing from elsewhere
    csp = re.search(r'http-equiv="Content-Security-Policy" content="([^"]+)"', html)
    assert csp is not None
    policy = csp.group(1)
    assert policy.startswith("default-src 'none'; ") and "unsafe" not in policy
    script = re.findall(r"<script>(.*?)</script>", html, re.S)
    style = re.findall(r"<style>(.*?)</style>", html, re.S)
    assert len(script) == 1 and len(style) == 1
    assert f"script-src '{sha(script[0])}'" in policy and f"style-src '{sha(style[0])}'" in policy
    # rrr writing --view wrote the same data (another title) into the result set
    written = (run / "view.html").read_text(encoding="utf-8")
    data = re.search(r'id="run-data">(.*?)</script>', written, re.S)
    assert data is not None and json.loads(data.group(1))["scenarios"][0]["name"] == "ctc"
    summary = json.loads((run / "summary.json").read_text())
    assert "view.html" in summary["files"]


def test_titles_and_data_cannot_break_out_of_the_page(run) -> None:
    table = read_csv_table(run / "ctc.csv")
    html = view_html({"</script><b>x": table}, ROBOT, title="<img src=x onerror=alert(1)>")
    assert "<img" not in html and "</script><b>" not in html
    assert html.count("<script") == 2 and html.count("</script>") == 2


def _view(folder: Path, *extra: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "rrr_robot", "view", str(folder), *extra],
                          capture_output=True, text=True)


def test_a_table_named_like_markup_opens(run: Path, tmp_path: Path) -> None:
    """A table named ``<!--<script>.csv`` (a scenario of that name): the page opens with it
    (before: "<!--" in the embedded data left the page blank while the command succeeded)."""
    folder = tmp_path / "res"
    folder.mkdir()
    name = "<!--<script>"
    shutil.copy(run / "ctc.csv", folder / f"{name}.csv")
    (folder / "summary.json").write_text(json.dumps({"scenarios": {name: {}}}))
    done = _view(folder)
    assert done.returncode == 0, done.stderr
    text = (folder / "view.html").read_text(encoding="utf-8")
    assert "<!--" not in text and text.count("<script") == 2, text[:300]
    s = state(folder / "view.html", "", tmp_path)
    assert s["state"] == "ready" and s["errors"] == "0", s
    assert html.unescape(s["scenario"]) == name, s


@pytest.mark.parametrize("folder_name", ["{{DATA}}", "{{SCRIPT}}", "<h1 a='b'>&x"])
def test_a_folder_named_like_a_placeholder_or_markup_is_only_its_name(
        run: Path, tmp_path: Path, folder_name: str) -> None:
    """A results folder named ``{{DATA}}`` or ``{{SCRIPT}}`` (or markup) is the page's title
    and heading as text: no placeholder is filled twice (before: the page's data or code went
    into its title and heading as raw HTML)."""
    folder = tmp_path / folder_name
    folder.mkdir()
    shutil.copy(run / "ctc.csv", folder / "ctc.csv")
    done = _view(folder)
    assert done.returncode == 0, done.stderr
    text = (folder / "view.html").read_text(encoding="utf-8")
    shown = html.escape(f"rrr view: {folder_name}", quote=True)
    assert f"<title>{shown}</title>" in text and f"<h1>{shown}</h1>" in text
    assert text.count("<script") == 2 and text.count("<h1") == 1
    s = state(folder / "view.html", "", tmp_path)
    assert s["state"] == "ready" and s["errors"] == "0", s


@pytest.mark.parametrize("where", ["parent", "absolute", "link", "option"])
def test_tables_outside_the_folder_are_refused(run: Path, tmp_path: Path, where: str) -> None:
    """summary.json naming ``../outside`` or an absolute path, a table that is a link out of
    the folder, ``--scenario ../outside``: refused, naming it, and no page (before: the table
    was read and its data embedded in the page)."""
    folder = tmp_path / "res"
    folder.mkdir()
    outside = tmp_path / "outside.csv"
    shutil.copy(run / "ctc.csv", outside)
    extra: tuple[str, ...] = ()
    names = {"parent": "../outside", "absolute": str(tmp_path / "outside"), "link": "ctc",
             "option": "ctc"}
    (folder / "summary.json").write_text(json.dumps({"scenarios": {names[where]: {}}}))
    if where == "link":
        (folder / "ctc.csv").symlink_to(outside)
    if where == "option":
        shutil.copy(run / "ctc.csv", folder / "ctc.csv")
        extra = ("--scenario", "../outside")
    done = _view(folder, *extra)
    assert done.returncode == 2, done.stderr
    message = "leads out of" if where == "link" else "cannot name a table in"
    assert message in done.stderr and done.stderr.count("\n") == 1, done.stderr
    assert not (folder / "view.html").exists()


@pytest.mark.parametrize(("files", "message"), [
    ({}, "no result table"),
    ({"ctc.csv": "t,q[1]\n0,0\n"}, r"t and q\[1\], q\[2\], q\[3\]"),
    ({"summary.json": '{"scenarios": {"pd": {}}}'}, "no table pd.csv"),
    ({"summary.json": "[1, 2"}, "not a summary"),
    ({"ctc.csv": "t,q[1],q[2],q[3]\n0,1,2,x\n"}, "not a table of numbers"),
])
def test_bad_folders_are_refused(tmp_path, files, message) -> None:
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    done = subprocess.run([sys.executable, "-m", "rrr_robot", "view", str(tmp_path)],
                          capture_output=True, text=True)
    assert done.returncode != 0 and re.search(message, done.stderr), done.stderr
    assert not (tmp_path / "view.html").exists()
    done = subprocess.run([sys.executable, "-m", "rrr_robot", "view", str(tmp_path / "none")],
                          capture_output=True, text=True)
    assert done.returncode != 0 and "not a folder" in done.stderr


def test_a_diverged_run_beside_another_opens_at_its_last_finite_row(run, tmp_path) -> None:
    """Two scenarios in one page, one of them diverged (NaN from row 3000 on): the page shows
    it up to its last finite row, with no console line, and switches by #scenario=."""
    table = read_csv_table(run / "ctc.csv")
    broken = {k: v.copy() for k, v in table.items()}
    for key in broken:
        if key != "t":
            broken[key][3000:] = np.nan
    page = tmp_path / "two.html"
    page.write_text(view_html({"ctc": table, "diverged": broken}, ROBOT), encoding="utf-8")
    s = state(page, "#scenario=diverged&t=5.5", tmp_path)
    assert s["state"] == "ready" and s["errors"] == "0" and s["scenario"] == "diverged"
    assert abs(float(s["time"]) - table["t"][2999]) < 1e-9
    s = state(page, "", tmp_path)
    assert s["scenario"] == "ctc" and s["frame"] == "0"
    with pytest.raises(rr.BadInputError, match="no row with finite t and q"):
        view_html({"all_nan": {k: np.full_like(v, np.nan) if k != "t" else v
                               for k, v in table.items()}}, ROBOT)


def test_the_title_reads_as_text_and_an_error_norm_never_goes_below_zero(tmp_path) -> None:
    """rrr writing --view of a text on two lines: the page's title joins the lines with " / "
    (it printed the repr, a literal backslash and n); in the browser the strips' ranges hold
    their data, and the tip error's (a norm) starts at 0, not at a padded negative value, while
    a signed signal keeps its margin below its minimum."""
    out = tmp_path / "two-lines"
    subprocess.run([sys.executable, "-m", "rrr_robot", "writing", "--text", "Hi\\nyou",
                    "--scenario", "ctc", "--engine", "native", "--no-figures", "--view",
                    "--out", str(out), "-q"], check=True)
    html = (out / "view.html").read_text(encoding="utf-8")
    title = re.search(r"<title>(.*?)</title>", html, re.S)
    assert title is not None and title.group(1) == "rrr writing: \u201cHi / you\u201d"
    assert "\\n" not in title.group(1) and re.search(r"<h1>rrr writing: \u201cHi / you", html)
    s = state(out / "view.html", "#scenario=ctc", tmp_path)
    assert s["state"] == "ready" and s["errors"] == "0"
    ranges = {title: (lo, hi) for title, lo, hi in json.loads(s["ranges"])}
    table = read_csv_table(out / "ctc.csv")
    err = 1e3 * np.linalg.norm(np.stack([table[f"tip.{a}"] - table[f"x_ref.{a}"]
                                         for a in "xyz"], axis=1), axis=1)
    lo, hi = ranges["tip error |tip - x_ref| (mm)"]
    assert lo == 0.0 and hi >= err.max() * (1 - 1e-6)
    u1 = table["u[1]"]   # a signed voltage: its range has room below its minimum
    lo, hi = ranges["voltage u (V)"]
    assert lo < min(table["u[1]"].min(), table["u[2]"].min(), table["u[3]"].min()) < 0 < hi
    assert u1.max() <= hi
