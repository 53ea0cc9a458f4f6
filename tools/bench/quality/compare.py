#!/usr/bin/env python3
"""Reconstruction quality beside the installed peers, per shared scan.

Usage: python3 tools/bench/quality/compare.py [--octowrap BIN] [--data DIR] [--only NAME,...]
       [--lod] [--intersections] [--out DIR]

For each scan (the bunny, Lucy, the kitten, the dragon, the LiDAR tile autzen_trim) it runs
`octowrap reconstruct` with its defaults and every peer that is installed, and prints one
markdown table: faces, the RMS of the points-to-mesh distance and the symmetric Hausdorff
distance, both as fractions of the points' bounding-box diagonal, and the wall time.

Peers (a missing one prints a row saying SKIPPED and why):
  * PoissonRecon (Kazhdan's screened Poisson), depth 8, when a `PoissonRecon` binary is on PATH;
  * Open3D's screened Poisson, depth 8 (PoissonRecon's code inside Open3D), when `open3d` imports;
  * Open3D's ball pivoting (radii 1, 2, 4 times the mean nearest-neighbour spacing);
  * CGAL's advancing front, when the `cgal` Python bindings import.
Poisson and ball pivoting need normals: estimated from 20 neighbours and oriented consistently
(LiDAR: towards the sky).

--lod adds the LOD-efficiency table: every level of octowrap's default hierarchy against
`octowrap decimate` (quadric) of its finest level to the same face count, points-to-mesh RMS
both, and their ratio (the target is at most 1.3 from level 3 up).
--intersections adds intersecting face pairs per level (`octowrap validate
--self-intersections`) for every scan.

Distances are computed with Open3D (exact point-to-triangle distance; a quad counts as two
triangles split along the diagonal from its first corner, as `octowrap validate` splits it), so
this script needs `open3d` for every table; without it, it prints SKIPPED and exits 0.
Install the peers with `pip install open3d-cpu cgal` (a virtual environment is fine).
"""

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time

SCANS = [
    ("bunny", "stanford-bunny/reconstruction/bun_zipper.ply", False),
    ("Lucy", "stanford-lucy-decimated/lucy.ply", False),
    ("kitten", "cgal-data/points_3/kitten.xyz", False),
    ("dragon", "stanford-dragon/dragon_vrip.ply.gz", False),
    ("autzen_trim", "lidar-las/autzen_trim.laz", True),
]


def run(cmd):
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed: {p.stderr.strip()[-400:]}")
    return time.perf_counter() - t, p.stderr


def read_points(o3d, bin_, path, work):
    ply = os.path.join(work, "points.ply")
    run([bin_, "convert", path, ply])
    pcd = o3d.io.read_point_cloud(ply)
    return pcd


def read_mesh(o3d, path):
    """A PLY mesh of quads or triangles as an Open3D triangle mesh (quads split 0-1-2, 0-2-3)."""
    import numpy as np

    verts, faces = read_ply_faces(path)
    tris = []
    for f in faces:
        for k in range(1, len(f) - 1):
            tris.append((f[0], f[k], f[k + 1]))
    m = o3d.geometry.TriangleMesh()
    m.vertices = o3d.utility.Vector3dVector(np.asarray(verts, dtype=np.float64))
    m.triangles = o3d.utility.Vector3iVector(np.asarray(tris, dtype=np.int32).reshape(-1, 3))
    return m, len(faces)


def read_ply_faces(path):
    """Vertices and polygon faces of a binary or ASCII PLY written by octowrap or Open3D."""
    import numpy as np

    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header") + len(b"end_header")
    end = data.index(b"\n", end) + 1
    header = data[:end].decode("ascii").splitlines()
    fmt = next(l.split()[1] for l in header if l.startswith("format"))
    elements, cur = [], None
    for l in header:
        w = l.split()
        if w[0] == "element":
            cur = [w[1], int(w[2]), []]
            elements.append(cur)
        elif w[0] == "property" and cur is not None:
            cur[2].append(w[1:])
    types = {"float": "f4", "float32": "f4", "double": "f8", "float64": "f8", "uchar": "u1", "uint8": "u1",
             "char": "i1", "int8": "i1", "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
             "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4"}
    if fmt == "ascii":
        body = data[end:].decode("ascii").split()
        pos = 0
        verts, faces = [], []
        for name, count, props in elements:
            for _ in range(count):
                row = []
                for p in props:
                    if p[0] == "list":
                        n = int(body[pos])
                        pos += 1
                        row.append([int(x) for x in body[pos:pos + n]])
                        pos += n
                    else:
                        row.append(float(body[pos]))
                        pos += 1
                if name == "vertex":
                    verts.append(row[:3])
                elif name == "face":
                    faces.append(row[0])
        return verts, faces
    order = "<" if fmt == "binary_little_endian" else ">"
    pos = end
    verts, faces = None, []
    for name, count, props in elements:
        if all(p[0] != "list" for p in props):
            dt = np.dtype([(p[1], order + types[p[0]]) for p in props])
            arr = np.frombuffer(data, dtype=dt, count=count, offset=pos)
            pos += dt.itemsize * count
            if name == "vertex":
                verts = np.stack([arr["x"], arr["y"], arr["z"]], axis=1).astype(np.float64)
            continue
        # A list element (faces): read row by row.
        p = props[0]
        ct, it = np.dtype(order + types[p[1]]), np.dtype(order + types[p[2]])
        for _ in range(count):
            n = int(np.frombuffer(data, dtype=ct, count=1, offset=pos)[0])
            pos += ct.itemsize
            idx = np.frombuffer(data, dtype=it, count=n, offset=pos)
            pos += it.itemsize * n
            if name == "face":
                faces.append([int(x) for x in idx])
    return verts, faces


