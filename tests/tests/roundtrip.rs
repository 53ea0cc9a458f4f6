//! Round trips between all writable formats keep positions and faces.

use octowrap_geom::{DVec3, Vec3};
use octowrap_io::{Format, ReadOptions, WriteOptions, read_path, write_path};
use octowrap_mesh::{FaceList, Mesh};
use octowrap_testdata::file as shared_file;

/// Triangles, quads and a pentagon side by side, with coordinates that need f64
/// (georeferenced: UTM easting near 600 km, millimetres matter).
fn mixed_mesh() -> Mesh {
    let base = DVec3::new(600_123.456, 5_200_987.654, 123.001);
    let pts = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
        [2.0, 0.5, 0.25],
        [0.5, 2.0, 0.125],
        [-1.0, 0.5, 0.001],
        [1.5, 1.5, 1.5],
    ];
    let mut m = Mesh::from_positions(pts.iter().map(|p| base + DVec3::from_array(*p)).collect());
    m.faces = FaceList::default();
    m.faces.push(&[0, 1, 2, 3]);
    m.faces.push(&[1, 4, 2]);
    m.faces.push(&[3, 2, 7, 5]);
    m.faces.push(&[0, 3, 5, 6, 7]);
    m
}

fn roundtrip(mesh: &Mesh, ext: &str, ascii: bool) -> Mesh {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join(format!("m.{ext}"));
    let mut w = WriteOptions::default();
    w.ascii = ascii;
    write_path(&path, mesh, &w).unwrap_or_else(|e| panic!("writing {ext}: {e}"));
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names.len(), 1, "temporary files left behind: {names:?}");
    read_path(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("reading back {ext}: {e}"))
}

#[test]
fn polygon_formats_keep_positions_and_faces_exactly() {
    let m = mixed_mesh();
    for (ext, ascii) in [("ply", false), ("ply", true), ("obj", false), ("off", false)] {
        let back = roundtrip(&m, ext, ascii);
        assert_eq!(back.vertices.positions, m.vertices.positions, "{ext} ascii={ascii}");
        assert_eq!(back.faces, m.faces, "{ext} ascii={ascii}");
    }
}

#[test]
fn stl_keeps_the_surface_as_triangles() {
    let m = mixed_mesh();
    let expected_triangles: usize = m.faces.iter().map(|f| f.len() - 2).sum();
    for ascii in [false, true] {
        let back = roundtrip(&m, "stl", ascii);
        assert!(back.faces.all_triangles());
        assert_eq!(back.faces.len(), expected_triangles, "ascii={ascii}");
        // STL stores f32: every position comes back within f32 rounding of an input vertex.
        for p in &back.vertices.positions {
            let nearest = m.vertices.positions.iter().map(|q| (*q - *p).length()).fold(f64::INFINITY, f64::min);
            assert!(nearest <= 0.5, "STL vertex {p} is {nearest} from every input vertex");
        }
    }
}

#[test]
fn xyz_keeps_points_and_normals() {
    let mut m = mixed_mesh();
    m.faces = FaceList::default();
    m.vertices.normals =
        Some((0..m.vertex_count()).map(|i| Vec3::new(0.0, (i as f32).sin(), (i as f32).cos())).collect());
    let back = roundtrip(&m, "xyz", false);
    assert_eq!(back.vertices.positions, m.vertices.positions);
    assert_eq!(back.vertices.normals, m.vertices.normals);
}

#[test]
fn georeferenced_coordinates_survive_to_the_millimetre_in_binary_ply() {
    let m = mixed_mesh();
    let back = roundtrip(&m, "ply", false);
    for (a, b) in back.vertices.positions.iter().zip(&m.vertices.positions) {
        assert!((*a - *b).abs().max_element() < 1e-3, "{a} vs {b}");
    }
}

#[test]
fn real_files_convert_to_ply_and_back() {
    let files = [
        "cgal-data/points_3/kitten.xyz",
        "cgal-data/meshes/elephant.off",
        "lidar-las/autzen_trim.laz",
        "pcl-pcd/milk.pcd",
        "e57/bunnyInt19.e57",
        "mesh-defects/trimesh/not_convex.obj",
        "stanford-bunny/reconstruction/bun_zipper_res2.ply",
    ];
    for rel in files {
        let Some(path) = shared_file(rel) else { continue };
        let m = read_path(&path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let back = roundtrip(&m, "ply", false);
        assert_eq!(back.vertex_count(), m.vertex_count(), "{rel}");
        assert_eq!(back.faces, m.faces, "{rel}");
        for (a, b) in back.vertices.positions.iter().zip(&m.vertices.positions) {
            assert!(a == b || (*a - *b).abs().max_element() < 1e-3, "{rel}: {a} vs {b}");
        }
        // And back to the source format where octowrap writes it.
        let src = Format::from_path(&path).unwrap();
        if src.writable() {
            let again = roundtrip(&back, src.name(), false);
            assert_eq!(again.vertex_count(), m.vertex_count(), "{rel} back to {src}");
        }
    }
}
