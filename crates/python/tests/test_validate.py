"""validate: the command line's report, and agreement with trimesh on the defect meshes."""

import numpy as np
import pytest

import octowrap
from conftest import data, skip


def test_report_has_the_command_line_fields():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    tetra = np.array([[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    r = octowrap.validate(v, tetra, require=["watertight", "oriented", "clean"])
    assert r["passed"] and r["failed_requirements"] == [] and r["file"] == "<arrays>"
    out = r["outcome"]
    assert out["kind"] == "mesh"
    assert out["properties"] == {
        "manifold": True, "oriented": True, "closed": True, "watertight": True, "clean": True, "intersection_free": None,
    }
    assert out["euler_characteristic"] == 2 and out["components"][0]["genus"] == 0
    flipped = tetra.copy()
    flipped[0] = flipped[0][::-1]
    r = octowrap.validate(v, flipped, require=["watertight", "oriented"])
    assert r["failed_requirements"] == ["oriented"]
    assert [f["code"] for f in r["outcome"]["findings"]] == ["E-ORIENTATION"]
    assert r["outcome"]["counts"]["orientation_conflicts"] == 3
    r = octowrap.validate(v, tetra[:3], require="closed")
    assert r["failed_requirements"] == ["closed"] and r["outcome"]["counts"]["boundary_loops"] == 1
    r = octowrap.validate(v, tetra, require=["intersection-free"])
    assert r["outcome"]["properties"]["intersection_free"] is True


def _defect_meshes():
    root = data("mesh-defects")
    files = sorted(p for p in root.rglob("*") if p.suffix.lower() in {".stl", ".obj", ".off", ".ply"})
    assert files, f"no meshes under {root}"
    return files


def test_agrees_with_trimesh_where_both_define_the_property():
    try:
        import trimesh
    except ImportError:
        skip("trimesh is not installed (pip install trimesh)")
    compared = 0
    for path in _defect_meshes():
        mesh = octowrap.read(path)
        if not isinstance(mesh, octowrap.Mesh):
            continue
        stl = path.suffix.lower() == ".stl"
        # trimesh merges an STL's corners on load (process=True); octowrap welds bit-equal ones.
        tm = trimesh.load(path, force="mesh", process=stl)
        tri = octowrap.Mesh(mesh.vertices, mesh.triangles())
        r = octowrap.validate(tri.vertices, tri.faces, weld=stl)["outcome"]
        if stl and len(tm.vertices) != len(tri.vertices) - r["welded_vertices"]:
            # trimesh merged near-equal corners that octowrap keeps apart: not the same mesh.
            continue
        c = r["counts"]
        # trimesh: watertight = every edge has exactly two faces.
        assert tm.is_watertight == (c["boundary_edges"] == 0 and c["non_manifold_edges"] == 0), path.name
        # trimesh: winding consistent = the two faces of every two-face edge run it oppositely,
        # defined by both only where no edge has more than two faces.
        if c["non_manifold_edges"] == 0:
            assert tm.is_winding_consistent == (c["orientation_conflicts"] == 0), path.name
        compared += 1
    assert compared >= 5, compared
