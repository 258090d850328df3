"""Write the table that the packaged reference FMU ships, fmu/reference/resources/reference.csv:
the default writing task's start pose held at rest for 1 s (rrr_robot.ssp.table
.placeholder_columns). tests/python/jobs/test_ssp.py checks that the committed file is what this
writes.

Usage: python tools/make_reference_table.py [OUT]   (default: the committed file)
"""

from __future__ import annotations

import sys
from pathlib import Path

from rrr_robot.core.tables import write_csv
from rrr_robot.ssp.table import placeholder_columns
from rrr_robot.writing.job import WritingJob, prepare

DEFAULT = Path(__file__).resolve().parents[1] / "fmu" / "reference" / "resources" / "reference.csv"


def main() -> int:
    out = Path(sys.argv[1]) if len(sys.argv) > 1 else DEFAULT
    ref = prepare(WritingJob(out=out.parent, scenarios=["ctc"], figures=False)).reference
    write_csv(out, placeholder_columns(ref))
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
