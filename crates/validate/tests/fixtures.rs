//! The named pathology fixtures in `fixtures/meshes/` and the real defect meshes in
//! `../shared/data/mesh-defects/` give exactly the expected counts.

use std::path::{Path, PathBuf};

use octowrap_io::{ReadOptions, read_path};
use octowrap_validate::{Code, MeshReport, ValidateOptions, validate_mesh};

fn fixture(rel: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/meshes").join(rel)
}

fn check(path: &Path, weld: bool) -> MeshReport {
    let mesh = read_path(path, &ReadOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let mut o = ValidateOptions::default();
    o.weld = weld;
    validate_mesh(&mesh, &o)
}

/// Expected: (boundary edges, boundary loops, non-manifold edges, non-manifold vertices,
/// orientation conflicts, components, χ).
type Expect = (usize, usize, usize, usize, usize, usize, i64);

fn counts(r: &MeshReport) -> Expect {
    let c = &r.counts;
    (
        c.boundary_edges,
        c.boundary_loops,
        c.non_manifold_edges,
        c.non_manifold_vertices,
        c.orientation_conflicts,
        r.components.len(),
        r.euler_characteristic,
    )
}

#[test]
fn valid_fixtures() {
    let cube = check(&fixture("valid/cube_quads.obj"), false);
    assert_eq!(counts(&cube), (0, 0, 0, 0, 0, 1, 2));
    assert!(cube.properties.watertight && cube.properties.oriented && cube.properties.clean);
    assert_eq!(cube.components[0].genus, Some(0));
    assert!(cube.findings.is_empty(), "{:?}", cube.findings);

    let torus = check(&fixture("valid/torus_quads.obj"), false);
    assert_eq!(counts(&torus), (0, 0, 0, 0, 0, 1, 0));
    assert_eq!(torus.components[0].genus, Some(1));

    let open = check(&fixture("valid/open_box.obj"), false);
    assert_eq!(counts(&open), (4, 1, 0, 0, 0, 1, 1));
    assert!(open.properties.manifold && open.properties.oriented && !open.properties.closed);
    assert_eq!(open.components[0].genus, None);
    assert_eq!(open.findings.len(), 1);
    assert_eq!(open.findings[0].code, Code::BoundaryEdge);
}

#[test]
fn defect_fixtures() {
    let cases: &[(&str, Expect, Code)] = &[
        ("three_faces_one_edge.obj", (6, 1, 1, 0, 1, 1, 1), Code::NonManifoldEdge),
        ("hourglass_vertex.obj", (6, 1, 0, 1, 0, 1, 1), Code::NonManifoldVertex),
        ("flipped_face.obj", (0, 0, 0, 0, 4, 1, 2), Code::Orientation),
        ("moebius.obj", (12, 1, 0, 0, 1, 1, 0), Code::Orientation),
        ("duplicate_face.obj", (0, 0, 0, 0, 0, 1, 2), Code::DuplicateFace),
    ];
    for (name, expect, first) in cases {
        let r = check(&fixture(&format!("defects/{name}")), false);
        assert_eq!(counts(&r), *expect, "{name}");
        assert_eq!(r.findings[0].code, *first, "{name}: {:?}", r.findings);
    }
    let d = check(&fixture("defects/degenerate_faces.obj"), false);
    assert_eq!((d.counts.degenerate_faces, d.counts.zero_area_faces, d.counts.unused_vertices), (1, 1, 1));
    assert_eq!(
        d.findings.iter().find(|f| f.code == Code::ZeroAreaFace).unwrap().elements,
        vec![octowrap_validate::Element::Face(2)]
    );
    assert!(d.properties.manifold && !d.properties.clean);
}

#[test]
fn self_intersections_are_found_exactly() {
    let mut o = ValidateOptions::default();
    o.self_intersections = true;
    let mesh = read_path(&fixture("defects/crossing_quads.obj"), &ReadOptions::default()).unwrap();
    let r = validate_mesh(&mesh, &o);
    assert_eq!(r.counts.self_intersections, Some(1));
    assert_eq!(r.properties.intersection_free, Some(false));
    assert_eq!(r.findings[0].elements, vec![octowrap_validate::Element::Faces(0, 1)]);
    // Valid meshes touch only along shared edges and at shared vertices: no false positives,
    // including the coplanar neighbours of the flat cube faces.
    for name in ["valid/cube_quads.obj", "valid/torus_quads.obj", "valid/open_box.obj"] {
        let mesh = read_path(&fixture(name), &ReadOptions::default()).unwrap();
        assert_eq!(validate_mesh(&mesh, &o).counts.self_intersections, Some(0), "{name}");
    }
    // Without the option the check does not run.
    assert_eq!(validate_mesh(&mesh, &ValidateOptions::default()).counts.self_intersections, None);
}

#[test]
fn clean_closed_shared_meshes_are_intersection_free() {
    let mut o = ValidateOptions::default();
    o.self_intersections = true;
    for name in ["elephant.off", "armadillo.off", "bunny00.off"] {
        let Some(path) = octowrap_testdata::file(&format!("cgal-data/meshes/{name}")) else { continue };
        let r = check(&path, false);
        assert!(r.properties.watertight && r.properties.oriented, "{name}");
        let mesh = read_path(&path, &ReadOptions::default()).unwrap();
        assert_eq!(validate_mesh(&mesh, &o).counts.self_intersections, Some(0), "{name}");
    }
}

#[test]
fn broken_indices_are_described_not_rejected() {
    let r = check(&fixture("defects/out_of_range.off"), false);
    assert_eq!((r.counts.out_of_range_faces, r.counts.short_faces), (1, 1));
    assert!(!r.properties.manifold);
    assert_eq!(r.findings[0].code, Code::IndexRange);
}

/// The table of `mesh-defects/PROVENANCE.md`: V, F, dup, boundary edges, non-manifold edges,
/// non-manifold vertices, zero-area faces, orientation conflicts, components, χ — measured
/// after welding exactly equal positions.
const TABLE: &[(&str, [i64; 10])] = &[
    ("trimesh/soup.stl", [300, 100, 0, 300, 0, 0, 0, 0, 100, 100]),
    ("trimesh/joined_tetrahedra.obj", [5, 8, 0, 0, 3, 0, 0, 6, 1, 4]),
    ("trimesh/shared.STL", [72, 24, 58, 0, 1, 0, 0, 2, 1, 3]),
    ("trimesh/not_convex.obj", [288, 96, 244, 0, 12, 0, 0, 24, 1, 8]),
    ("trimesh/multibody.stl", [96, 32, 76, 0, 0, 0, 0, 12, 2, 4]),
    ("trimesh/featuretype.STL", [10428, 3476, 8418, 576, 0, 0, 0, 0, 1, -16]),
    ("trimesh/busted.STL", [11634, 3878, 9693, 0, 0, 0, 0, 0, 1, 2]),
    ("trimesh/7_8ths_cube.stl", [72, 24, 58, 0, 0, 0, 0, 0, 1, 2]),
    ("trimesh/unit_cube.STL", [36, 12, 28, 0, 0, 0, 0, 0, 1, 2]),
    ("cgal/elephant-with-holes.off", [2798, 4463, 65, 1353, 0, 65, 0, 0, 1, -175]),
    ("cgal/holes.off", [4291, 8288, 0, 304, 0, 0, 0, 0, 1, -5]),
    ("cgal/degtri_sliding.off", [8, 8, 0, 6, 0, 0, 4, 0, 1, 1]),
    ("cgal/mesh_with_border.off", [548, 1014, 0, 80, 0, 0, 0, 0, 1, 1]),
];

#[test]
fn shared_defect_meshes_match_their_provenance_table() {
    let mut wrong = Vec::new();
    for (rel, e) in TABLE {
        let Some(path) = octowrap_testdata::file(&format!("mesh-defects/{rel}")) else { continue };
        let r = check(&path, true);
        let c = &r.counts;
        let got = [
            r.vertices as i64,
            r.faces as i64,
            r.welded_vertices as i64,
            c.boundary_edges as i64,
            c.non_manifold_edges as i64,
            c.non_manifold_vertices as i64,
            c.zero_area_faces as i64,
            c.orientation_conflicts as i64,
            r.components.len() as i64,
            r.euler_characteristic,
        ];
        // V is the raw count; the checks run on the welded mesh.
        let got = [got[0] + got[2], got[1], got[2], got[3], got[4], got[5], got[6], got[7], got[8], got[9]];
        if got != *e {
            wrong.push(format!("{rel}: got {got:?}, table says {e:?}"));
        }
    }
    assert!(wrong.is_empty(), "\n{}", wrong.join("\n"));
}
