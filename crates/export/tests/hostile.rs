//! The export's writer never harms what it replaces, and degenerate input costs linear time.

use std::path::Path;

use octowrap_export::{Error, ExportOptions, to_glb, write_path};
use octowrap_mesh::{DVec3, FaceList, Hierarchy, Mesh};

fn square() -> Hierarchy {
    let mut m = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::new(1.0, 1.0, 0.0), DVec3::Y]);
    m.faces = FaceList::from_quads(&[[0, 1, 2, 3]]);
    Hierarchy::single(m)
}

fn names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> =
        std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    v.sort();
    v
}

#[cfg(unix)]
#[test]
fn a_link_stays_a_link_a_mode_is_kept_and_no_clobber_refuses() {
    use std::os::unix::fs::{MetadataExt, PermissionsExt};
    let dir = tempfile::tempdir().unwrap();
    let real = dir.path().join("real.glb");
    std::fs::write(&real, b"old").unwrap();
    std::fs::set_permissions(&real, std::fs::Permissions::from_mode(0o644)).unwrap();
    let link = dir.path().join("link.glb");
    std::os::unix::fs::symlink("real.glb", &link).unwrap();
    write_path(&link, &square(), &ExportOptions::default()).unwrap();
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert_eq!(&std::fs::read(&real).unwrap()[..4], b"glTF");
    assert_eq!(std::fs::metadata(&real).unwrap().mode() & 0o777, 0o644);

    let mut o = ExportOptions::default();
    o.no_clobber = true;
    let e = write_path(&real, &square(), &o).unwrap_err();
    assert!(matches!(e, Error::Io { .. }), "{e}");
    assert!(e.to_string().starts_with(&real.display().to_string()), "names the file: {e}");
    // .gltf: an existing .bin beside it is refused before the .gltf is written.
    std::fs::write(dir.path().join("m.bin"), b"keep").unwrap();
    assert!(write_path(&dir.path().join("m.gltf"), &square(), &o).is_err());
    assert_eq!(std::fs::read(dir.path().join("m.bin")).unwrap(), b"keep");
    assert_eq!(names(dir.path()), ["link.glb", "m.bin", "real.glb"], "no temporary, no .gltf");
}

#[test]
fn triangles_naming_a_vertex_twice_are_dropped_in_linear_time() {
    // 300,000 faces `f 1 1 1` and one real triangle: meshoptimizer's cache order is quadratic in a
    // vertex's valence, so these took minutes when written.
    let mut m = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X, DVec3::Y]);
    for _ in 0..300_000 {
        m.faces.push(&[0, 0, 0]);
    }
    m.faces.push(&[0, 1, 2]);
    let mut o = ExportOptions::default();
    o.meshopt = true;
    let (_, summary) = to_glb(&Hierarchy::single(m), &o).unwrap();
    assert_eq!(summary.levels[0].triangles, 1);
    assert_eq!(summary.levels[0].source_faces, 300_001);
    // Only degenerate triangles: nothing to draw, a named error.
    let mut d = Mesh::from_positions(vec![DVec3::ZERO, DVec3::X]);
    d.faces.push(&[0, 1, 1]);
    let e = to_glb(&Hierarchy::single(d), &o).unwrap_err();
    assert!(matches!(e, Error::Invalid { .. }), "{e}");
}
