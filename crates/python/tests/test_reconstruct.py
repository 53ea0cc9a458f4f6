"""reconstruct, Hierarchy, save and open_mrq: the library's results, the command line's bytes."""

import inspect
import subprocess

import numpy as np
import pytest

import octowrap
from octowrap import _octowrap
from conftest import assert_gil_released, octowrap_bin, sphere


@pytest.fixture(scope="module")
def hierarchy():
    return octowrap.reconstruct(sphere(30000), max_level=5)


def test_python_defaults_are_the_library_defaults():
    params = inspect.signature(octowrap.reconstruct).parameters
    defaults = _octowrap.recon_defaults()
    assert {k: params[k].default for k in defaults} == defaults


def test_levels_are_linked_quad_meshes(hierarchy):
    assert len(hierarchy) == 6
    assert [lv.kind for lv in hierarchy] == ["root"] + ["wrapped"] * 5
    assert hierarchy[0].faces.shape == (6, 4) and (hierarchy[0].parent == -1).all()
    for k in range(1, len(hierarchy)):
        lv, up = hierarchy[k], hierarchy[k - 1]
        assert lv.faces.ndim == 2 and lv.faces.shape[1] == 4
        assert lv.vertices.dtype == np.float64 and lv.vertices.shape[1] == 3
        assert lv.parent.shape == lv.quadrant.shape == (len(lv.faces),)
        sub = lv.parent >= 0
        assert ((lv.quadrant >= 0) == sub).all()
        assert lv.parent.max() < len(up.faces) and lv.quadrant.max() <= 3
        pairs = lv.parent[sub] * 4 + lv.quadrant[sub]
        assert len(np.unique(pairs)) == len(pairs), "two faces claim one quadrant"
        r = octowrap.validate(lv.vertices, lv.faces, require=["watertight", "oriented"])
        assert r["passed"], (k, r["failed_requirements"])
    assert hierarchy[-1].kind == hierarchy[5].kind
    with pytest.raises(IndexError, match="levels 0 to 5"):
        hierarchy[6]
    lo, hi = hierarchy.cube
    assert all(a < -1 and b > 1 for a, b in zip(lo, hi))


def test_same_bytes_for_any_thread_count(tmp_path):
    p = sphere(20000, seed=3)
    octowrap.reconstruct(p, max_level=4, threads=1).save(tmp_path / "1.mrq")
    octowrap.reconstruct(p, max_level=4, threads=2).save(tmp_path / "2.mrq")
    assert (tmp_path / "1.mrq").read_bytes() == (tmp_path / "2.mrq").read_bytes()


# (command-line arguments, reconstruct's options, save's options): the CLI's default, each MRQ
# option, and a finest level asked for with other relaxation.
CLI_CASES = [
    ([], {}, {}),
    (["--keep-positions"], {"keep_positions": True}, {}),
    (["--bits", "14"], {"bits": 14}, {}),
    (["--level", "6", "--relax-passes", "2"], {"max_level": 6, "relax_passes": 2}, {}),
    (["--level", "5", "--bits", "13", "--keep-positions"], {"max_level": 5, "bits": 13, "keep_positions": True}, {}),
    # --step: reconstructed free, then placed on the lines of a grid not tied to the cube.
    (["--level", "5", "--step", "0.004"], {"max_level": 5, "keep_positions": True}, {"step": 0.004, "keep_positions": False}),
]


