"""Shared helpers: the data folder, the command-line binary, and skips that say why.

A case that needs the shared scans (``OCTOWRAP_DATA``, default ``../shared/data`` beside the
repository root) or a missing tool prints a line starting with ``SKIPPED`` and is skipped; with
``OCTOWRAP_REQUIRE_DATA=1`` (set by ``.ci/run`` when the data is present) a missing data file fails
instead, so a case cannot pass by not running.
"""

import os
import shutil
import threading
import time
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[3]


def skip(reason: str) -> None:
    print(f"SKIPPED {reason}")
    pytest.skip(reason)


def data(relative: str) -> Path:
    """The file or folder ``relative`` under the data folder, or a skip (a failure when required)."""
    root = Path(os.environ.get("OCTOWRAP_DATA", REPO / ".." / "shared" / "data"))
    path = root / relative
    if not path.exists():
        if os.environ.get("OCTOWRAP_REQUIRE_DATA") == "1":
            pytest.fail(f"{path} is missing and OCTOWRAP_REQUIRE_DATA=1")
        skip(f"{path} is missing (set OCTOWRAP_DATA)")
    return path


def octowrap_bin() -> Path:
    """The command line: ``$OCTOWRAP_BIN``, else ``target/release/octowrap``, else ``octowrap`` on PATH."""
    named = os.environ.get("OCTOWRAP_BIN")
    candidates = [Path(named)] if named else [REPO / "target" / "release" / "octowrap"]
    if not named and shutil.which("octowrap"):
        candidates.append(Path(shutil.which("octowrap")))
    for c in candidates:
        if c.is_file() and os.access(c, os.X_OK):
            return c
    skip(f"no octowrap binary at {', '.join(map(str, candidates))} (set OCTOWRAP_BIN)")
    raise AssertionError("unreachable")


def sphere(n: int, seed: int = 1):
    """``n`` points on the unit sphere, float64 (N, 3)."""
    import numpy as np

    p = np.random.default_rng(seed).normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1, keepdims=True)


def ticks_during(work, min_seconds=0.3):
    """Ticks of a thread that sleeps 1 ms per tick while ``work()`` runs (called again until
    ``min_seconds`` have passed, so a fast machine still gives enough time to tell), the seconds it
    took, and the ticks per second the same thread makes while nothing runs (the machine's load
    slows it)."""
    ticks = 0
    stop = threading.Event()

    def count():
        nonlocal ticks
        while not stop.is_set():
            ticks += 1
            time.sleep(0.001)

    t = threading.Thread(target=count)
    t.start()
    time.sleep(0.05)
    before = ticks
    start = time.perf_counter()
    work()
    while time.perf_counter() - start < min_seconds:
        work()
    seconds = time.perf_counter() - start
    during = ticks - before
    idle_start, idle_seconds = ticks, min(seconds, 1.0)
    time.sleep(idle_seconds)
    idle_rate = (ticks - idle_start) / idle_seconds
    stop.set()
    t.join()
    return during, seconds, idle_rate


def assert_gil_released(work, name):
    """``work()`` lets other Python threads run: one that ticks gets at least a tenth of its idle
    ticks while it runs, where calls holding the GIL leave it next to none."""
    during, seconds, idle_rate = ticks_during(work)
    assert during >= max(5, idle_rate * seconds / 10), (name, during, seconds, idle_rate)
