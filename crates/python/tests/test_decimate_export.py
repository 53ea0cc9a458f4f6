"""decimate and export_glb: the command line's bytes and reports, and hostile input."""

import json
import subprocess

import numpy as np
import pytest

import octowrap
from conftest import assert_gil_released, data, octowrap_bin, sphere


@pytest.fixture(scope="module")
def hierarchy():
    return octowrap.reconstruct(sphere(30000, seed=11) * 2.0 + np.array([1.0, 0.0, -3.0]), max_level=5)


@pytest.fixture(scope="module")
def coloured_ply(tmp_path_factory, hierarchy):
    """The finest level as a PLY with a colour per vertex."""
    finest = hierarchy[-1]
    colors = (np.abs(finest.vertices - finest.vertices.min(axis=0)) * 60).astype(np.uint8)
    path = tmp_path_factory.mktemp("mesh") / "level5.ply"
    octowrap.write(path, octowrap.Mesh(finest.vertices, finest.faces, colors=colors))
    return path


def run_cli(*args):
    run = subprocess.run([str(octowrap_bin()), *map(str, args)], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    return run.stdout


def without_names(report):
    return {k: v for k, v in report.items() if k not in {"input", "output", "seconds"}}


@pytest.mark.parametrize(
    "args, kwargs",
    [
        (["--ratio", "0.2"], {"ratio": 0.2}),
        (["--target-faces", "700", "--lock-border", "--quads", "triangles"], {"target_faces": 700, "lock_border": True, "quads": "triangles"}),
        (["--max-error", "0.5%", "--measure"], {"max_error": "0.5%", "measure": True}),
        (["--max-error", "0.02", "--ratio", "0.5"], {"max_error": 0.02, "ratio": 0.5}),
    ],
)
def test_decimate_gives_the_command_line_bytes_and_report(tmp_path, coloured_ply, args, kwargs):
    cli = tmp_path / "cli.ply"
    report_cli = json.loads(run_cli("decimate", coloured_ply, "-o", cli, "--json", *args))
    mesh = octowrap.read(coloured_ply)
    small, report = octowrap.decimate(mesh, **kwargs)
    octowrap.write(tmp_path / "py.ply", small)
    assert (tmp_path / "py.ply").read_bytes() == cli.read_bytes()
    assert without_names(report) == without_names(report_cli)
    assert report["mode"] == "decimate" and report["output_faces"] < report["input_faces"] == len(mesh.face_offsets) - 1
    assert small.colors is not None and small.colors.dtype == np.uint8 and len(small.colors) == len(small.vertices)
    # The same arrays given loose give the same mesh.
    loose, _ = octowrap.decimate(mesh.vertices, mesh.faces, **kwargs)
    np.testing.assert_array_equal(loose.vertices, small.vertices)
    np.testing.assert_array_equal(loose.face_indices, small.face_indices)
    assert loose.colors is None


def test_decimated_mesh_keeps_the_topology(hierarchy):
    finest = hierarchy[-1]
    small, report = octowrap.decimate(finest, target_faces=600)
    assert report["output_faces"] <= 600
    r = octowrap.validate(small.vertices, small.faces, require=["watertight", "oriented"])
    assert r["passed"], r["failed_requirements"]
    assert r["outcome"]["euler_characteristic"] == 2


def test_cut_gives_the_command_line_bytes_and_report(tmp_path, hierarchy):
    mrq = tmp_path / "h.mrq"
    hierarchy.save(mrq)
    f = octowrap.open_mrq(mrq)
    camera = {"position": [1.0, -8.0, -3.0], "target": [1.0, 0.0, -3.0], "fov_y_degrees": 60, "viewport_height_px": 1080, "pixel_error": 4.0}
    (tmp_path / "camera.json").write_text(json.dumps(camera))
    for args, kwargs in [(["--max-error", "0.01"], {"max_error": 0.01}), (["--max-error", "1%"], {"max_error": "1%"}), (["--view", tmp_path / "camera.json"], {"view": camera})]:
        cli = tmp_path / "cli.ply"
        # The face-level cut: the command line cuts a chunked file through whole chunks unless
        # asked for this one.
        report_cli = json.loads(run_cli("decimate", mrq, "-o", cli, "--json", "--cut", "faces", *args))
        cut, report = octowrap.decimate(f, cut="faces", **kwargs)
        octowrap.write(tmp_path / "py.ply", cut)
        assert (tmp_path / "py.ply").read_bytes() == cli.read_bytes(), args
        assert without_names(report) == without_names(report_cli), args
        assert report["mode"] == "cut" and sum(report["cut"]["faces_per_level"]) == report["output_faces"]
        assert octowrap.validate(cut.vertices, cut.faces, require=["watertight", "oriented"])["passed"], args
    # By default a chunked file is cut through whole chunks, as the command line does.
    for args, kwargs in [(["--max-error", "1%"], {"max_error": "1%"}), (["--view", tmp_path / "camera.json"], {"view": camera})]:
        cli = tmp_path / "cli.ply"
        report_cli = json.loads(run_cli("decimate", mrq, "-o", cli, "--json", *args))
        cut, report = octowrap.decimate(f, **kwargs)
        octowrap.write(tmp_path / "py.ply", cut)
        assert (tmp_path / "py.ply").read_bytes() == cli.read_bytes(), args
        assert without_names(report) == without_names(report_cli), args
        assert report["mode"] == "chunk cut" and report["chunk_cut"]["bytes_read"] <= report["chunk_cut"]["file_bytes"]
    with pytest.raises(ValueError, match="cut must be"):
        octowrap.decimate(f, max_error=0.01, cut="some")
    with pytest.raises(ValueError, match='cut="chunks" cuts an MrqFile'):
        octowrap.decimate(hierarchy, max_error=0.01, cut="chunks")
    # With a face target the finest level is decimated, as the command line does with an MRQ file.
    report_cli = json.loads(run_cli("decimate", mrq, "-o", tmp_path / "cli.ply", "--json", "--ratio", "0.5"))
    small, report = octowrap.decimate(f, ratio=0.5)
    octowrap.write(tmp_path / "py.ply", small)
    assert (tmp_path / "py.ply").read_bytes() == (tmp_path / "cli.ply").read_bytes()
    assert without_names(report) == without_names(report_cli) and report["mode"] == "decimate"
    # The camera may also be a file; a reconstructed hierarchy cuts like the decoded one.
    by_file, _ = octowrap.decimate(f, view=tmp_path / "camera.json")
    by_dict, _ = octowrap.decimate(f, view=camera)
    np.testing.assert_array_equal(by_file.face_indices, by_dict.face_indices)
    coarse, report = octowrap.decimate(hierarchy, max_error=0.05)
    assert report["mode"] == "cut" and report["cut"]["faces_per_level"][-1] == 0
    assert 0 < report["cut"]["max_error"] <= 0.05 and len(coarse.face_offsets) - 1 < len(hierarchy[-1].faces) / 4


def test_export_gives_the_command_line_bytes(tmp_path, hierarchy, coloured_ply):
    mrq = tmp_path / "h.mrq"
    hierarchy.save(mrq, units="m")
    f = octowrap.open_mrq(mrq)
    cases = [
        ([], {}),
        (["--levels", "all", "--quantize", "--meshopt"], {"levels": "all", "quantize": True, "meshopt": True}),
        (["--level", "2", "--crease-angle", "30"], {"levels": 2, "crease_angle": 30.0}),
        (["--levels", "all", "--screen-error", "3"], {"levels": "all", "screen_error": 3.0}),
    ]
    for args, kwargs in cases:
        run_cli("export", mrq, "-o", tmp_path / "cli.glb", *args)
        glb, summary = octowrap.export_glb(f, **kwargs)
        assert glb == (tmp_path / "cli.glb").read_bytes(), args
        assert summary["bytes"] == len(glb)
    glb, summary = octowrap.export_glb(f, levels="all")
    assert [lv["level"] for lv in summary["levels"]] == list(range(len(hierarchy)))[::-1]
    assert len(summary["screen_coverage"]) == len(hierarchy) and summary["extensions_used"] == ["MSFT_lod"]
    # A mesh file: the command records its name as the source.
    run_cli("export", coloured_ply, "-o", tmp_path / "mesh.glb", "--quantize")
    mesh = octowrap.read(coloured_ply)
    glb, summary = octowrap.export_glb(mesh, quantize=True, metadata={"source": coloured_ply.name}, path=tmp_path / "py.glb")
    assert glb == (tmp_path / "mesh.glb").read_bytes() == (tmp_path / "py.glb").read_bytes()
    assert summary["levels"][0]["triangles"] == 2 * len(mesh.faces)
    plain, _ = octowrap.export_glb(mesh, colors=False)
    assert len(plain) < len(octowrap.export_glb(mesh)[0])
    # A hierarchy held in memory exports the same levels as its file (positions differ by the grid).
    held, summary = octowrap.export_glb(hierarchy, levels=3)
    assert summary["levels"][0]["level"] == 3 and summary["levels"][0]["source_faces"] == len(hierarchy[3].faces)


def test_the_bunny_decimates_as_on_the_command_line(tmp_path):
    bunny = data("stanford-bunny/reconstruction/bun_zipper.ply")
    report_cli = json.loads(run_cli("decimate", bunny, "-o", tmp_path / "cli.obj", "--ratio", "0.05", "--json"))
    small, report = octowrap.decimate(octowrap.read(bunny), ratio=0.05)
    octowrap.write(tmp_path / "py.obj", small)
    assert (tmp_path / "py.obj").read_bytes() == (tmp_path / "cli.obj").read_bytes()
    assert without_names(report) == without_names(report_cli)
    assert report["output_faces"] == round(0.05 * report["input_faces"])


V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0.5, 0.5, 1]], dtype=float)
F = np.array([[0, 3, 2, 1], [0, 1, 4, 4], [1, 2, 4, 4], [2, 3, 4, 4], [3, 0, 4, 4]])[:1]
TET = np.array([[0, 2, 1], [0, 1, 4], [1, 2, 4], [2, 0, 4]])


