"""distance and Mesh.distance: exact point-to-surface distances, computed in Rust."""

import importlib.util

import numpy as np
import pytest

import octowrap
from conftest import assert_gil_released, skip, sphere


def unit_cube():
    """The axis-aligned cube of edge 1 centred at the origin, six outward quads."""
    v = np.array([[x, y, z] for z in (-0.5, 0.5) for y in (-0.5, 0.5) for x in (-0.5, 0.5)], dtype=float)
    f = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [2, 6, 7, 3], [0, 4, 6, 2], [1, 3, 7, 5]])
    return octowrap.Mesh(v, f)


def test_distances_to_a_cube_are_the_closed_form():
    rng = np.random.default_rng(4)
    p = rng.uniform(-2, 2, size=(5000, 3))
    d = octowrap.distance(p, unit_cube())
    outside = np.linalg.norm(np.maximum(np.abs(p) - 0.5, 0.0), axis=1)
    inside = 0.5 - np.abs(p).max(axis=1)
    expected = np.where(outside > 0, outside, inside)
    assert d.dtype == np.float64 and d.shape == (len(p),)
    np.testing.assert_allclose(d, expected, rtol=0, atol=1e-12)
    assert (np.abs(p).max(axis=1) < 0.5).sum() > 50, "the sample must hold points inside"


def test_level_distance_agrees_with_trimesh():
    if importlib.util.find_spec("trimesh") is None or importlib.util.find_spec("rtree") is None:
        skip("the comparison needs trimesh and rtree (pip install trimesh rtree)")
    import trimesh

    h = octowrap.reconstruct(sphere(20000, seed=2), max_level=4)
    level = h[4]
    p = sphere(3000, seed=9) * np.random.default_rng(9).uniform(0.8, 1.2, size=(3000, 1))
    d = level.distance(p)
    np.testing.assert_array_equal(d, octowrap.distance(p, level))
    np.testing.assert_array_equal(d, octowrap.distance(p, level.vertices, level.faces))
    # Quads split along their shorter diagonal (the 0-2 one on a tie), as octowrap splits them.
    v, q = level.vertices, level.faces
    short02 = ((v[q[:, 0]] - v[q[:, 2]]) ** 2).sum(1) <= ((v[q[:, 1]] - v[q[:, 3]]) ** 2).sum(1)
    tris = np.concatenate([q[short02][:, [0, 1, 2]], q[short02][:, [0, 2, 3]], q[~short02][:, [0, 1, 3]], q[~short02][:, [1, 2, 3]]])
    _, reference, _ = trimesh.proximity.closest_point(trimesh.Trimesh(v, tris, process=False), p)
    # trimesh's answer is never nearer; it is farther by up to 1e-6 on a few points, where its
    # search misses the nearest triangle's nearest point.
    assert (d <= reference + 1e-12).all()
    assert (np.abs(d - reference) < 1e-9).mean() > 0.99 and np.abs(d - reference).max() < 1e-5
    assert d.max() > 0.1


def test_edge_cases_and_errors():
    cube = unit_cube()
    assert octowrap.distance(np.zeros((0, 3)), cube).shape == (0,)
    no_faces = octowrap.Mesh(cube.vertices, np.zeros((0, 3), dtype=np.int64))
    assert np.isinf(octowrap.distance(np.zeros((2, 3)), no_faces)).all()
    with pytest.raises(ValueError, match=r"points must be an array of float64 with shape \(N, 3\), found shape \(4,\)"):
        octowrap.distance(np.zeros(4), cube)
    with pytest.raises(ValueError, match="found dtype float32"):
        octowrap.distance(np.zeros((2, 3), dtype=np.float32), cube)
    with pytest.raises(ValueError, match=r"points must be finite; row 1 is \[NaN, 0.0, 0.0\]"):
        octowrap.distance(np.array([[0.0, 0, 0], [np.nan, 0, 0]]), cube)
    with pytest.raises(ValueError, match="broken input"):
        octowrap.distance(np.zeros((1, 3)), cube.vertices, np.array([[0, 1, 8]]))
    with pytest.raises(ValueError, match="pass a Level"):
        octowrap.distance(np.zeros((1, 3)), octowrap.reconstruct(sphere(5000), max_level=2))
    with pytest.raises(ValueError, match="needs a mesh"):
        octowrap.distance(np.zeros((1, 3)), octowrap.PointCloud(np.zeros((1, 3))))


def test_the_gil_is_released_while_measuring():
    level = octowrap.reconstruct(sphere(50000, seed=3), max_level=6)[6]
    p = sphere(1_000_000, seed=8) * 1.01
    assert_gil_released(lambda: octowrap.distance(p, level), "distance")
