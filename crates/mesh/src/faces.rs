//! Polygon face lists in compressed-row form.

use std::fmt;

/// Faces of 3 or more vertices each, stored as one index array plus offsets:
/// face `i` is `indices[offsets[i]..offsets[i + 1]]`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FaceList {
    offsets: Vec<u32>,
    indices: Vec<u32>,
}

impl Default for FaceList {
    fn default() -> Self {
        Self { offsets: vec![0], indices: Vec::new() }
    }
}

/// A face that breaks the face-list rules.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum IndexError {
    /// Face `face` refers to vertex `index`, but there are only `vertex_count` vertices.
    OutOfRange {
        /// Face number.
        face: usize,
        /// The offending index.
        index: u32,
        /// Number of vertices.
        vertex_count: usize,
    },
    /// Face `face` has fewer than 3 vertices.
    TooFewVertices {
        /// Face number.
        face: usize,
        /// Its vertex count.
        len: usize,
    },
}

impl fmt::Display for IndexError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::OutOfRange { face, index, vertex_count } => {
                write!(f, "face {face} refers to vertex {index}, but there are only {vertex_count} vertices")
            }
            Self::TooFewVertices { face, len } => {
                write!(f, "face {face} has {len} vertices; at least 3 are needed")
            }
        }
    }
}

impl std::error::Error for IndexError {}

impl FaceList {
    /// An empty list with room for `faces` faces of `corners` indices in all.
    pub fn with_capacity(faces: usize, corners: usize) -> Self {
        let mut offsets = Vec::with_capacity(faces + 1);
        offsets.push(0);
        Self { offsets, indices: Vec::with_capacity(corners) }
    }

    /// A list of quads.
    pub fn from_quads(quads: &[[u32; 4]]) -> Self {
        Self { offsets: (0..=quads.len() as u32).map(|i| i * 4).collect(), indices: quads.as_flattened().to_vec() }
    }

    /// A list of quads, taking over their storage (no copy of the indices: for the finest
    /// levels of large reconstructions, tens of megabytes not allocated twice).
    pub fn from_quad_vec(quads: Vec<[u32; 4]>) -> Self {
        let offsets = (0..=quads.len() as u32).map(|i| i * 4).collect();
        Self { offsets, indices: bytemuck::allocation::cast_vec(quads) }
    }

    /// A list of triangles.
    pub fn from_triangles(tris: &[[u32; 3]]) -> Self {
        Self { offsets: (0..=tris.len() as u32).map(|i| i * 3).collect(), indices: tris.as_flattened().to_vec() }
    }

    /// Appends a face. The face-size rule (3 or more) is checked by [`FaceList::check`], not here,
    /// so that readers can hold broken input for the validator to describe.
    pub fn push(&mut self, face: &[u32]) {
        self.indices.extend_from_slice(face);
        self.offsets.push(self.indices.len() as u32);
    }

    /// Appends a face from an iterator of indices.
    pub fn push_iter(&mut self, face: impl IntoIterator<Item = u32>) {
        self.indices.extend(face);
        self.offsets.push(self.indices.len() as u32);
    }

    /// Number of faces.
    pub fn len(&self) -> usize {
        self.offsets.len() - 1
    }

    /// Whether there are no faces.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Total number of face corners (sum of face sizes).
    pub fn corner_count(&self) -> usize {
        self.indices.len()
    }

    /// The vertex indices of face `i`.
    pub fn face(&self, i: usize) -> &[u32] {
        &self.indices[self.offsets[i] as usize..self.offsets[i + 1] as usize]
    }

    /// Iterates over the faces.
    pub fn iter(&self) -> impl ExactSizeIterator<Item = &[u32]> + '_ {
        self.offsets.windows(2).map(|w| &self.indices[w[0] as usize..w[1] as usize])
    }

    /// All indices, face after face.
    pub fn indices(&self) -> &[u32] {
        &self.indices
    }

    /// The offsets array (`len() + 1` entries, starting at 0).
    pub fn offsets(&self) -> &[u32] {
        &self.offsets
    }

    /// Whether every face is a quad.
    pub fn all_quads(&self) -> bool {
        self.offsets.windows(2).all(|w| w[1] - w[0] == 4)
    }

    /// Whether every face is a triangle.
    pub fn all_triangles(&self) -> bool {
        self.offsets.windows(2).all(|w| w[1] - w[0] == 3)
    }

    /// `(face size, count)` pairs, ascending by size.
    pub fn size_histogram(&self) -> Vec<(usize, usize)> {
        let mut h = std::collections::BTreeMap::new();
        for w in self.offsets.windows(2) {
            *h.entry((w[1] - w[0]) as usize).or_insert(0usize) += 1;
        }
        h.into_iter().collect()
    }

    /// Checks face sizes and index ranges, reporting the first offence.
    pub fn check(&self, vertex_count: usize) -> Result<(), IndexError> {
        for (face, f) in self.iter().enumerate() {
            if f.len() < 3 {
                return Err(IndexError::TooFewVertices { face, len: f.len() });
            }
            if let Some(&index) = f.iter().find(|&&i| i as usize >= vertex_count) {
                return Err(IndexError::OutOfRange { face, index, vertex_count });
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Taking over a quad vector gives the list that copying it gives, with its indices in place.
    #[test]
    fn quads_taken_over_equal_quads_copied() {
        let quads: Vec<[u32; 4]> = (0..1000u32).map(|i| [i, i + 1, 2 * i + 7, i ^ 5]).collect();
        let copied = FaceList::from_quads(&quads);
        let taken = FaceList::from_quad_vec(quads.clone());
        assert_eq!(taken, copied);
        assert_eq!(taken.len(), 1000);
        assert_eq!(taken.face(999), &quads[999]);
        assert_eq!(FaceList::from_quad_vec(Vec::new()), FaceList::default());
    }

    #[test]
    fn csr_layout_and_checks() {
        let mut f = FaceList::default();
        assert!(f.is_empty());
        f.push(&[0, 1, 2, 3]);
        f.push_iter([3, 2, 4]);
        assert_eq!(f.offsets(), &[0, 4, 7]);
        assert_eq!(f.iter().collect::<Vec<_>>(), vec![&[0, 1, 2, 3][..], &[3, 2, 4][..]]);
        assert!(f.check(5).is_ok());
        assert_eq!(f.check(4), Err(IndexError::OutOfRange { face: 1, index: 4, vertex_count: 4 }));
        f.push(&[1, 2]);
        assert_eq!(f.check(5), Err(IndexError::TooFewVertices { face: 2, len: 2 }));
        assert!(!f.all_quads());
        assert!(FaceList::from_quads(&[[0, 1, 2, 3]]).all_quads());
    }
}
