"""Reconstructs the Stanford bunny and prints each level's points-to-mesh RMS error.

The error is the root mean square of the distance from every input point to the level's surface
(its quads split into triangles), relative to the diagonal of the points' bounding box, computed
with trimesh's proximity query (pip install trimesh rtree scipy), beside the paper's Table 3. A plot
of error against level, both series, goes to bunny_levels.png when matplotlib is installed.

    OCTOWRAP_DATA=/path/to/shared/data python crates/python/examples/bunny_levels.py
"""

import os
import sys
import time
from pathlib import Path

import numpy as np

import octowrap

REPO = Path(__file__).resolve().parents[3]
DATA = Path(os.environ.get("OCTOWRAP_DATA", REPO / ".." / "shared" / "data"))
BUNNY = DATA / "stanford-bunny" / "reconstruction" / "bun_zipper.ply"
# The paper's Table 3: the bunny's RMS error per level (1 to 6), relative to the diagonal.
PAPER = {1: 0.0259, 2: 0.0095, 3: 0.0036, 4: 0.0011, 5: 0.0004, 6: 0.00014}


def points_to_mesh_rms(points: np.ndarray, level: octowrap.Level) -> float:
    import trimesh

    mesh = level.to_trimesh()
    _, distance, _ = trimesh.proximity.closest_point(mesh, points)
    return float(np.sqrt(np.mean(distance**2)))


def main() -> int:
    if not BUNNY.is_file():
        print(f"SKIPPED {BUNNY} is missing (set OCTOWRAP_DATA)")
        return 0
    points = octowrap.read(BUNNY).positions
    start = time.perf_counter()
    h = octowrap.reconstruct(points)
    print(f"{len(points)} points -> {len(h)} levels in {time.perf_counter() - start:.2f} s")
    diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    try:
        import rtree  # noqa: F401  (trimesh's proximity query needs rtree and scipy)
        import scipy  # noqa: F401
        import trimesh  # noqa: F401
    except ImportError:
        print("no table: the error needs trimesh, rtree and scipy (pip install trimesh rtree scipy)")
        return 0
    levels, errors = [], []
    print("level     faces  RMS / diagonal  paper (Table 3)")
    for k in range(1, len(h)):
        level = h[k]
        rms = points_to_mesh_rms(points, level) / diagonal
        levels.append(k)
        errors.append(rms)
        paper = f"{PAPER[k]:.5f}" if k in PAPER else "-"
        print(f"{k:>5}  {len(level.parent):>8}  {rms:>14.5f}  {paper:>15}")
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("no plot: it needs matplotlib (pip install matplotlib)")
        return 0
    fig, ax = plt.subplots(figsize=(5, 3.5))
    ax.semilogy(levels, errors, "o-", label="octowrap")
    ax.semilogy(list(PAPER), list(PAPER.values()), "s--", label="paper, Table 3")
    ax.set_xticks(sorted(set(levels) | set(PAPER)))
    ax.legend()
    ax.set_xlabel("level")
    ax.set_ylabel("points-to-mesh RMS / bbox diagonal")
    ax.set_title("Stanford bunny")
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig("bunny_levels.png", dpi=120)
    print("plot: bunny_levels.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