def distances(o3d, pcd, mesh, samples=200_000):
    """(points-to-mesh RMS, symmetric Hausdorff), in world units."""
    import numpy as np

    pts = np.asarray(pcd.points)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(mesh))
    d = scene.compute_distance(o3d.core.Tensor(pts.astype(np.float32))).numpy().astype(np.float64)
    rms = float(np.sqrt(np.mean(d * d)))
    on = mesh.sample_points_uniformly(number_of_points=samples)
    on.points.extend(mesh.vertices)
    back = np.asarray(on.compute_point_cloud_distance(pcd))
    return rms, max(float(d.max()), float(back.max()))


def with_normals(o3d, pcd, lidar):
    pcd = o3d.geometry.PointCloud(pcd)
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(20))
    if lidar:
        import numpy as np

        top = np.asarray(pcd.points).max(axis=0) + [0, 0, 1000.0]
        pcd.orient_normals_towards_camera_location(top)
    else:
        pcd.orient_normals_consistent_tangent_plane(10)
    return pcd


def peers(o3d, pcd, lidar, work, cgal_max):
    """(name, mesh or None, faces, seconds, note) for every peer."""
    out = []
    exe = shutil.which("PoissonRecon")
    normals = None
    if o3d is not None:
        t = time.perf_counter()
        normals = with_normals(o3d, pcd, lidar)
        normal_time = time.perf_counter() - t
    if exe and normals is not None:
        src, dst = os.path.join(work, "oriented.ply"), os.path.join(work, "poisson.ply")
        o3d.io.write_point_cloud(src, normals)
        secs, _ = run([exe, "--in", src, "--out", dst, "--depth", "8"])
        m, nf = read_mesh(o3d, dst)
        out.append(("PoissonRecon d8", m, nf, secs + normal_time, ""))
    else:
        out.append(("PoissonRecon d8", None, 0, 0.0, "SKIPPED: no PoissonRecon on PATH"))
    if o3d is None:
        return out
    t = time.perf_counter()
    m, _ = o3d.geometry.TriangleMesh.create_from_point_cloud_poisson(normals, depth=8)
    out.append(("Open3D Poisson d8", m, len(m.triangles), time.perf_counter() - t + normal_time, ""))
    t = time.perf_counter()
    spacing = float(sum(normals.compute_nearest_neighbor_distance())) / len(normals.points)
    radii = o3d.utility.DoubleVector([spacing, 2 * spacing, 4 * spacing])
    m = o3d.geometry.TriangleMesh.create_from_point_cloud_ball_pivoting(normals, radii)
    out.append(("Open3D ball pivoting", m, len(m.triangles), time.perf_counter() - t + normal_time, ""))
    try:
        from CGAL.CGAL_Advancing_front_surface_reconstruction import advancing_front_surface_reconstruction
        from CGAL.CGAL_Kernel import Point_3
        from CGAL.CGAL_Point_set_3 import Point_set_3
        from CGAL.CGAL_Polyhedron_3 import Polyhedron_3
    except ImportError as e:
        out.append(("CGAL advancing front", None, 0, 0.0, f"SKIPPED: {e}"))
        return out
    import numpy as np

    if len(pcd.points) > cgal_max:
        out.append(("CGAL advancing front", None, 0, 0.0, f"SKIPPED: more than --cgal-max-points {cgal_max} points"))
        return out
    t = time.perf_counter()
    ps = Point_set_3()
    for p in np.asarray(pcd.points):
        ps.insert(Point_3(float(p[0]), float(p[1]), float(p[2])))
    poly = Polyhedron_3()
    advancing_front_surface_reconstruction(ps, poly)
    secs = time.perf_counter() - t
    dst = os.path.join(work, "afront.off")
    poly.write_to_file(dst)
    m = o3d.io.read_triangle_mesh(dst)
    out.append(("CGAL advancing front", m, len(m.triangles), secs, ""))
    return out


