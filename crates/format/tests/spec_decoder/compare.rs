//! The comparison with the reference decoder (`octowrap_format::decode`, the only item of the
//! crate the spec decoder's tests call).

use std::path::Path;

use octowrap_mesh::FaceOrigin;

use super::file::File;

/// Compares the spec decoder's result with the reference decoder's.
pub fn compare_with_reference(path: &Path, bytes: &[u8], ours: &File) {
    let name = path.display();
    let theirs = octowrap_format::decode(bytes, &octowrap_format::DecodeOptions::default())
        .unwrap_or_else(|e| panic!("{name}: the reference decoder fails: {e}"));
    let h = &theirs.hierarchy;
    assert_eq!(ours.levels.len(), h.levels.len(), "{name}: level count");
    assert_eq!(ours.cube, h.cube.map(|c| (c.min.to_array(), c.max.to_array())), "{name}: cube");
    let m = &theirs.info.metadata;
    let theirs_meta = (&m.units, &m.source, &m.generator, &m.entries);
    let ours_meta = (&ours.metadata.units, &ours.metadata.source, &ours.metadata.generator, &ours.metadata.entries);
    assert_eq!(ours_meta, theirs_meta, "{name}: metadata");
    for (k, (l, r)) in ours.levels.iter().zip(&h.levels).enumerate() {
        let bits = |p: &[[f64; 3]]| p.iter().map(|x| x.map(f64::to_bits)).collect::<Vec<_>>();
        let reference: Vec<[f64; 3]> = r.mesh.vertices.positions.iter().map(octowrap_mesh::DVec3::to_array).collect();
        assert_eq!(bits(&ours.positions[k]), bits(&reference), "{name} level {k}: positions");
        let faces: Vec<Vec<u32>> = r.mesh.faces.iter().map(<[u32]>::to_vec).collect();
        assert_eq!(l.faces, faces, "{name} level {k}: faces");
        let origins: Vec<Option<(u32, u8)>> = r
            .origins
            .iter()
            .map(|o| match o {
                FaceOrigin::Subface { parent, quadrant } => Some((*parent, quadrant.0)),
                FaceOrigin::Created => None,
            })
            .collect();
        assert_eq!(l.origins, origins, "{name} level {k}: origins");
        let lattice = r.lattice.as_ref().map(|x| (x.face_slots.clone(), x.vertex_corners.clone()));
        assert_eq!(l.slots.clone().zip(l.vertex_corners.clone()), lattice, "{name} level {k}: lattice");
    }
}
