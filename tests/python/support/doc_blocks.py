"""The fenced blocks of README.md and docs/**/*.md, and how the docs test runs them.

What a block's info string (the words after the opening fence) means:

- ``bash``, ``sh``: run as one script, ``bash -euo pipefail``;
- ``console``: a terminal session. Lines starting with ``$ `` are commands (a trailing ``\\``
  continues one on the next line), the other lines are what they print: each printed line must
  appear in the output, in order, where ``...`` stands for any text. A command may fail only if
  the next command is ``echo $?`` (which then prints its status). A console block whose first
  line is ``# not run here: <reason>`` is not run (tests/python/docs/blocks/test_doc_blocks.py lists
  every such block: adding one means adding it there);
- ``python``: run with this interpreter in a fresh process;
- ``text output``: the lines that the runnable block before it prints, in that order, with
  ``...`` for any text (a plain ``text`` block is not run);
- ``<language> file=NAME`` (``c``, ``toml``, ``python``, ...): written to NAME in the working
  folder before the next blocks run (a C quick start's program, a scenario file), not run
  itself;
- not run: the languages in :data:`NOT_RUN` (listings, file formats, signatures).

A table with a column headed "example" (the README's table of the ``rrr`` commands): each
```` `rrr ...` ```` code span in that column is run as a ``bash`` block where its row stands; an
extra the row's example names (``'.[sweep]'``) is installed for its commands, as is one a block
names (see below).

Any other language, and a fence without one, is an error: every block is either run or one of
the kinds above. Directives of MyST (```` ```{toctree} ````) are not code blocks.

All blocks of one page run in order in one working folder (a later block can use what an
earlier one wrote), with HOME in that folder, the repository's top-level files and folders
linked into it (so ``examples/...``, ``python/rrr_robot/data/...`` and ``scripts/...`` resolve
as in a clone) and this interpreter's ``bin`` first on PATH (the ``rrr`` command of the venv).

The README's blocks run "after the first command": with :func:`installed_only`, Python imports
only what the first command's ``pip install`` (scripts/setup_env.sh's default target) installs,
and a block (a table row's commands) also what the extras it names install; any other module of
this venv (the test tools, the other extras) is missing for them as on a user's machine.
"""

from __future__ import annotations

import importlib.metadata as md
import os
import re
import subprocess
import sys
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from packaging.requirements import Requirement
from packaging.utils import canonicalize_name

from support import REPO

ROOT = REPO
SHELL = frozenset({"bash", "sh"})
NOT_RUN = frozenset({"text", "toml", "json", "csv", "ini", "c", "cmake", "xml", "dbc", "diff",
                     "yaml", "none", "math"})
#: Top-level entries of the repository never linked into a working folder (build outputs,
#: results of earlier runs, caches).
NOT_LINKED = re.compile(r"^(\.git|\.venv|build.*|results|out|dist|_skbuild|\..*cache)$")
FENCE = re.compile(r"^(?P<indent> {0,3}|\s*)(?P<fence>`{3,}|~{3,})(?P<info>[^`]*)$")
NOT_RUN_HERE = "# not run here:"


@dataclass
class Block:
    """One fenced block: its page, first line number (1-based), language, flags and text."""

    page: str
    line: int
    lang: str
    flags: dict[str, str]
    text: str

    @property
    def where(self) -> str:
        return f"{self.page}:{self.line}"

    @property
    def file(self) -> str | None:
        return self.flags.get("file")

    @property
    def not_run_here(self) -> str | None:
        """The reason of a ``# not run here: <reason>`` console block, else None."""
        first = self.text.split("\n", 1)[0].strip()
        if self.lang == "console" and first.startswith(NOT_RUN_HERE):
            return first[len(NOT_RUN_HERE):].strip()
        return None

    @property
    def extras(self) -> str:
        """The extras a block installs first (``'.[docs]'`` in it, or in its table row)."""
        if "table" in self.flags:
            return self.flags.get("extras", "")
        return ",".join(re.findall(r"\.\[([\w,-]+)\]", self.text))

    @property
    def kind(self) -> str:
        """run, output, file, not-run-here, listing or unknown."""
        if self.file is not None:
            return "file"
        if self.lang in SHELL or self.lang == "python":
            return "run"
        if self.lang == "console":
            return "not-run-here" if self.not_run_here is not None else "run"
        if self.lang == "text" and "output" in self.flags:
            return "output"
        if self.lang in NOT_RUN:
            return "listing"
        return "unknown"


