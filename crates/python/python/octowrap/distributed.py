"""Tiled reconstruction on a Dask cluster: plan, split, per-tile reconstruction and merge as tasks.

    python -m octowrap.distributed plan.json -o merged.ply [--scheduler ADDRESS] [--workdir DIR]
    python -m octowrap.distributed plan.json --inputs scan.laz --points-per-tile 2000000 -o merged.ply

With ``--inputs`` the plan is made first (``octowrap tile plan``); else ``plan.json`` must exist.
Without ``--scheduler`` a ``LocalCluster`` of ``--workers`` single-threaded worker processes runs
on this machine; with it, the tasks go to that scheduler (``dask-scheduler`` on a head node,
workers from dask-jobqueue on Slurm or PBS, or the Dask Kubernetes operator: see the README).

Every task runs one ``octowrap`` command (``--octowrap``, ``$OCTOWRAP_BIN`` or ``octowrap`` on
``PATH``), so a worker needs the binary and a file system shared with the others, not this package
compiled:

* ``split`` per input: ``octowrap tile split PLAN INPUT -o WORKDIR/parts``;
* ``gather`` per tile, after every split: ``octowrap tile split PLAN --merge --tile ID``;
* ``reconstruct`` per tile: ``octowrap reconstruct WORKDIR/parts/tile-ID.pts --plan PLAN --tile ID
  -o WORKDIR/tiles/ID.mrq``;
* ``merge`` once: ``octowrap tile merge PLAN WORKDIR/tiles -o OUTPUT``.

Each task is a pure function of its input files (the command line is deterministic whatever the
thread count) and writes its outputs atomically (a temporary file renamed into place), so a task
that Dask retries after a worker died gives the same bytes, and a half-written file is never seen.

Dask rather than Ray: Dask's ``distributed`` runs the same task graph on a laptop's
``LocalCluster``, under Slurm/PBS through dask-jobqueue and on Kubernetes, with no object store
to size; the tasks pass file names, not arrays, so Ray's shared-memory object store would not be
used.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Dict, List, Optional, Sequence

__all__ = ["run", "main"]


def _binary(explicit: Optional[str]) -> str:
    found = explicit or os.environ.get("OCTOWRAP_BIN") or shutil.which("octowrap")
    if not found:
        raise FileNotFoundError("no octowrap binary: pass --octowrap, set OCTOWRAP_BIN or put octowrap on PATH")
    return str(found)


def _octowrap(binary: str, *args: str) -> None:
    done = subprocess.run([binary, *args], capture_output=True, text=True)
    if done.returncode != 0:
        raise RuntimeError(f"octowrap {' '.join(args)} failed ({done.returncode}): {done.stderr.strip()}")


def plan_task(binary: str, inputs: Sequence[str], plan: str, points_per_tile: int) -> str:
    """``octowrap tile plan``; returns the plan's path."""
    _octowrap(binary, "tile", "plan", *inputs, "-o", plan, "--points-per-tile", str(points_per_tile))
    return plan


def split_task(binary: str, plan: str, input_path: str, parts: str) -> str:
    """``octowrap tile split`` for one input; returns the input."""
    _octowrap(binary, "tile", "split", plan, input_path, "-o", parts)
    return input_path


def gather_task(binary: str, plan: str, tile: int, parts: str, *splits: str) -> str:
    """``octowrap tile split --merge`` for one tile (after every split); returns its points file."""
    _octowrap(binary, "tile", "split", plan, "--merge", "--tile", str(tile), "-o", parts)
    return str(Path(parts) / f"tile-{tile}.pts")


def reconstruct_task(binary: str, plan: str, tile: int, points: str, tiles: str, threads: int) -> str:
    """``octowrap reconstruct --plan --tile``; returns the tile's MRQ file."""
    out = str(Path(tiles) / f"{tile}.mrq")
    _octowrap(binary, "reconstruct", points, "--plan", plan, "--tile", str(tile), "-o", out, "--threads", str(threads))
    return out


