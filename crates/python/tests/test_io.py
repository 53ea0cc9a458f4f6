"""read / write: round trips through every writable format, errors with the file's name."""

import numpy as np
import pytest

import octowrap
from conftest import sphere


def quad_mesh():
    h = octowrap.reconstruct(sphere(8000), max_level=3)
    return h[3]


def test_every_writable_format_round_trips(tmp_path):
    level = quad_mesh()
    mesh = octowrap.Mesh(level.vertices, level.faces)
    assert set(octowrap.WRITABLE_FORMATS) == {"ply", "obj", "off", "stl", "xyz"}
    for ext in octowrap.WRITABLE_FORMATS:
        path = tmp_path / f"m.{ext}"
        if ext == "xyz":
            octowrap.write(path, octowrap.PointCloud(level.vertices))
            back = octowrap.read(path)
            assert isinstance(back, octowrap.PointCloud)
            np.testing.assert_array_equal(back.points, level.vertices)
            continue
        octowrap.write(path, mesh)
        back = octowrap.read(path)
        assert isinstance(back, octowrap.Mesh), ext
        if ext == "stl":
            # STL stores triangles with their corners: quads split along the shorter diagonal,
            # positions as float32.
            assert back.faces.shape == (2 * len(level.faces), 3)
            tri = back.vertices[back.faces]
            assert np.abs(tri - tri.astype(np.float32)).max() == 0
            assert np.allclose(np.unique(back.vertices, axis=0), np.unique(level.vertices, axis=0), atol=1e-6)
            continue
        np.testing.assert_array_equal(back.vertices, level.vertices, err_msg=ext)
        np.testing.assert_array_equal(back.faces, level.faces, err_msg=ext)
        assert back.faces.dtype == np.int64


def test_ascii_ply_and_attributes_round_trip(tmp_path):
    p = sphere(100)
    normals = p.astype(np.float32)
    colors = (np.arange(300) % 256).astype(np.uint8).reshape(100, 3)
    for ascii in (False, True):
        path = tmp_path / f"c{int(ascii)}.ply"
        octowrap.write(path, octowrap.PointCloud(p, normals=normals, colors=colors), ascii=ascii)
        back = octowrap.read(path)
        np.testing.assert_array_equal(back.points, p)
        np.testing.assert_array_equal(back.normals, normals)
        np.testing.assert_array_equal(back.colors, colors)
    assert octowrap.read(tmp_path / "c1.ply").normals.dtype == np.float32


def test_mixed_polygons_come_as_offsets_and_indices(tmp_path):
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [2, 0, 0]], dtype=float)
    faces = (np.array([0, 4, 7]), np.array([0, 1, 2, 3, 1, 4, 2]))
    octowrap.write(tmp_path / "mixed.obj", octowrap.Mesh(v, faces))
    back = octowrap.read(tmp_path / "mixed.obj")
    assert isinstance(back.faces, tuple)
    assert back.face_offsets.tolist() == [0, 4, 7]
    assert back.face_indices.tolist() == [0, 1, 2, 3, 1, 4, 2]
    assert back.triangles().tolist() == [[0, 1, 2], [0, 2, 3], [1, 4, 2]]


def test_errors_name_the_file(tmp_path):
    with pytest.raises(FileNotFoundError) as e:
        octowrap.read(tmp_path / "missing.ply")
    assert e.value.filename == str(tmp_path / "missing.ply")
    assert "missing.ply" in str(e.value)
    bad = tmp_path / "bad.ply"
    bad.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n")
    with pytest.raises(octowrap.FormatError) as e:
        octowrap.read(bad)
    assert isinstance(e.value, ValueError)
    assert str(e.value).startswith(f"{bad}: byte ") and "1000000000 vertices declared" in str(e.value)
    with pytest.raises(ValueError, match="writable format"):
        octowrap.write(tmp_path / "x.las", octowrap.PointCloud(sphere(10)))
    with pytest.raises(ValueError, match="xyz cannot hold faces"):
        octowrap.write(tmp_path / "x.xyz", octowrap.Mesh(np.eye(3), np.array([[0, 1, 2]])))
    with pytest.raises(ValueError, match="broken mesh"):
        octowrap.write(tmp_path / "x.ply", octowrap.Mesh(np.eye(3), np.array([[0, 1, 3]])))
    assert not (tmp_path / "x.ply").exists()
    with pytest.raises(OSError) as e:
        octowrap.write(tmp_path / "no" / "dir" / "x.ply", octowrap.PointCloud(sphere(10)))
    assert "x.ply" in str(e.value)


def test_to_trimesh_and_to_open3d():
    level = quad_mesh()
    colors = np.full((len(level.vertices), 3), 200, np.uint8)
    mesh = octowrap.Mesh(level.vertices, level.faces, colors=colors)
    try:
        import trimesh  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match="pip install trimesh"):
            mesh.to_trimesh()
    else:
        tm = mesh.to_trimesh()
        np.testing.assert_array_equal(tm.vertices, level.vertices)
        assert len(tm.faces) == 2 * len(level.faces)
        assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
        assert (tm.visual.vertex_colors[:, :3] == 200).all()
        assert len(octowrap.PointCloud(level.vertices).to_trimesh().vertices) == len(level.vertices)
    try:
        import open3d  # noqa: F401
    except ImportError:
        with pytest.raises(ImportError, match="pip install open3d"):
            mesh.to_open3d()
    else:
        o3 = mesh.to_open3d()
        assert len(o3.triangles) == 2 * len(level.faces) and o3.is_watertight()