def doc_pages() -> list[Path]:
    """README.md and every Markdown page of docs/."""
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def blocks_of(path: Path) -> list[Block]:
    """The fenced blocks of a Markdown page (MyST directives left out)."""
    page = str(path.relative_to(ROOT))
    lines = path.read_text(encoding="utf-8").split("\n")
    out: list[Block] = []
    example_col: int | None = None
    i = 0
    while i < len(lines):
        m = FENCE.match(lines[i])
        if m is None:
            example_col = _table_row(page, lines, i, example_col, out)
            i += 1
            continue
        example_col = None
        indent, fence, info = len(m["indent"]), m["fence"], m["info"].strip()
        start = i
        body: list[str] = []
        i += 1
        while i < len(lines):
            close = lines[i].strip()
            if close.startswith(fence[0] * len(fence)) and set(close) == {fence[0]}:
                break
            body.append(lines[i][indent:] if lines[i][:indent].strip() == "" else lines[i])
            i += 1
        i += 1
        if info.startswith("{"):
            continue  # a directive ({toctree}, {note}, ...)
        words = info.split()
        lang = words[0].lower() if words else ""
        flags: dict[str, str] = {}
        for word in words[1:]:
            key, _, value = word.partition("=")
            flags[key] = value
        out.append(Block(page, start + 1, lang, flags, "\n".join(body) + "\n"))
    return out


def _cells(line: str) -> list[str]:
    return [c.strip() for c in re.split(r"(?<!\\)\|", line.strip().strip("|"))]


def _table_row(page: str, lines: list[str], i: int, example_col: int | None,
               out: list[Block]) -> int | None:
    """Tables with an "example" column: each `rrr ...` code span in it is a command, run where
    the row stands. Returns the example column of the table line i is in (None outside)."""
    line = lines[i]
    if not line.lstrip().startswith("|"):
        return None
    if i + 1 < len(lines) and re.match(r"^\s*\|[\s:|-]+\|\s*$", lines[i + 1]):
        header = [c.lower() for c in _cells(line)]
        return header.index("example") if "example" in header else None
    if example_col is None or re.match(r"^\s*\|[\s:|-]+\|\s*$", line):
        return example_col
    cells = _cells(line)
    if example_col < len(cells):
        extras = ",".join(re.findall(r"\.\[([\w,-]+)\]", cells[example_col]))
        for cmd in re.findall(r"`(rrr [^`]*)`", cells[example_col]):
            out.append(Block(page, i + 1, "bash", {"table": "", "extras": extras},
                             cmd.replace("\\|", "|") + "\n"))
    return example_col


def all_blocks() -> list[Block]:
    return [b for page in doc_pages() for b in blocks_of(page)]


# ---------------------------------------------------------------------------------------------
# what the README's first command installs


def first_command_target() -> str:
    """The pip target of the README's first command: scripts/setup_env.sh's default."""
    text = (ROOT / "scripts/setup_env.sh").read_text(encoding="utf-8")
    found = re.search(r'RRR_PIP_TARGET:-([^}"]+)\}', text)
    assert found, "scripts/setup_env.sh: no default RRR_PIP_TARGET"
    return found[1]


def closure(requirements: list[str]) -> set[str]:
    """The distributions these requirements pull in (installed ones; their extras ignored)."""
    seen: set[str] = set()
    todo = [Requirement(r) for r in requirements]
    while todo:
        req = todo.pop()
        name = canonicalize_name(req.name)
        if name in seen or (req.marker is not None and not req.marker.evaluate({"extra": ""})):
            continue
        seen.add(name)
        try:
            todo += [Requirement(r) for r in (md.requires(req.name) or [])]
        except md.PackageNotFoundError:
            pass
    return seen