@pytest.mark.parametrize(
    "vertices, faces, message",
    [
        (V.astype(np.float32), TET, "found dtype float32; pass numpy.asarray"),
        (V[:, :2].copy(), TET, r"found shape \(5, 2\) of float64"),
        (V, TET.astype(np.float64), "must hold integers"),
        (V, TET.reshape(-1), r"shape \(M, k\)"),
        (np.where(np.arange(5)[:, None] == 4, np.nan, V), TET, "non-finite"),
        (V, np.array([[0, 1, 9]]), "broken input: .*9"),
        (V, np.array([[0, 1]]), "broken input"),
        (np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), "no faces"),
        (V.tolist(), TET, "not list"),
    ],
)
def test_bad_meshes_are_value_errors(vertices, faces, message):
    with pytest.raises(ValueError, match=message):
        octowrap.decimate(vertices, faces, ratio=0.5)
    with pytest.raises(ValueError, match=message.replace("no faces", "no faces|has no faces")):
        octowrap.export_glb(vertices, faces)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({}, "give a target"),
        ({"ratio": 0.0}, r"ratio must be in \(0, 1\]"),
        ({"ratio": float("nan")}, r"ratio must be in \(0, 1\]"),
        ({"target_faces": 0}, "1 face or more"),
        ({"max_error": -1.0}, "zero or positive"),
        ({"max_error": "lots"}, "not a number"),
        ({"max_error": float("inf")}, "zero or positive"),
        ({"quads": "hexes"}, "quads must be"),
        ({"view": {"position": [0, 0, 5]}}, "view cuts a hierarchy"),
    ],
)
def test_bad_decimate_options_are_value_errors(kwargs, message):
    if "quads" in kwargs:
        kwargs = {**kwargs, "ratio": 0.5}
    with pytest.raises(ValueError, match=message):
        octowrap.decimate(V, TET, **kwargs)


