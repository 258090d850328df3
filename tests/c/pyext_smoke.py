#!/usr/bin/env python3
"""CTest pyext_smoke: the extension module of a CMake build (rrr_robot.core._ext) on the package
sources, before any pip install.

Stages python/rrr_robot with the built _ext module and librrr.so into a temporary folder and runs
the binding's tests (tests/python/unit/test_ext_binding.py: every method's batches against its rows
bit for bit, the refusals, batches without the GIL and from threads), the Model API tests and
the plant step's (tests/python/unit/test_plant_api.py) on it.
In the sanitizer build CMake runs this under the preloaded ASan runtime, so ASan and UBSan check
the module's C code and the librrr it links.

Usage: pyext_smoke.py --package python/rrr_robot --ext <_ext...so> --lib <librrr.so>
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
TESTS = ["tests/python/unit/test_ext_binding.py", "tests/python/unit/test_model_api.py",
         "tests/python/unit/test_plant_api.py"]


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--package", type=Path, required=True)
    parser.add_argument("--ext", type=Path, required=True)
    parser.add_argument("--lib", type=Path, required=True)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="rrr-pyext-") as tmp:
        pkg = Path(tmp) / "rrr_robot"
        shutil.copytree(args.package, pkg, ignore=shutil.ignore_patterns("__pycache__", "*.so"))
        shutil.copy2(args.ext, pkg / "core" / args.ext.name)
        shutil.copy2(args.lib, pkg / "librrr.so")
        # the version, as the wheel carries it (the staged copy is outside the source tree, so
        # core/_version.py cannot read c_src/rrr/include/rrr/rrr_version.h beside it)
        header = ROOT / "c_src" / "rrr" / "include" / "rrr" / "rrr_version.h"
        version = re.findall(r'^#define RRR_VERSION_STRING "([^"]+)"$',
                             header.read_text(encoding="utf-8"), re.M)
        (pkg / "core" / "_build_version.py").write_text(f'version = "{version[0]}"\n')
        env = {**os.environ, "PYTHONPATH": tmp, "PYTHONDONTWRITEBYTECODE": "1"}
        where = subprocess.run(
            [sys.executable, "-c", "import rrr_robot.core.model as m, rrr_robot.core._ext as e; "
             "print(type(m.Model.default()._k) is e.Kernels, e.__file__)"],
            env=env, check=False, capture_output=True, text=True)
        if where.returncode != 0:
            print(f"pyext_smoke: the staged modules do not import:\n{where.stderr}",
                  file=sys.stderr)
            return 1
        uses_it, module = where.stdout.split()
        print(f"pyext_smoke: module {module}", flush=True)
        if uses_it != "True" or not module.startswith(tmp):
            print("pyext_smoke: the staged extension module was not the one imported",
                  file=sys.stderr)
            return 1
        return subprocess.run(
            [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", *TESTS],
            env=env, cwd=ROOT, check=False).returncode


if __name__ == "__main__":
    sys.exit(main())