def intersecting_pairs(bin_, path):
    p = subprocess.run([bin_, "validate", path, "--self-intersections"], capture_output=True, text=True)
    m = re.search(r"pairs of intersecting faces: (\d+)", p.stdout + p.stderr)
    return int(m.group(1)) if m else 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    here = os.path.dirname(os.path.abspath(__file__))
    root = os.path.abspath(os.path.join(here, "..", "..", ".."))
    ap.add_argument("--octowrap", default=os.path.join(root, "target", "release", "octowrap"))
    ap.add_argument("--data", default=os.environ.get("OCTOWRAP_DATA", os.path.join(root, "..", "shared", "data")))
    ap.add_argument("--only", default="")
    ap.add_argument("--lod", action="store_true")
    ap.add_argument("--intersections", action="store_true")
    ap.add_argument("--no-peers", action="store_true")
    ap.add_argument("--out", default="")
    ap.add_argument("--cgal-max-points", type=int, default=60_000, help="CGAL's advancing front takes minutes past this")
    a = ap.parse_args()
    try:
        import open3d as o3d
    except ImportError:
        print("SKIPPED: open3d does not import (pip install open3d-cpu); every table needs its distances")
        return 0
    if not os.path.exists(a.octowrap):
        print(f"SKIPPED: no octowrap binary at {a.octowrap} (cargo build --release -p octowrap-cli)")
        return 0
    only = {s for s in a.only.split(",") if s}
    work = a.out or tempfile.mkdtemp(prefix="octowrap-quality-")
    os.makedirs(work, exist_ok=True)
    main_rows, lod_rows, cross_rows = [], [], []
    for name, rel, lidar in SCANS:
        if only and name not in only:
            continue
        path = os.path.join(a.data, rel)
        if not os.path.exists(path):
            main_rows.append(f"| {name} | SKIPPED: {path} is missing | | | | |")
            continue
        sub = os.path.join(work, name)
        os.makedirs(sub, exist_ok=True)
        pcd = read_points(o3d, a.octowrap, path, sub)
        diag = float(((pcd.get_max_bound() - pcd.get_min_bound()) ** 2).sum() ** 0.5)
        levels = os.path.join(sub, "levels")
        shutil.rmtree(levels, ignore_errors=True)
        out = os.path.join(sub, "octowrap.ply")
        secs, err = run([a.octowrap, "reconstruct", path, "-o", out, "--all-levels", levels])
        note = " ".join(l.strip() for l in err.splitlines() if "level" in l.lower())[:160]
        m, nf = read_mesh(o3d, out)
        rms, hd = distances(o3d, pcd, m)
        main_rows.append(
            f"| {name} | octowrap (default) | {nf} | {rms / diag:.2e} | {hd / diag:.2e} | {secs:.2f} | {note} |")
        if not a.no_peers:
            for peer, pm, pf, ps, pnote in peers(o3d, pcd, lidar, sub, a.cgal_max_points):
                if pm is None:
                    main_rows.append(f"| {name} | {peer} | | | | | {pnote} |")
                    continue
                prms, phd = distances(o3d, pcd, pm)
                main_rows.append(
                    f"| {name} | {peer} | {pf} | {prms / diag:.2e} | {phd / diag:.2e} | {ps:.2f} | {pnote} |")
        files = sorted((int(f[6:-4]), os.path.join(levels, f)) for f in os.listdir(levels) if f.startswith("level-"))
        if a.intersections:
            counts = [f"L{k}: {intersecting_pairs(a.octowrap, f)}" for k, f in files if k >= 1]
            cross_rows.append(f"| {name} | {', '.join(counts)} |")
        if a.lod and not lidar:
            finest = files[-1][1]
            for k, f in files:
                if k < 3:
                    continue
                m, nf = read_mesh(o3d, f)
                rms, _ = distances(o3d, pcd, m, samples=1000)
                dec = os.path.join(sub, f"decimated-{k}.ply")
                if k == files[-1][0]:
                    drms = rms
                else:
                    run([a.octowrap, "decimate", finest, "-o", dec, "--target-faces", str(nf)])
                    dm, _ = read_mesh(o3d, dec)
                    drms, _ = distances(o3d, pcd, dm, samples=1000)
                lod_rows.append(f"| {name} | {k} | {nf} | {rms / diag:.2e} | {drms / diag:.2e} | {rms / drms:.2f} |")
    print("| scan | method | faces | P→M RMS / diag | Hausdorff / diag | s | note |")
    print("|---|---|---|---|---|---|---|")
    print("\n".join(main_rows))
    if lod_rows:
        print()
        print("| scan | level | faces | level P→M RMS / diag | quadric decimation of the finest, same faces | ratio |")
        print("|---|---|---|---|---|---|")
        print("\n".join(lod_rows))
    if cross_rows:
        print()
        print("| scan | intersecting face pairs per level |")
        print("|---|---|")
        print("\n".join(cross_rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
