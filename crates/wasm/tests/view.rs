//! View-dependent streaming of a chunked file (crates/wasm/src/view.rs): a close camera fetches
//! only part of the file, the mesh equals the reader's cut of the same selection on the whole
//! file, and the budget drops pieces no cut uses.

use octowrap_format::select::{ViewCamera, in_view, select_for_view};
use octowrap_format::synthetic::{Edits, cube_hierarchy};
use octowrap_format::{ChunkedMrq, EncodeOptions, Limits, Quantization};
use octowrap_wasm::stream::LevelMesh;
use octowrap_wasm::view::View;

/// A chunked file of the synthetic cube hierarchy (6 levels, chunk shift 1).
fn chunked() -> Vec<u8> {
    let h = cube_hierarchy(6, Edits::none(), 1);
    let mut o = EncodeOptions::with_quantization(Quantization::Bits(14));
    o.version = 5;
    o.chunk_shift = 1;
    let mut bytes = octowrap_format::encode(&h, &o).unwrap();
    // Every chunk's geometric error: its level's distance from the finest, so that views refine.
    let chunks = ChunkedMrq::open(&bytes[..], &Limits::default()).unwrap().chunks();
    let finest = chunks.iter().map(|c| c.level).max().unwrap();
    let errors: Vec<f32> = chunks.iter().map(|c| 0.01 * ((1u32 << (finest - c.level)) - 1) as f32).collect();
    octowrap_format::set_chunk_errors(&mut bytes, &errors).unwrap();
    bytes
}

/// A camera close to the cube's corner (0, 0, 0), looking at it.
fn close() -> ViewCamera {
    ViewCamera {
        position: [-0.15, -0.15, -0.15],
        target: [0.1, 0.1, 0.1],
        up: [0.0, 0.0, 1.0],
        fov_y_degrees: 30.0,
        viewport_height_px: 1080.0,
        pixel_error: 40.0,
    }
}

/// Fetches what `v` asks for from `file` until it has a mesh; returns it and the bytes served.
fn view(v: &mut View, file: &[u8], camera: &ViewCamera) -> (LevelMesh, u64) {
    let mut served = 0;
    let mut fetch = |v: &mut View| {
        for (s, e) in v.next_ranges().unwrap() {
            v.push(s, &file[s as usize..e as usize]).unwrap();
            served += e - s;
        }
    };
    while v.info().is_none() {
        fetch(v);
    }
    v.select(camera, 1.5);
    for _ in 0..10 {
        fetch(v);
        if let Some(m) = v.cut().unwrap() {
            return (m, served);
        }
    }
    panic!("no mesh after 10 rounds of fetching");
}

#[test]
fn a_close_view_fetches_part_of_the_file_and_cuts_what_the_reader_cuts() {
    let file = chunked();
    let mut v = View::new(u64::MAX);
    let (mesh, served) = view(&mut v, &file, &close());
    assert!(served < file.len() as u64 * 3 / 4, "served {served} of {} bytes", file.len());
    // The same selection cut by the reader over the whole file.
    let mut reader = ChunkedMrq::open(&file[..], &Limits::default()).unwrap();
    let chunks = reader.chunks();
    let s = select_for_view(&chunks, &close(), 1.5);
    let seen = in_view(&chunks, &close(), 1.5);
    let cut = reader.cut_where(&s.drawn, |c| seen[c as usize]).unwrap();
    assert_eq!(mesh.faces as usize, cut.mesh.faces.len());
    assert_eq!(mesh.triangles.len(), 3 * cut.mesh.triangles().len());
    let stats = v.last_cut();
    assert_eq!(stats.drawn as usize, cut.drawn.len());
    assert_eq!(
        stats.finest_level,
        chunks.iter().map(|c| c.level).max().unwrap(),
        "the corner reaches the finest level"
    );
    assert_eq!(stats.unresolved, 0);
}

#[test]
fn the_budget_drops_pieces_no_cut_uses() {
    let file = chunked();
    let near = close();
    let far = ViewCamera { position: [1.15, 1.15, 1.15], target: [0.9, 0.9, 0.9], ..close() };
    // The same two views without a budget: every piece stays.
    let mut unbounded = View::new(u64::MAX);
    view(&mut unbounded, &file, &near);
    view(&mut unbounded, &file, &far);
    let mut v = View::new(4 << 10);
    view(&mut v, &file, &near);
    view(&mut v, &file, &far);
    // The pieces of the near view that the far one does not read are gone (the preamble stays).
    assert!(v.held() < unbounded.held(), "{} bytes held, {} without a budget", v.held(), unbounded.held());
    let (again, _) = view(&mut v, &file, &near);
    assert!(again.faces > 0, "dropped pieces are fetched again");
}

#[test]
fn a_truncated_file_is_reported_with_the_missing_range() {
    let file = chunked();
    let cut = &file[..file.len() - 100];
    let mut v = View::new(u64::MAX);
    v.set_file_len(cut.len() as u64).unwrap();
    while v.info().is_none() {
        for (s, e) in v.next_ranges().unwrap() {
            v.push(s, &cut[s as usize..e as usize]).unwrap();
        }
    }
    let whole = ViewCamera { position: [2.5, 2.5, 2.5], target: [0.5, 0.5, 0.5], pixel_error: 0.1, ..close() };
    v.select(&whole, 1.5);
    let mut failed = None;
    for _ in 0..10 {
        match v.next_ranges() {
            Ok(ranges) => {
                for (s, e) in ranges {
                    v.push(s, &cut[s as usize..(e as usize).min(cut.len())]).unwrap();
                }
                if v.cut().unwrap().is_some() {
                    break;
                }
            }
            Err(e) => {
                failed = Some(e.to_string());
                break;
            }
        }
    }
    // The view of the whole cube at the finest level reads the last chunks, past the end.
    let e = failed.expect("the truncation is reported");
    assert!(e.contains("truncated") && e.contains(&cut.len().to_string()), "{e}");
}