@pytest.fixture(scope="module")
def cli_points(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cli")
    p = sphere(40000, seed=5) * 3.0 + np.array([10.0, -2.0, 0.5])
    octowrap.write(tmp / "points.ply", octowrap.PointCloud(p))
    np.testing.assert_array_equal(octowrap.read(tmp / "points.ply").points, p)
    return tmp / "points.ply", p


@pytest.mark.parametrize("args,recon,save", CLI_CASES, ids=[" ".join(c[0]) or "default" for c in CLI_CASES])
def test_same_mrq_bytes_as_the_command_line(tmp_path, cli_points, args, recon, save):
    exe = octowrap_bin()
    ply, p = cli_points
    cli = tmp_path / "cli.mrq"
    run = subprocess.run([str(exe), "reconstruct", str(ply), "-o", str(cli), *args], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    h = octowrap.reconstruct(p, **recon)
    h.save(tmp_path / "py.mrq", source="points.ply", **save)
    assert (tmp_path / "py.mrq").read_bytes() == cli.read_bytes(), args


def test_the_file_decodes_to_the_levels_reconstructed_on_the_decoder_lines(tmp_path, cli_points):
    _, p = cli_points
    h = octowrap.reconstruct(p, max_level=5)
    free = octowrap.reconstruct(p, max_level=5, keep_positions=True)
    h.save(tmp_path / "lines.mrq")
    free.save(tmp_path / "free.mrq")
    f = octowrap.open_mrq(tmp_path / "lines.mrq")
    for k in range(len(h)):
        decoded, built = f.level(k).vertices, h[k].vertices
        assert decoded.shape == built.shape
        # The decoder orders vertices canonically: compare sorted rows, exactly.
        np.testing.assert_array_equal(np.unique(decoded, axis=0), np.unique(built, axis=0), err_msg=f"level {k}")
    # The free reconstruction differs from the lines' and costs more bytes (three numbers per
    # vertex where the lines' file stores one).
    assert not np.array_equal(free[5].vertices, h[5].vertices)
    assert (tmp_path / "free.mrq").stat().st_size > (tmp_path / "lines.mrq").stat().st_size * 1.2
    with pytest.raises(ValueError, match=r"bits must lie in 1\.\.=28, not 29"):
        octowrap.reconstruct(p, max_level=2, bits=29)


def test_open_mrq_reads_only_the_prefix_it_needs(tmp_path, hierarchy):
    path = tmp_path / "h.mrq"
    hierarchy.save(path, units="m")
    f = octowrap.open_mrq(path)
    assert len(f) == len(hierarchy)
    info = f.info
    assert info["metadata"]["units"] == "m" and info["grid"]["bits"] == len(hierarchy) - 1 + 6 and info["version"] == octowrap.FORMAT_VERSION
    assert [lv["face_count"] for lv in info["levels"]] == [len(lv.faces) for lv in hierarchy]
    assert info["preamble_size"] + sum(lv["stored_size"] for lv in info["levels"]) == path.stat().st_size
    # Cut the file after level 3: levels 0-3 still decode, level 4 does not.
    end3 = info["levels"][3]["offset"] + info["levels"][3]["stored_size"]
    cut = tmp_path / "cut.mrq"
    cut.write_bytes(path.read_bytes()[:end3])
    g = octowrap.open_mrq(cut)
    lv3 = g.level(3)
    np.testing.assert_array_equal(lv3.faces, f.level(3).faces)
    assert lv3.kind is None and len(lv3.faces) == len(hierarchy[3].faces)
    # A free reconstruction's file holds every reconstructed vertex within half a grid step on
    # each axis (in the canonical vertex order: compare each with its nearest).
    free = octowrap.reconstruct(sphere(30000), max_level=5, keep_positions=True)
    kept = tmp_path / "kept.mrq"
    free.save(kept)
    a, b = octowrap.open_mrq(kept).level(3).vertices, free[3].vertices
    nearest = np.abs(a[:, None, :] - b[None, :, :]).max(axis=2).min(axis=1)
    step = info["grid"]["step"]
    assert nearest.max() <= step / 2 * (1 + 1e-9), (nearest.max(), step)
    assert kept.stat().st_size > path.stat().st_size
    with pytest.raises(octowrap.FormatError, match=r"reading .*cut.mrq: truncated"):
        g.level(4)
    with pytest.raises(IndexError):
        g.level(len(g))
    assert len(f.hierarchy(2)) == 3


def test_the_gil_is_released_while_reconstructing():
    p = sphere(400_000, seed=7)
    assert_gil_released(lambda: octowrap.reconstruct(p, max_level=7), "reconstruct")
