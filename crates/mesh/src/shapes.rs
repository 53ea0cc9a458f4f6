//! Parametric test shapes: triangulated grids, open or wrapped into a cylinder or a torus. The
//! benchmarks, examples and tests share them, so that "the 1 M-face torus" is one mesh everywhere.
//! Compiled with the `testing` feature only (a dev-dependency feature, not the library's API).

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

/// Area-uniform random points on a mesh's faces (first three corners of each), with Gaussian
/// noise: the bench's "dragon resampled to 4.3 M points". Point `i` depends only on `i` and the
/// mesh, so points can be drawn in any order or in parallel with the same result.
///
/// ```
/// use octowrap_mesh::shapes::{SurfaceSampler, torus};
/// let s = SurfaceSampler::new(&torus(8, 6, 2.0, 0.5));
/// let p = s.point(17, 0.0);
/// assert!(((p.x.hypot(p.y) - 2.0).hypot(p.z) - 0.5).abs() < 0.1);
/// assert_eq!(p, s.point(17, 0.0));
/// ```
pub struct SurfaceSampler {
    tris: Vec<[DVec3; 3]>,
    /// Running sum of the triangles' areas.
    cumulative: Vec<f64>,
}

impl SurfaceSampler {
    /// A sampler over `mesh`'s faces of 3 or more corners.
    pub fn new(mesh: &Mesh) -> Self {
        let p = &mesh.vertices.positions;
        let tris: Vec<[DVec3; 3]> = mesh
            .faces
            .iter()
            .filter(|f| f.len() >= 3)
            .map(|f| [p[f[0] as usize], p[f[1] as usize], p[f[2] as usize]])
            .collect();
        let mut total = 0.0;
        let cumulative = tris
            .iter()
            .map(|t| {
                total += (t[1] - t[0]).cross(t[2] - t[0]).length() * 0.5;
                total
            })
            .collect();
        Self { tris, cumulative }
    }

    /// Point number `i`, moved by Gaussian noise of standard deviation `sigma` on each axis.
    /// A mesh without faces gives the origin.
    pub fn point(&self, i: u64, sigma: f64) -> DVec3 {
        let (Some(&total), Some(last)) = (self.cumulative.last(), self.tris.len().checked_sub(1)) else {
            return DVec3::ZERO;
        };
        let mut s = i.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ 0xD1B5_4A32_D192_ED03;
        let mut next = || {
            s = s.wrapping_add(0x9E37_79B9_7F4A_7C15);
            let mut z = s;
            z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
            z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
            ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
        };
        let k = self.cumulative.partition_point(|&c| c < next() * total).min(last);
        let (mut u, mut v) = (next(), next());
        if u + v > 1.0 {
            u = 1.0 - u;
            v = 1.0 - v;
        }
        let t = &self.tris[k];
        let mut g = || {
            let (a, b) = (next().max(1e-300), next());
            (-2.0 * a.ln()).sqrt() * (std::f64::consts::TAU * b).cos()
        };
        let noise = DVec3::new(g(), g(), g()) * sigma;
        t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v + noise
    }
}
