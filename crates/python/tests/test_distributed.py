"""octowrap.distributed on a LocalCluster of 2 workers: the autzen LiDAR tile in 8 octree tiles,
run twice, the second time with a worker killed while the reconstructions run; both runs must
write the same bytes (tasks are pure functions of their input files, outputs atomic)."""

import importlib.util
import os
import signal
import threading
import time
from pathlib import Path

import pytest

from conftest import data, octowrap_bin, skip

SOURCE = Path(__file__).resolve().parents[1] / "python" / "octowrap" / "distributed.py"


def load():
    # By path: the module needs no compiled extension, so the test runs without a built wheel.
    spec = importlib.util.spec_from_file_location("octowrap_distributed", SOURCE)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_tiled_run_survives_a_killed_worker(tmp_path):
    try:
        from distributed import Client, LocalCluster
    except ImportError:
        skip("dask and distributed are not installed (pip install dask distributed)")
    laz = data("lidar-las/autzen_trim.laz")
    binary = str(octowrap_bin())
    dist = load()
    outputs = []
    for attempt in ("clean", "killed"):
        work = tmp_path / attempt
        work.mkdir()
        plan = work / "plan.json"
        with LocalCluster(n_workers=2, threads_per_worker=1, processes=True) as cluster, Client(cluster) as client:
            killed = []
            if attempt == "killed":
                def kill_one():
                    # Wait for a reconstruction to be running, then kill its worker's process.
                    deadline = time.time() + 60
                    while time.time() < deadline and not killed:
                        for addr, keys in client.processing().items():
                            if any("reconstruct_task" in str(k) for k in keys):
                                pid = client.run(os.getpid, workers=[addr])[addr]
                                os.kill(pid, signal.SIGKILL)
                                killed.append(pid)
                                return
                        time.sleep(0.01)

                threading.Thread(target=kill_one, daemon=True).start()
            out = dist.run(str(plan), str(work / "merged.ply"), client=client, inputs=[str(laz)],
                           points_per_tile=60000, octowrap=binary)
            if attempt == "killed":
                assert killed, "no reconstruction task was seen running"
        tiles = sorted(Path(p) for p in out["tiles"])
        assert len(tiles) == 8
        outputs.append([p.read_bytes() for p in tiles] + [Path(out["output"]).read_bytes()])
    assert outputs[0] == outputs[1]
    merged = outputs[0][-1]
    assert merged.startswith(b"ply\n") and b"element face 11634" in merged
