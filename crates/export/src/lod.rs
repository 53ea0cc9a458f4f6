//! Level-of-detail switching hints: each level's geometric error and the `MSFT_screencoverage`
//! values derived from it.
//!
//! Follows the `MSFT_lod` extension (Khronos glTF repository, `extensions/2.0/Vendor/MSFT_lod`):
//! the node holding the extension is the most detailed level; `ids` lists the other levels in
//! decreasing detail; `extras.MSFT_screencoverage[i]` is the screen coverage (the projected height
//! of the model's bounding sphere over the viewport height) down to which level `i` of that chain is
//! shown. One value per level; the last is 0, so the coarsest level is never culled.
//!
//! # The error estimate
//! A level's geometric error is its **mean edge length** (over every face's edges, in the input's
//! units). For a reconstructed hierarchy this is about the level's voxel edge, which bounds how far
//! the level can stray from the finest surface, and it needs no distance queries, so any mesh has
//! one. Level `i + 1` of the chain is good enough once its error, projected, covers at most
//! `max_screen_error` of the viewport height: with bounding radius `r`, an error `e` projects to
//! `e * c / (2 r)` at coverage `c`, so level `i` is shown down to `c_i = 2 r max_screen_error / e_{i+1}`
//! (clamped to `[0, 1]` and made non-increasing).

use octowrap_mesh::Mesh;

/// The mean length of the edges of `mesh`'s faces (each face contributes all its edges, so an edge
/// shared by two faces counts twice); 0 for a mesh without faces.
pub fn mean_edge_length(mesh: &Mesh) -> f64 {
    let p = &mesh.vertices.positions;
    let (mut sum, mut count) = (0.0, 0u64);
    for f in mesh.faces.iter() {
        for (k, &a) in f.iter().enumerate() {
            let b = f[(k + 1) % f.len()];
            if let (Some(pa), Some(pb)) = (p.get(a as usize), p.get(b as usize)) {
                sum += pa.distance(*pb);
                count += 1;
            }
        }
    }
    if count == 0 { 0.0 } else { sum / count as f64 }
}

/// `MSFT_screencoverage` values for a chain of levels in decreasing detail with geometric errors
/// `errors` (same order), a bounding-sphere radius `radius` and the tolerated projected error
/// `max_screen_error` (a fraction of the viewport height). See the module docs.
pub fn screen_coverage(errors: &[f64], radius: f64, max_screen_error: f64) -> Vec<f64> {
    let mut out = Vec::with_capacity(errors.len());
    let mut previous = 1.0f64;
    for i in 0..errors.len() {
        let c = match errors.get(i + 1) {
            None => 0.0,
            Some(&e) if e > 0.0 && e.is_finite() => (2.0 * radius * max_screen_error / e).clamp(0.0, 1.0),
            Some(_) => 1.0,
        };
        let c = if c.is_finite() { c.min(previous) } else { previous };
        out.push(c);
        previous = c;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use octowrap_geom::DVec3;
    use octowrap_mesh::FaceList;

    #[test]
    fn mean_edge_of_a_rectangle() {
        let mut m = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X * 2.0, DVec3::new(2.0, 1.0, 0.0), DVec3::Y]);
        m.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
        assert!((mean_edge_length(&m) - 1.5).abs() < 1e-12);
        assert!(mean_edge_length(&Mesh::default()).abs() < f64::EPSILON);
    }

    #[test]
    fn coverage_decreases_and_ends_at_zero() {
        // Finest first: errors grow with coarseness.
        let c = screen_coverage(&[0.001, 0.002, 0.004, 0.5], 0.1, 0.001);
        assert_eq!(c.len(), 4);
        assert!((c[0] - 0.1).abs() < 1e-12, "{c:?}");
        assert!((c[1] - 0.05).abs() < 1e-12, "{c:?}");
        assert!((c[2] - 0.0004).abs() < 1e-12, "{c:?}");
        assert!(c[3].abs() < f64::EPSILON);
        // A coarser level with a smaller error never switches back up.
        let c = screen_coverage(&[0.001, 0.004, 0.002], 0.1, 0.001);
        assert!(c.windows(2).all(|w| w[0] >= w[1]), "{c:?}");
        // Zero error: the coarser level is as good, so it is shown from coverage 1.
        assert_eq!(screen_coverage(&[0.0, 0.0], 1.0, 0.001), vec![1.0, 0.0]);
        assert_eq!(screen_coverage(&[0.3], 1.0, 0.001), vec![0.0]);
    }
}
