"""Every command and code block of README.md and docs/ runs as written (support/doc_blocks.py
says how each kind of block is run): a block fails the test when it fails, when its
shown output is not what it prints, or when it is of no known kind; the blocks that cannot run
here are listed below, each with its reason."""

from __future__ import annotations

import dataclasses
import os
import subprocess
import sys
import time
from collections.abc import Iterator
from concurrent.futures import Future, ThreadPoolExecutor
from pathlib import Path

import pytest
from support.doc_blocks import (
    ROOT,
    Block,
    Workdir,
    all_blocks,
    blocks_of,
    check_output,
    doc_pages,
    installed_only,
    run_block,
)

#: The blocks marked ``# not run here: <reason>``: (page, first command). A new one must be
#: added here (and its reason be one a reader accepts: hardware or privileges this machine
#: lacks, or a command that the test command itself runs elsewhere: the test command, the
#: builds it makes and the tests it runs).
NOT_RUN_HERE = {
    ("README.md", "bash scripts/run_tests.sh"),
    # the manual's build: a stage of the test command (scripts/run_tests.sh), run once there
    ("README.md", "pip install -q sphinx myst-parser furo breathe   # or '.[docs]'; and Doxygen "
                  "(apt-get install doxygen)"),
    ("docs/aarch64.md",
     "cmake -S . -B build-aarch64 -DCMAKE_TOOLCHAIN_FILE=cmake/aarch64-linux-gnu.cmake"),
    ("docs/aarch64.md", "ctest --test-dir build -R aarch64 --output-on-failure"),
    ("docs/can-bench.md", "sudo ip link set can0 up type can bitrate 1000000"),
    # a kernel with AF_CAN and root (the tests run the same in a QEMU guest), an adapter
    ("docs/socketcan.md", "modprobe vcan"),
    ("docs/socketcan.md", "ip link add dev vcan1 type vcan"),
    ("docs/socketcan.md", "rrr_hil_plant --fmu DIR --socketcan vcan0 --log plant.csv &    "
                          "# DIR: the unzipped plant FMU"),
    ("docs/socketcan.md", "ip link set can0 type can bitrate 1000000 restart-ms 100   "
                          "# 1 Mbit/s; restart after bus-off"),
    ("docs/canopen.md", "sudo ip link add dev vcan0 type vcan && sudo ip link set vcan0 up"),
    ("docs/c-library.md", "cmake -S . -B build && cmake --build build -j2"),
    # the release folder: scripts/test_dist.sh (a stage of the test command) builds it, then
    # installs its x86-64 wheel in a venv without a compiler and runs it
    ("docs/getting-started.md", "python3 -m venv venv && . venv/bin/activate"),
    ("docs/getting-started.md", "bash scripts/dist.sh"),
    ("docs/sweeps.md", "dask scheduler --host 0.0.0.0 --port 8786"),
    # the firmware: scripts/test_pil.sh builds it in the test command and
    # tests/python/can/test_hil_pil.py runs both images with rrr hil pil; a board and its probe
    ("docs/microcontroller.md", "cmake -S c_src/firmware -B build-firmware"),
    ("docs/microcontroller.md",
     'openocd -f board/st_nucleo_f7.cfg -c "program build-firmware/rrr_pil_m7.elf verify reset '
     'exit"'),
    # minutes of measurement (its --quick mode runs in the test command)
    ("docs/performance.md",
     "python bench/bench_sweep.py --engine fmpy --sizes 10,100 --runs 100 --repeats 3 --skip-big"),
}
#: Seconds one block may take (the longest is the README's first command, about 15 s here).
BLOCK_TIMEOUT = 120.0
#: Pages run side by side (RRR_DOC_TEST_JOBS; default: the CPUs, at most 2).
JOBS = int(os.environ.get("RRR_DOC_TEST_JOBS", "0")) or min(2, os.cpu_count() or 1)
#: Environment of the blocks: scripts/setup_env.sh skips its pip install (the test command
#: installed the package into this venv just before), so `bash scripts/writing_task.sh` runs
#: the writing task itself.
BLOCK_ENV = {"RRR_SKIP_INSTALL": "1"}


def _pages_with_runnable_blocks() -> list[str]:
    return [str(p.relative_to(ROOT)) for p in doc_pages()
            if any(b.kind in ("run", "file") for b in blocks_of(p))]


def _first_command(block: Block) -> str:
    for line in block.text.split("\n"):
        if line.startswith("$ "):
            return line[2:].rstrip(" \\").strip()
    return ""