_SITECUSTOMIZE = '''"""Written by tests/python/support/doc_blocks.py: imports of modules that
`pip install {target}` does not install (nor an extra named in RRR_DOC_EXTRAS) fail, as on a
user's machine."""
import os
import sys

OWNERS = {owners!r}
INSTALLED = {installed!r}
EXTRAS = {extras!r}
_allowed = set(INSTALLED)
for _extra in filter(None, os.environ.get("RRR_DOC_EXTRAS", "").split(",")):
    _allowed |= set(EXTRAS[_extra])
_blocked = {{m for m, dists in OWNERS.items() if not set(dists) & _allowed}}


class _NotInstalled:
    @staticmethod
    def find_spec(name, path=None, target=None):
        top = name.partition(".")[0]
        if top in _blocked:
            raise ModuleNotFoundError(
                f"No module named {{top!r}}: the README's first command (pip install "
                f"{target}) does not install it (its distributions: {{OWNERS[top]}})",
                name=top)
        return None


sys.meta_path.insert(0, _NotInstalled)
'''


def _top_level_owners() -> dict[str, set[str]]:
    """Top-level module -> the distributions that install it, from their RECORD files (also a
    cmeel wheel's modules, which it installs under cmeel.prefix/lib/pythonX.Y/site-packages)."""
    owners: dict[str, set[str]] = {}
    for dist in md.distributions():
        name = canonicalize_name(dist.metadata["Name"])
        for line in (dist.read_text("RECORD") or "").splitlines():
            parts = line.rsplit(",", 2)[0].split("/")
            if parts[0] == "cmeel.prefix" and "site-packages" in parts:
                parts = parts[parts.index("site-packages") + 1:]
            if len(parts) == 1 and not parts[0].endswith((".py", ".so")):
                continue  # a file at the top that is no module (a .pth, a data file)
            top = parts[0].split(".")[0] if len(parts) == 1 else parts[0]
            if top.isidentifier():
                owners.setdefault(top, set()).add(name)
    return owners


def installed_only(folder: Path) -> dict[str, str]:
    """Environment variables under which Python imports only what the README's first command
    installs (rrr_robot, its dependencies and the extras of its target, with their
    requirements), plus the extras listed in RRR_DOC_EXTRAS: a ``sitecustomize`` in ``folder``
    makes every other module of this venv's distributions missing."""
    target = first_command_target()
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    optional = project["optional-dependencies"]
    chosen = re.fullmatch(r"\.(?:\[([\w,-]*)\])?", target)
    assert chosen, f"the first command's target {target!r} is not '.' or '.[extras]'"
    requirements = list(project["dependencies"])
    for extra in filter(None, (chosen[1] or "").split(",")):
        requirements += optional[extra]
    installed = closure(requirements) | {"rrr-robot", "pip", "setuptools"}  # and the venv's own
    extras = {name: sorted(closure(reqs)) for name, reqs in optional.items()}
    owners = {module: sorted(dists) for module, dists in _top_level_owners().items()
              if module not in sys.stdlib_module_names and not module.startswith("_")}
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "sitecustomize.py").write_text(_SITECUSTOMIZE.format(
        target=target, owners=owners, installed=sorted(installed), extras=extras),
        encoding="utf-8")
    return {"PYTHONPATH": str(folder)}


# ---------------------------------------------------------------------------------------------
# running


def pattern(expected: str) -> re.Pattern[str]:
    """A shown output line as a pattern: ``...`` is any text, surrounding blanks are free."""
    parts = [re.escape(p) for p in expected.strip().split("...")]
    return re.compile(r"\s*" + ".*".join(parts) + r"\s*$")


def check_output(shown: list[str], printed: str, where: str) -> None:
    """Every shown line (blank ones and lines of only ``...`` aside) matches a printed line
    (stdout and stderr as they came), in order."""
    lines = iter(printed.splitlines())
    for want in (s for s in shown if s.strip() not in ("", "...")):
        pat = pattern(want)
        if not any(pat.match(line) for line in lines):
            raise AssertionError(f"{where}: the block shows the line\n    {want}\nwhich its "
                                 f"commands did not print (in this order); they printed:\n"
                                 f"{printed}")


