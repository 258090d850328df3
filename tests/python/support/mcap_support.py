"""The MCAP files of the tests read back by a reader we do not write with (rosbags), shared by
jobs/test_mcap.py (``rrr writing --mcap``) and can/test_hil_results.py (``rrr hil bench
--mcap``)."""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.highlevel import AnyReader


def rosbags_messages(path: Path) -> tuple[dict[str, list[tuple[int, Any, bytes]]], Any]:
    with AnyReader([path]) as reader:
        got: dict[str, list[tuple[int, Any, bytes]]] = defaultdict(list)
        for conn, stamp, raw in reader.messages():
            got[conn.topic].append((stamp, reader.deserialize(raw, conn.msgtype), raw))
        return got, reader.typestore


def same(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True))
