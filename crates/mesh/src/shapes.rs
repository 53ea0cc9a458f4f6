//! Parametric test shapes: triangulated grids, open or wrapped into a cylinder or a torus. The
//! benchmarks, examples and tests share them, so that "the 1 M-face torus" is one mesh everywhere.

use octowrap_geom::DVec3;

use crate::{FaceList, Mesh};

/// A grid of `nu × nv` cells, two triangles a cell (split along the same diagonal everywhere),
/// with the vertex of grid point `(i, j)` at `position(i / nu, j / nv)`. A wrapped direction
/// joins its last column of cells to the first (no seam vertices), so `wrap = [true, true]` gives a
/// closed torus, `[false, true]` a cylinder open at both ends, `[false, false]` a sheet. Vertex
/// `(i, j)` has index `i * columns + j`, `columns` being `nv` when `v` wraps and `nv + 1` when not;
/// faces run cell by cell in the same order, all oriented alike.
///
/// ```
/// use octowrap_mesh::shapes::triangulated_grid;
/// use octowrap_geom::DVec3;
/// let sheet = triangulated_grid(4, 3, [false, false], |u, v| DVec3::new(u, v, 0.0));
/// assert_eq!((sheet.vertex_count(), sheet.faces.len()), (20, 24));
/// ```
pub fn triangulated_grid(nu: u32, nv: u32, wrap: [bool; 2], position: impl Fn(f64, f64) -> DVec3) -> Mesh {
    let (rows, cols) = (if wrap[0] { nu } else { nu + 1 }, if wrap[1] { nv } else { nv + 1 });
    let positions = (0..rows)
        .flat_map(|i| (0..cols).map(move |j| (i, j)))
        .map(|(i, j)| position(f64::from(i) / f64::from(nu.max(1)), f64::from(j) / f64::from(nv.max(1))))
        .collect();
    let id = |i: u32, j: u32| (i % rows) * cols + (j % cols);
    let mut tris = Vec::with_capacity(2 * nu as usize * nv as usize);
    for i in 0..nu {
        for j in 0..nv {
            tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    let mut mesh = Mesh::from_positions(positions);
    mesh.faces = FaceList::from_triangles(&tris);
    mesh
}

/// A closed triangulated torus of `2 · nu · nv` faces around the z axis: tube radius `minor`, its
/// centre `major` from the axis, outward-facing, genus 1.
///
/// ```
/// let t = octowrap_mesh::shapes::torus(10, 6, 2.0, 0.7);
/// assert_eq!((t.vertex_count(), t.faces.len()), (60, 120));
/// ```
pub fn torus(nu: u32, nv: u32, major: f64, minor: f64) -> Mesh {
    triangulated_grid(nu, nv, [true, true], |u, v| {
        let (u, v) = (u * std::f64::consts::TAU, v * std::f64::consts::TAU);
        DVec3::new((major + minor * v.cos()) * u.cos(), (major + minor * v.cos()) * u.sin(), minor * v.sin())
    })
}
