"""export_tiles: the 3D Tiles tileset of the command line, byte for byte."""

import json
import subprocess

import numpy as np
import pytest

import octowrap
from conftest import assert_gil_released, octowrap_bin, sphere


def files(folder):
    """Every file under ``folder``: relative path -> bytes."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def cli_export(src, out, *flags):
    run = subprocess.run(
        [str(octowrap_bin()), "export", str(src), "-o", str(out / "tileset.json"), *flags],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr
    return files(out)


@pytest.fixture(scope="module")
def mrq(tmp_path_factory):
    path = tmp_path_factory.mktemp("tiles") / "ball.mrq"
    octowrap.reconstruct(sphere(30000, seed=6) * 5.0, max_level=5).save(path, units="m", source="ball.ply")
    return path


@pytest.mark.parametrize("flags", [[], ["--quantize", "--meshopt"], ["--no-colors", "--quantize"]], ids=lambda f: " ".join(f) or "default")
def test_same_files_as_the_command_line(tmp_path, mrq, flags):
    cli = cli_export(mrq, tmp_path / "cli", *flags)
    assert "tileset.json" in cli and sum(k.endswith(".glb") for k in cli) > 5
    kw = {"quantize": "--quantize" in flags, "meshopt": "--meshopt" in flags, "colors": "--no-colors" not in flags}
    # From the file's path, from the opened file, and from its hierarchy with the file's
    # metadata given by hand.
    s = octowrap.export_tiles(mrq, tmp_path / "path", **kw)
    assert files(tmp_path / "path") == cli
    octowrap.export_tiles(octowrap.open_mrq(mrq), tmp_path / "opened" / "tileset.json", **kw)
    assert files(tmp_path / "opened") == cli
    meta = octowrap.open_mrq(mrq).info["metadata"]
    pairs = [(k, meta[k]) for k in ("units", "source", "generator")]
    octowrap.export_tiles(octowrap.open_mrq(mrq).hierarchy(), tmp_path / "held", metadata=pairs, **kw)
    assert files(tmp_path / "held") == cli
    assert s["bytes"] == sum(len(b) for b in cli.values())
    assert s["content_tiles"] == sum(k.endswith(".glb") for k in cli) and s["levels"] == 6
    tileset = json.loads(cli["tileset.json"])
    assert s["root_error"] == pytest.approx(tileset["root"]["geometricError"])


def test_a_mesh_becomes_one_tile_as_on_the_command_line(tmp_path, mrq):
    level = octowrap.open_mrq(mrq).level(3)
    octowrap.write(tmp_path / "part.ply", octowrap.Mesh(level.vertices, level.faces))
    cli = cli_export(tmp_path / "part.ply", tmp_path / "cli")
    octowrap.export_tiles(tmp_path / "part.ply", tmp_path / "path")
    assert files(tmp_path / "path") == cli
    octowrap.export_tiles(level.vertices, tmp_path / "arrays", faces=level.faces)
    assert files(tmp_path / "arrays") == cli


def test_errors(tmp_path, mrq):
    (tmp_path / "file").write_text("x")
    with pytest.raises(OSError):
        octowrap.export_tiles(mrq, tmp_path / "file" / "sub")
    with pytest.raises(ValueError, match="needs a mesh"):
        octowrap.export_tiles(octowrap.PointCloud(np.zeros((3, 3))), tmp_path / "pc")
    with pytest.raises(ValueError, match="broken input"):
        octowrap.export_tiles(np.zeros((3, 3)), tmp_path / "broken", faces=np.array([[0, 1, 7]]))
    # A mesh without faces is refused, as the command line refuses it (no panic).
    empty = octowrap.Mesh(np.zeros((3, 3)), np.zeros((0, 3), dtype=np.int64))
    with pytest.raises(ValueError, match="level 0 has no faces"):
        octowrap.export_tiles(empty, tmp_path / "empty")
    with pytest.raises(ValueError, match=r"does not end in \.json"):
        octowrap._octowrap.export_tiles(str(tmp_path / "t.txt"), None, None, None, False, False, True, [])
    with pytest.raises(octowrap.FormatError):
        bad = tmp_path / "bad.mrq"
        bad.write_bytes(b"not an mrq file at all")
        octowrap.export_tiles(bad, tmp_path / "bad")


def test_the_gil_is_released_while_exporting(tmp_path, mrq):
    h = octowrap.open_mrq(mrq).hierarchy()
    assert_gil_released(lambda: octowrap.export_tiles(h, tmp_path / "gil"), "export_tiles")
