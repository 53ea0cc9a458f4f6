//! A check of cuts (spec §11.5) for tests: the open edges of a cut that are not open edges of
//! the level they come from, and the edges it uses twice.

use std::collections::HashSet;

use octowrap_mesh::Hierarchy;

use crate::Cut;

/// A lattice edge: the corners of its two ends.
pub type CornerEdge = ([u32; 3], [u32; 3]);

/// What [`cut_cracks`] found.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CutCracks {
    /// Open directed edges of the cut that are no open edge of their face's level.
    pub foreign_open: usize,
    /// Directed edges the cut uses twice.
    pub twice: usize,
}

/// Per level of `h`: its open directed edges (by vertex: two vertices may share a lattice
/// corner), named by their lattice corners.
pub fn open_edges(h: &Hierarchy) -> Vec<HashSet<CornerEdge>> {
    h.levels
        .iter()
        .map(|l| {
            let Some(lattice) = &l.lattice else { return HashSet::new() };
            let corners = &lattice.vertex_corners;
            let mut half = HashSet::new();
            for f in l.mesh.faces.iter() {
                for i in 0..f.len() {
                    half.insert((f[i], f[(i + 1) % f.len()]));
                }
            }
            half.iter()
                .filter(|&&(a, b)| !half.contains(&(b, a)))
                .map(|&(a, b)| (corners[a as usize], corners[b as usize]))
                .collect()
        })
        .collect()
}

/// The cracks of `cut` against the levels' own open edges (`open`, from [`open_edges`] of the
/// file's hierarchy); `chunk_levels`: each chunk's level.
pub fn cut_cracks<S: std::hash::BuildHasher>(
    cut: &Cut,
    chunk_levels: &[u32],
    open: &[HashSet<CornerEdge, S>],
) -> CutCracks {
    let m = cut.lattice_level;
    let mut half: HashSet<(u32, u32)> = HashSet::new();
    let mut out = CutCracks::default();
    for f in cut.mesh.faces.iter() {
        for i in 0..f.len() {
            out.twice += usize::from(!half.insert((f[i], f[(i + 1) % f.len()])));
        }
    }
    for (fi, f) in cut.mesh.faces.iter().enumerate() {
        let k = chunk_levels[cut.face_chunks[fi] as usize];
        for i in 0..f.len() {
            let (a, b) = (f[i], f[(i + 1) % f.len()]);
            if half.contains(&(b, a)) {
                continue;
            }
            let corner = |v: u32| cut.lattice[v as usize].map(|x| (x >> (m - k)) as u32);
            if !open[k as usize].contains(&(corner(a), corner(b))) {
                out.foreign_open += 1;
            }
        }
    }
    out
}