def console_commands(text: str) -> list[tuple[str, list[str]]]:
    """A console block as (command, shown output lines) pairs."""
    out: list[tuple[str, list[str]]] = []
    lines = text.rstrip("\n").split("\n")
    i = 0
    while i < len(lines):
        line = lines[i]
        if line.startswith("$ "):
            cmd = line[2:]
            while cmd.endswith("\\") and i + 1 < len(lines):
                i += 1
                cmd = cmd + "\n" + lines[i]
            out.append((cmd, []))
        elif out:
            out[-1][1].append(line)
        elif line.strip() and not line.startswith("#"):
            raise AssertionError(f"console block: output before the first command: {line!r}")
        i += 1
    return out


@dataclass
class Workdir:
    """The working folder of one page's blocks."""

    path: Path
    env: dict[str, str] = field(default_factory=dict)

    @classmethod
    def make(cls, path: Path, extra_env: dict[str, str]) -> Workdir:
        path.mkdir(parents=True, exist_ok=True)
        for entry in ROOT.iterdir():
            if not NOT_LINKED.match(entry.name) and not (path / entry.name).exists():
                (path / entry.name).symlink_to(entry)
        venv = path / ".venv"  # scripts/setup_env.sh activates the venv of this interpreter
        if not venv.exists():
            venv.symlink_to(Path(sys.executable).parent.parent)
        home = path / "home"
        home.mkdir(exist_ok=True)
        env = dict(os.environ)
        bindir = str(Path(sys.executable).parent)
        env.update({
            "HOME": str(home),
            "PATH": bindir + os.pathsep + env.get("PATH", ""),
            "MPLBACKEND": "Agg",
            "PYTHONDONTWRITEBYTECODE": "1",
            "VIRTUAL_ENV": str(Path(sys.executable).parent.parent),
        })
        env.pop("PYTHONPATH", None)
        env.update(extra_env)
        return cls(path, env)

    def run(self, args: list[str], where: str, timeout: float,
            stdin: str | None = None) -> subprocess.CompletedProcess[str]:
        try:
            return subprocess.run(args, cwd=self.path, env=self.env, input=stdin,
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                  timeout=timeout)
        except subprocess.TimeoutExpired as exc:
            raise AssertionError(f"{where}: still running after {timeout:.0f} s (a docs block "
                                 "must be short: use a short-duration option)") from exc


def run_block(block: Block, work: Workdir, timeout: float) -> str:
    """Run one runnable block; returns what it printed. Raises AssertionError when it fails."""
    if block.lang in SHELL:
        res = work.run(["bash", "-euo", "pipefail", "-c", block.text], block.where, timeout)
        printed = res.stdout
        if res.returncode != 0:
            raise AssertionError(f"{block.where}: the {block.lang} block exited with "
                                 f"{res.returncode}:\n{block.text}\n--- printed:\n{printed}")
        return printed
    if block.lang == "python":
        res = work.run([sys.executable, "-"], block.where, timeout, stdin=block.text)
        printed = res.stdout
        if res.returncode != 0:
            raise AssertionError(f"{block.where}: the python block exited with "
                                 f"{res.returncode}:\n{block.text}\n--- printed:\n{printed}")
        return printed
    assert block.lang == "console", block
    printed_all = ""
    commands = console_commands(block.text)
    if not commands:
        raise AssertionError(f"{block.where}: a console block without a '$ ' command")
    status = 0
    for k, (cmd, shown) in enumerate(commands):
        script = cmd if cmd.strip() != "echo $?" else f"echo {status}"
        res = work.run(["bash", "-o", "pipefail", "-c", script], block.where, timeout)
        printed = res.stdout
        status = res.returncode
        checked_next = k + 1 < len(commands) and commands[k + 1][0].strip() == "echo $?"
        if status != 0 and not checked_next:
            raise AssertionError(f"{block.where}: '$ {cmd}' exited with {status} (a command "
                                 f"that is meant to fail is followed by '$ echo $?'):\n"
                                 f"{printed}")
        check_output(shown, printed, f"{block.where}: $ {cmd}")
        printed_all += printed
    return printed_all
