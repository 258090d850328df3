"""The repository's habits: the licence that pyproject declares is the LICENSE file's, the
pre-commit hooks run the checks of the test command, CONTRIBUTING names the fast subset."""

from __future__ import annotations

import tomllib

from support import REPO

ROOT = REPO


def test_the_license_file_is_the_declared_one() -> None:
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["license"]
    assert declared == {"text": "BSD-3-Clause"}
    text = (ROOT / "LICENSE").read_text()
    assert text.startswith("BSD 3-Clause License\n")
    assert "Neither the name of the copyright holder" in text


def test_pre_commit_runs_what_the_test_command_checks() -> None:
    hooks = (ROOT / ".pre-commit-config.yaml").read_text()
    script = (ROOT / "scripts" / "run_tests.sh").read_text()
    entries = [line.split("entry:", 1)[1].strip() for line in hooks.splitlines()
               if line.strip().startswith("entry:")]
    assert sorted(e.split()[0] for e in entries) == ["lint-imports", "mypy", "ruff"]
    for entry in entries:
        assert entry in script, f"pre-commit runs {entry!r}, the test command does not"


def test_contributing_names_the_fast_subset_and_the_markers() -> None:
    text = (ROOT / "CONTRIBUTING.md").read_text()
    assert 'python -m pytest -m "not slow" tests/python' in text
    markers = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"][
        "ini_options"]["markers"]
    for marker in markers:
        assert f"`{marker.split(':')[0]}`" in text


def test_bench_scripts_share_their_timing_helpers() -> None:
    """bench/_timing.py is the one home of the clocks, the interleaved blocks, the min / median /
    max series and the progress log: no bench script writes its own again."""
    import re

    own = re.compile(r"^(def (mmm|log|interleaved)\(|class Series\b|CLOCKS(_S)?\s*[:=]\s*(dict|\{))"
                     r"|^import statistics\b", re.M)
    scripts = sorted((ROOT / "bench").glob("*.py"))
    found = {p.name: own.findall(p.read_text()) for p in scripts if p.name != "_timing.py"}
    assert {name: hits for name, hits in found.items() if hits} == {}
    benches = [p for p in scripts if p.name.startswith("bench_") or p.name == "run_bench.py"]
    assert len(benches) >= 5
    assert [p.name for p in benches if "from _timing import" not in p.read_text()] == []


def test_no_test_bounds_the_wall_clock() -> None:
    """A busy machine makes a test slower, never red: no assertion compares an elapsed wall-clock
    time with an upper bound (a timeout far above a quiet run, a lower bound for a timeout, or
    a printed figure instead; the benchmarks measure)."""
    import re

    clock = re.compile(r"^\s*assert\b.*\b(monotonic|perf_counter|time)\(\)\s*-\s*\w+\s*<")
    elapsed = re.compile(r"^\s*assert\b.*(\b(took|elapsed|seconds|guest_seconds)\b|"
                         r"-\s*(start|sent|t0|begin)\b)\s*<|^\s*CHECK\(.*\b(took|elapsed)\b\s*<")
    found = []
    for path in sorted([*(ROOT / "tests").rglob("*.py"), *(ROOT / "tests").rglob("*.c")]):
        for n, line in enumerate(path.read_text(errors="replace").splitlines(), start=1):
            if clock.search(line) or elapsed.search(line):
                found.append(f"{path.relative_to(ROOT)}:{n}: {line.strip()}")
    assert found == []