def test_bad_cut_and_export_options_are_value_errors(tmp_path, hierarchy):
    with pytest.raises(ValueError, match="lock_border steers edge collapse"):
        octowrap.decimate(hierarchy, max_error=0.01, lock_border=True)
    with pytest.raises(ValueError, match="invalid camera"):
        octowrap.decimate(hierarchy, view={"position": [0, 0, 5], "target": [0, 0, 5], "fov_y_degrees": 60, "viewport_height_px": 1080, "pixel_error": 1})
    with pytest.raises(ValueError, match="faces come with the Mesh"):
        octowrap.decimate(hierarchy[2], TET, ratio=0.5)
    with pytest.raises(ValueError, match="not a PointCloud"):
        octowrap.export_glb(octowrap.PointCloud(V))
    for kwargs, message in [
        ({"levels": 9}, "level 9"),
        ({"levels": -1}, "levels must be"),
        ({"levels": True}, "levels must be"),
        ({"crease_angle": 200.0}, "0 to 180 degrees"),
        ({"screen_error": 0.0}, "positive number of pixels"),
        ({"path": tmp_path / "x.gltf"}, r"must end in \.glb"),
    ]:
        with pytest.raises(ValueError, match=message):
            octowrap.export_glb(hierarchy, **kwargs)
    with pytest.raises(FileNotFoundError):
        octowrap.export_glb(hierarchy, path=tmp_path / "missing" / "x.glb")
    assert not list(tmp_path.iterdir())


def test_the_gil_is_released_while_decimating_and_exporting():
    finest = octowrap.reconstruct(sphere(60_000, seed=13), max_level=6)[6]
    for name, work in [
        ("decimate", lambda: [octowrap.decimate(finest, ratio=r) for r in (0.05, 0.1, 0.2)]),
        ("export_glb", lambda: [octowrap.export_glb(finest, meshopt=True, quantize=True, crease_angle=c) for c in (30.0, 40.0, 50.0) * 8]),
    ]:
        assert_gil_released(work, name)