def merge_task(binary: str, plan: str, tiles: str, output: str, level: Optional[int], *done: str) -> str:
    """``octowrap tile merge``; returns the merged mesh's path."""
    args = ["tile", "merge", plan, tiles, "-o", output]
    if level is not None:
        args += ["--level", str(level)]
    _octowrap(binary, *args)
    return output


def run(
    plan: str,
    output: str,
    *,
    workdir: Optional[str] = None,
    scheduler: Optional[str] = None,
    client=None,
    workers: int = 2,
    inputs: Sequence[str] = (),
    points_per_tile: int = 2_000_000,
    level: Optional[int] = None,
    octowrap: Optional[str] = None,
    threads: int = 1,
    retries: int = 3,
) -> Dict[str, object]:
    """Runs the tiled reconstruction on Dask; returns the paths written (``tiles``, ``output``).

    ``client`` (a ``distributed.Client``) wins over ``scheduler``; with neither, a
    ``LocalCluster`` of ``workers`` processes runs for the call. Each task may be retried
    ``retries`` times (a worker lost mid-task).
    """
    from distributed import Client, LocalCluster

    binary = _binary(octowrap)
    plan = str(Path(plan).resolve())
    work = Path(workdir) if workdir else Path(plan).parent / (Path(plan).stem + "-work")
    parts, tiles = work / "parts", work / "tiles"
    parts.mkdir(parents=True, exist_ok=True)
    tiles.mkdir(parents=True, exist_ok=True)
    own_cluster = None
    if client is None:
        if scheduler:
            client = Client(scheduler)
        else:
            own_cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True)
            client = Client(own_cluster)
    try:
        if inputs:
            client.submit(plan_task, binary, [str(Path(i).resolve()) for i in inputs], plan, points_per_tile,
                          retries=retries, pure=True).result()
        with open(plan) as f:
            spec = json.load(f)
        input_paths = [str(i["path"]) for i in spec["inputs"]]
        ids = [int(t["id"]) for t in spec["tiles"]]
        splits = [client.submit(split_task, binary, plan, p, str(parts), retries=retries, pure=True)
                  for p in input_paths]
        gathered = {t: client.submit(gather_task, binary, plan, t, str(parts), *splits, retries=retries, pure=True)
                    for t in ids}
        recons = [client.submit(reconstruct_task, binary, plan, t, gathered[t], str(tiles), threads,
                                retries=retries, pure=True) for t in ids]
        merged = client.submit(merge_task, binary, plan, str(tiles), str(Path(output).resolve()), level, *recons,
                               retries=retries, pure=True)
        return {"tiles": [r.result() for r in recons], "output": merged.result()}
    finally:
        if own_cluster is not None:
            client.close()
            own_cluster.close()


def main(argv: Optional[List[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="python -m octowrap.distributed", description=__doc__.splitlines()[0])
    p.add_argument("plan", help="the plan file (made first when --inputs is given)")
    p.add_argument("-o", "--output", required=True, help="the merged mesh (.ply, .obj, .off, .stl)")
    p.add_argument("--scheduler", help="a Dask scheduler address (default: a LocalCluster)")
    p.add_argument("--workers", type=int, default=2, help="LocalCluster workers (default 2)")
    p.add_argument("--workdir", help="folder for parts/ and tiles/ (default: PLAN-work beside the plan)")
    p.add_argument("--inputs", nargs="+", default=[], help="make the plan from these point clouds first")
    p.add_argument("--points-per-tile", type=int, default=2_000_000)
    p.add_argument("--level", type=int, help="the level to merge (default: the plan's finest)")
    p.add_argument("--octowrap", help="the octowrap binary (default: $OCTOWRAP_BIN, else PATH)")
    p.add_argument("--threads", type=int, default=1, help="threads per reconstruction task (default 1)")
    a = p.parse_args(argv)
    try:
        out = run(a.plan, a.output, workdir=a.workdir, scheduler=a.scheduler, workers=a.workers, inputs=a.inputs,
                  points_per_tile=a.points_per_tile, level=a.level, octowrap=a.octowrap, threads=a.threads)
    except (RuntimeError, OSError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
