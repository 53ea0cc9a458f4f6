"""The Python side of the bench's `python` area (tools/bench/src/python.rs).

    python driver.py POINTS LEVEL RUNS OCTOWRAP_BIN

Prints `key value` lines: the best of RUNS wall and process CPU times (every thread's) of
`octowrap.reconstruct` on POINTS' positions (a numpy array) to LEVEL; the best of 5 `import octowrap` times in fresh interpreters (the
interpreter's own start excluded); the peak resident memory of a Python process that reads
POINTS, reconstructs it and saves the MRQ file, and of the command line doing the same
(`octowrap reconstruct POINTS -o x.mrq --level LEVEL`), each from `os.wait4`; and the wheel's size
(a built wheel in target/wheels if there is one, else the installed package's files deflated as a
wheel holds them).
"""

import os
import subprocess
import sys
import tempfile
import time
import zipfile
from pathlib import Path


def peak_rss_kib(argv):
    """The peak resident set of the process running ``argv``, in KiB, and its exit status."""
    child = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode != 0:
        sys.exit(f"{argv[0]} failed ({child.returncode}): {child.stderr.read().decode(errors='replace')}")
    return usage.ru_maxrss


def wheel_size(repo):
    wheels = sorted((repo / "target" / "wheels").glob("octowrap-*.whl"), key=lambda p: p.stat().st_mtime)
    if wheels:
        return wheels[-1].stat().st_size, f"built wheel {wheels[-1].name}"
    import octowrap

    package = Path(octowrap.__file__).parent
    with tempfile.TemporaryDirectory() as tmp:
        whl = Path(tmp) / "estimate.whl"
        with zipfile.ZipFile(whl, "w", zipfile.ZIP_DEFLATED) as z:
            for f in sorted(package.rglob("*")):
                if f.is_file() and "__pycache__" not in f.parts:
                    z.write(f, f.relative_to(package.parent))
        return whl.stat().st_size, "the installed package deflated as in a wheel (no built wheel in target/wheels)"


def main():
    points_path, level, runs, cli = sys.argv[1], int(sys.argv[2]), int(sys.argv[3]), sys.argv[4]
    repo = Path(__file__).resolve().parents[3]
    # First, while this process is small: a child's peak includes the memory of the process it
    # was forked from (Linux counts the image before exec).
    with tempfile.TemporaryDirectory() as tmp:
        job = (
            "import sys, octowrap; p = octowrap.read(sys.argv[1]).positions; "
            "octowrap.reconstruct(p, max_level=int(sys.argv[2])).save(sys.argv[3])"
        )
        py = peak_rss_kib([sys.executable, "-c", job, points_path, str(level), os.path.join(tmp, "py.mrq")])
        line = peak_rss_kib([cli, "reconstruct", points_path, "-o", os.path.join(tmp, "cli.mrq"), "--level", str(level)])
    print(f"rss_python_kib {py}")
    print(f"rss_cli_kib {line}")

    import octowrap

    points = octowrap.read(points_path).positions
    best, best_cpu = float("inf"), float("inf")
    for _ in range(runs):
        start, cpu = time.perf_counter(), time.process_time()
        octowrap.reconstruct(points, max_level=level)
        best = min(best, time.perf_counter() - start)
        best_cpu = min(best_cpu, time.process_time() - cpu)
    print(f"points {len(points)}")
    print(f"reconstruct_seconds {best:.6f}")
    print(f"reconstruct_cpu_seconds {best_cpu:.6f}")

    probe = "import time; t = time.perf_counter(); import octowrap; print(time.perf_counter() - t)"
    imports = [float(subprocess.check_output([sys.executable, "-c", probe], text=True)) for _ in range(5)]
    print(f"import_seconds {min(imports):.6f}")

    size, what = wheel_size(repo)
    print(f"wheel_bytes {size}")
    print(f"wheel_what {what}")


if __name__ == "__main__":
    main()
