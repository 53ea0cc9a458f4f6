"""examples/bunny_levels.py prints the per-level error table and writes its plot."""

import importlib.util
import os
import subprocess
import sys

from conftest import REPO, data, skip


def test_bunny_levels_prints_the_table_and_writes_the_plot(tmp_path):
    data("stanford-bunny/reconstruction/bun_zipper.ply")
    missing = [m for m in ("trimesh", "rtree", "scipy", "matplotlib") if importlib.util.find_spec(m) is None]
    if missing:
        skip(f"the example needs {', '.join(missing)} (pip install {' '.join(missing)})")
    script = REPO / "crates" / "python" / "examples" / "bunny_levels.py"
    run = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=600, env=os.environ)
    assert run.returncode == 0, run.stderr
    lines = run.stdout.splitlines()
    start = lines.index("level     faces  RMS / diagonal  paper (Table 3)")
    rows = [line.split() for line in lines[start + 1 :] if line.split() and line.split()[0].isdigit()]
    assert [int(r[0]) for r in rows] == list(range(1, len(rows) + 1)) and len(rows) >= 4
    errors = [float(r[2]) for r in rows]
    assert all(a > b for a, b in zip(errors, errors[1:])), errors
    assert 0.0 < errors[-1] < 0.005 < errors[0] < 0.05, errors
    assert lines[-1] == "plot: bunny_levels.png"
    assert (tmp_path / "bunny_levels.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
