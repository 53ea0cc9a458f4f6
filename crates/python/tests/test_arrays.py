"""Hostile arrays: a ValueError that says what to pass, never a crash."""

import numpy as np
import pytest

import octowrap
from conftest import sphere

GOOD = sphere(2000)


@pytest.mark.parametrize(
    "points, message",
    [
        (GOOD.astype(np.float32), "found dtype float32; pass numpy.asarray"),
        (GOOD.astype(np.int64), "found dtype int64"),
        (GOOD[:, :2].copy(), r"found shape \(2000, 2\) of float64"),
        (GOOD.reshape(-1), r"found shape \(6000,\)"),
        (GOOD[::2], "must be C-contiguous"),
        (np.asfortranarray(GOOD), "must be C-contiguous"),
        (GOOD.tolist(), "not list"),
        (np.zeros((0, 3)), "the point cloud is empty"),
        (np.array([]), r"found shape \(0,\)"),
        (np.where(np.arange(2000)[:, None] == 7, np.nan, GOOD), "1 of 2000 points have NaN or infinite coordinates"),
        (np.full((5, 3), np.inf), "5 of 5 points have NaN"),
        (np.ones((50, 3)), "distinct point position"),
    ],
)
def test_bad_points_are_value_errors(points, message):
    with pytest.raises(ValueError, match=message):
        octowrap.reconstruct(points, max_level=2)


@pytest.mark.parametrize(
    "kwargs, message",
    [
        ({"max_level": "deep"}, "max_level must be"),
        ({"max_level": -1}, "max_level must be"),
        ({"max_level": 0}, "outside the supported range"),
        ({"max_level": 99}, "outside the supported range"),
        ({"max_level": True}, "max_level must be"),
        ({"threads": 0}, "threads must be at least 1"),
        ({"min_points": float("nan")}, "min_points must be a positive number"),
        ({"region_density": 0.0}, "region density must be a positive"),
        ({"wrap_sparse": True, "region_levels": 1}, "exclude each other"),
    ],
)
def test_bad_options_are_value_errors(kwargs, message):
    with pytest.raises(ValueError, match=message):
        octowrap.reconstruct(GOOD, **kwargs)


@pytest.mark.parametrize(
    "faces, message",
    [
        (np.array([[0, 1, 2]], dtype=np.float64), "must hold integers"),
        (np.array([[0, -1, 2]]), "indices must lie in 0..2"),
        (np.array([[0, 1, 2, 3, 4, 5]])[:, ::2], "must be C-contiguous"),
        (np.array([0, 1, 2]), r"shape \(M, k\)"),
        ((np.array([0, 4]), np.array([0, 1, 2])), "offsets must start at 0"),
        ((np.array([1, 3]), np.array([0, 1, 2])), "offsets must start at 0"),
        ((np.array([0, 3]),), "must be \\(offsets, indices\\)"),
        ([[0, 1, 2]], "not list"),
    ],
)
def test_bad_faces_are_value_errors(faces, message):
    with pytest.raises(ValueError, match=message):
        octowrap.validate(np.eye(3), faces)


def test_wrong_attribute_lengths_and_types(tmp_path):
    with pytest.raises(ValueError, match="normals has 3 rows, but there are 4 positions"):
        octowrap.write(tmp_path / "a.ply", octowrap.PointCloud(np.zeros((4, 3)), normals=np.zeros((3, 3))))
    with pytest.raises(ValueError, match="colors must be an array of uint8"):
        octowrap.write(tmp_path / "a.ply", octowrap.PointCloud(np.zeros((4, 3)), colors=np.zeros((4, 3))))
    with pytest.raises(ValueError, match="requirement 'shiny'"):
        octowrap.validate(np.eye(3), np.array([[0, 1, 2]]), require=["shiny"])
    assert not list(tmp_path.iterdir())


def test_faces_out_of_range_are_reported_not_refused():
    r = octowrap.validate(np.eye(3), np.array([[0, 1, 7]]))
    assert not r["passed"]
    assert r["outcome"]["counts"]["out_of_range_faces"] == 1
    assert r["outcome"]["findings"][0]["code"] == "E-INDEX-RANGE"
