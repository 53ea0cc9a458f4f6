"""Reconstructs the Stanford bunny and prints each level's points-to-mesh RMS error.

The error is the root mean square of the distance from every input point to the level's surface
(``octowrap.distance``: exact, its quads split into triangles), relative to the diagonal of the
points' bounding box, beside the paper's Table 3. Two columns: the levels as the MRQ file holds
them (``reconstruct``'s default: refined vertices on the decoder's lines, one number each), and the
free positions (``keep_positions=True``, a larger file). A plot of error against level goes to
bunny_levels.png with matplotlib, else to bunny_levels.svg, drawn here. Needs only numpy and
octowrap:

    pip install ./crates/python
    OCTOWRAP_DATA=/path/to/shared/data python crates/python/examples/bunny_levels.py
"""

import math
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


def rms(points: np.ndarray, level: octowrap.Level) -> float:
    """The points-to-mesh RMS distance."""
    return float(np.sqrt(np.mean(level.distance(points) ** 2)))


def plot_png(series: dict, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.5))
    for (name, (xs, ys)), style in zip(series.items(), ("o-", "^:", "s--")):
        ax.semilogy(xs, ys, style, label=name)
    ax.set_xticks(sorted({x for xs, _ in series.values() for x in xs}))
    ax.legend()
    ax.set_xlabel("level")
    ax.set_ylabel("points-to-mesh RMS / bbox diagonal")
    ax.set_title("Stanford bunny")
    ax.grid(True, which="both", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def plot_svg(series: dict, path: str) -> None:
    """The same plot as an SVG file written by hand: log-scale error against level."""
    w, h, left, right, top, bottom = 520, 360, 70, 20, 30, 50
    xs_all = sorted({x for xs, _ in series.values() for x in xs})
    ys_all = [y for _, ys in series.values() for y in ys if y > 0]
    x0, x1 = xs_all[0], max(xs_all[-1], xs_all[0] + 1)
    d0, d1 = math.floor(math.log10(min(ys_all))), math.ceil(math.log10(max(ys_all)))
    d1 = max(d1, d0 + 1)

    def px(x: float) -> float:
        return left + (x - x0) / (x1 - x0) * (w - left - right)

    def py(y: float) -> float:
        return top + (d1 - math.log10(y)) / (d1 - d0) * (h - top - bottom)

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" viewBox="0 0 {w} {h}" '
        'font-family="sans-serif" font-size="12">',
        f'<rect width="{w}" height="{h}" fill="white"/>',
        f'<text x="{w / 2}" y="18" text-anchor="middle" font-size="14">Stanford bunny</text>',
    ]
    for d in range(d0, d1 + 1):
        y = py(10.0**d)
        out.append(f'<line x1="{left}" y1="{y:.1f}" x2="{w - right}" y2="{y:.1f}" stroke="#ddd"/>')
        out.append(f'<text x="{left - 6}" y="{y + 4:.1f}" text-anchor="end">1e{d}</text>')
    for x in xs_all:
        out.append(f'<line x1="{px(x):.1f}" y1="{top}" x2="{px(x):.1f}" y2="{h - bottom}" stroke="#eee"/>')
        out.append(f'<text x="{px(x):.1f}" y="{h - bottom + 16}" text-anchor="middle">{x}</text>')
    out.append(f'<rect x="{left}" y="{top}" width="{w - left - right}" height="{h - top - bottom}" fill="none" stroke="black"/>')
    out.append(f'<text x="{(left + w - right) / 2}" y="{h - 12}" text-anchor="middle">level</text>')
    out.append(
        f'<text transform="translate(16 {(top + h - bottom) / 2}) rotate(-90)" text-anchor="middle">'
        "points-to-mesh RMS / bbox diagonal</text>"
    )
    colours = ("#1f77b4", "#2ca02c", "#ff7f0e")
    for i, ((name, (xs, ys)), colour) in enumerate(zip(series.items(), colours)):
        points = " ".join(f"{px(x):.1f},{py(y):.1f}" for x, y in zip(xs, ys))
        dash = ' stroke-dasharray="5 3"' if i else ""
        out.append(f'<polyline points="{points}" fill="none" stroke="{colour}" stroke-width="1.5"{dash}/>')
        out += [f'<circle cx="{px(x):.1f}" cy="{py(y):.1f}" r="3" fill="{colour}"/>' for x, y in zip(xs, ys)]
        ly = top + 16 + 16 * i
        out.append(f'<line x1="{w - right - 150}" y1="{ly - 4}" x2="{w - right - 126}" y2="{ly - 4}" stroke="{colour}" stroke-width="1.5"{dash}/>')
        out.append(f'<text x="{w - right - 120}" y="{ly}">{name}</text>')
    out.append("</svg>")
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(out) + "\n")


def main() -> int:
    if not BUNNY.is_file():
        print(f"SKIPPED {BUNNY} is missing (set OCTOWRAP_DATA)")
        return 0
    points = octowrap.read(BUNNY).positions
    start = time.perf_counter()
    h = octowrap.reconstruct(points)
    print(f"{len(points)} points -> {len(h)} levels in {time.perf_counter() - start:.2f} s")
    free = octowrap.reconstruct(points, keep_positions=True)
    diagonal = float(np.linalg.norm(points.max(axis=0) - points.min(axis=0)))
    levels, errors, free_errors = [], [], []
    print("level     faces  RMS / diagonal  free positions  paper (Table 3)")
    for k in range(1, len(h)):
        e, f = rms(points, h[k]) / diagonal, rms(points, free[k]) / diagonal
        levels.append(k)
        errors.append(e)
        free_errors.append(f)
        paper = f"{PAPER[k]:.2e}" if k in PAPER else "-"
        print(f"{k:>5}  {len(h[k].parent):>8}  {e:>14.3e}  {f:>14.3e}  {paper:>15}")
    series = {
        "octowrap (MRQ levels)": (levels, errors),
        "octowrap, free positions": (levels, free_errors),
        "paper, Table 3": (list(PAPER), list(PAPER.values())),
    }
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        plot_svg(series, "bunny_levels.svg")
        print("plot: bunny_levels.svg")
        return 0
    plot_png(series, "bunny_levels.png")
    print("plot: bunny_levels.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