def test_every_block_is_run_or_of_a_known_kind() -> None:
    problems = []
    blocks = all_blocks()
    assert len(blocks) > 50
    for k, b in enumerate(blocks):
        if b.kind == "unknown":
            lang = b.lang or "(none)"
            problems.append(f"{b.where}: a block of language {lang}: neither run nor a known "
                            "listing (tests/python/support/doc_blocks.py lists the kinds)")
        if b.kind == "output":
            before = next((x for x in reversed(blocks[:k]) if x.page == b.page
                           and x.kind in ("run", "output")), None)
            if before is None or before.kind != "run":
                problems.append(f"{b.where}: a 'text output' block must follow a runnable one")
    assert not problems, "\n".join(problems)


def test_not_run_here_blocks_are_listed() -> None:
    found = {(b.page, _first_command(b)): b.not_run_here for b in all_blocks()
             if b.kind == "not-run-here"}
    for (page, cmd), reason in sorted(found.items()):
        print(f"not run here: {page}: $ {cmd}  ({reason})")
        assert reason, f"{page}: '# not run here:' needs a reason"
    assert set(found) == NOT_RUN_HERE


def test_page_runnable_block_count() -> None:
    # the README's quick starts are among the runnable blocks
    kinds = [b.kind for b in blocks_of(ROOT / "README.md")]
    assert kinds.count("run") >= 4 and "file" in kinds


def test_the_readme_imports_only_what_the_first_command_installs(tmp_path: Path) -> None:
    """The README's blocks run "after the first command": rrr_robot and its dependencies (the
    reference of Figs 5 and 6 among them) import; the test tools, the references of the tests
    and the other extras do not, unless a block names its extra."""
    env = {**os.environ, **installed_only(tmp_path)}

    def imports(module: str, extras: str = "") -> bool:
        code = f"import {module}"
        return subprocess.run([sys.executable, "-c", code], env={**env, "RRR_DOC_EXTRAS": extras},
                              capture_output=True, check=False).returncode == 0

    assert all(imports(m) for m in ("rrr_robot.cli", "mujoco", "fmpy", "can", "matplotlib"))
    assert not any(imports(m) for m in ("pytest", "pinocchio", "roboticstoolbox", "dask"))
    assert imports("dask", "sweep") and imports("sphinx", "docs")
    assert [b.extras for b in blocks_of(ROOT / "README.md") if "rrr sweep" in b.text] == \
        ["sweep", "sweep"]


def run_page(page: str, folder: Path) -> str:
    """Run the blocks of one page in order in a working folder; returns its log (what ran, how
    long). Raises AssertionError at the first block that fails."""
    env = dict(BLOCK_ENV)
    if page == "README.md":  # "after the first command": only what it installs is importable
        env |= installed_only(folder.parent / "first-command-site")
    work = Workdir.make(folder, env)
    log = []
    printed = ""
    t0 = time.monotonic()
    for block in blocks_of(ROOT / page):
        if block.kind == "file":
            assert block.file, f"{block.where}: file= needs a name"
            target = work.path / block.file
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(block.text, encoding="utf-8")
        elif block.kind == "run":
            t = time.monotonic()
            # the extras a block (a table row's example) names and installs first
            here = dataclasses.replace(work, env={**work.env, "RRR_DOC_EXTRAS": block.extras})
            printed = run_block(block, here, BLOCK_TIMEOUT)
            log.append(f"{block.where}: {block.lang} block ran in {time.monotonic() - t:.1f} s")
        elif block.kind == "output":
            check_output(block.text.split("\n"), printed, block.where)
    log.append(f"{page}: every block ran in {time.monotonic() - t0:.1f} s")
    return "\n".join(log)


@pytest.fixture(scope="module")
def page_runs(tmp_path_factory: pytest.TempPathFactory) -> Iterator[dict[str, Future[str]]]:
    """Every page's blocks, started at once on JOBS threads (the blocks are processes: the
    pages run side by side, each in order in its own folder); each test waits for its page."""
    pages = _pages_with_runnable_blocks()
    with ThreadPoolExecutor(max_workers=JOBS) as pool:
        futures = {page: pool.submit(run_page, page, tmp_path_factory.mktemp("doc") / "work")
                   for page in pages}
        yield futures
        for future in futures.values():
            future.cancel()


@pytest.mark.parametrize("page", _pages_with_runnable_blocks())
def test_runnable_blocks_of_page(page: str, page_runs: dict[str, Future[str]]) -> None:
    print(page_runs[page].result())
