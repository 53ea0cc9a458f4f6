//! The level-by-level stream as the viewer's worker drives it, against a simulated range server:
//! what it asks for, what it decodes (the same level as the format's decoder), and how it fails
//! on truncated, corrupted, reordered and foreign bytes.

use std::ops::Range;

use octowrap_format::synthetic::{Edits, cube_hierarchy};
use octowrap_format::{DecodeError, DecodeOptions, EncodeOptions, Metadata};
use octowrap_wasm::stream::{FIRST_REQUEST_BYTES, Stream, StreamError};

/// A file of 6 synthetic levels, larger than the first request.
fn file(metadata_bytes: usize) -> Vec<u8> {
    let mut opts = EncodeOptions::default();
    if metadata_bytes > 0 {
        opts.metadata = Metadata { entries: vec![("note".into(), "x".repeat(metadata_bytes))], ..Metadata::default() };
    }
    let bytes = octowrap_format::encode(&cube_hierarchy(6, Edits::default(), 7), &opts).unwrap();
    assert!(bytes.len() as u64 > 2 * FIRST_REQUEST_BYTES, "the test file spans several requests: {}", bytes.len());
    bytes
}

/// Drives `s` as the worker does against a server holding `served`: fetches each range (cut at
/// the end, with the length announced), decodes every newly ready level. Returns the ranges
/// asked for, the levels decoded, and the error that stopped it.
fn drive(s: &mut Stream, served: &[u8]) -> (Vec<Range<u64>>, Vec<u32>, Option<StreamError>) {
    let (mut ranges, mut levels) = (Vec::new(), Vec::new());
    loop {
        let r = match s.next_range() {
            Ok(Some(r)) => r,
            Ok(None) => return (ranges, levels, None),
            Err(e) => return (ranges, levels, Some(e)),
        };
        ranges.push(r.clone());
        let end = (r.end as usize).min(served.len());
        if let Err(e) =
            s.set_file_len(served.len() as u64).and_then(|()| s.push(r.start, &served[r.start as usize..end]))
        {
            return (ranges, levels, Some(e));
        }
        if let Some(k) = s.ready_level().filter(|&k| levels.last().is_none_or(|&l| k > l)) {
            match s.decode(k) {
                Ok(m) => {
                    assert_eq!(m.level, k);
                    levels.push(k);
                }
                Err(e) => {
                    // As the worker does: show the finest intact level above the damage, then stop.
                    let shown = levels.last().map_or(0, |&l| l + 1);
                    if let Some(j) = (shown..k).rev().find(|&j| s.decode(j).is_ok()) {
                        levels.push(j);
                    }
                    return (ranges, levels, Some(e));
                }
            }
        }
    }
}

#[test]
fn streams_levels_in_order_and_decodes_what_the_format_decodes() {
    let bytes = file(0);
    let mut s = Stream::new(u64::MAX);
    let (ranges, levels, err) = drive(&mut s, &bytes);
    assert!(err.is_none(), "{err:?}");
    assert_eq!(ranges[0], 0..FIRST_REQUEST_BYTES);
    // Contiguous, each byte once, the whole file.
    for w in ranges.windows(2) {
        assert_eq!(w[0].end, w[1].start);
    }
    assert_eq!(ranges.last().unwrap().end, bytes.len() as u64);
    let info = s.info().unwrap();
    assert_eq!(*levels.last().unwrap() as usize, info.levels.len() - 1);
    // After the first request, one request per level.
    let first_levels = info.levels.iter().filter(|l| l.offset + l.stored_size <= FIRST_REQUEST_BYTES).count();
    assert_eq!(ranges.len(), 1 + info.levels.len() - first_levels);
    assert!(levels.windows(2).all(|w| w[1] == w[0] + 1), "{levels:?}");

    let whole = octowrap_format::decode(&bytes[..], &DecodeOptions::default()).unwrap();
    for (k, level) in whole.hierarchy.levels.iter().enumerate() {
        let m = s.decode(k as u32).unwrap();
        let want: Vec<f32> =
            level.mesh.vertices.positions.iter().flat_map(|p| [p.x as f32, p.y as f32, p.z as f32]).collect();
        assert_eq!(m.positions, want, "level {k}");
        assert_eq!(m.triangles, level.mesh.triangles().concat(), "level {k}");
        assert_eq!(m.faces as usize, level.mesh.faces.len());
    }
}

#[test]
fn a_long_preamble_takes_a_second_request() {
    let bytes = file(40_000);
    let mut s = Stream::new(u64::MAX);
    s.push(0, &bytes[..FIRST_REQUEST_BYTES as usize]).unwrap();
    assert!(s.info().is_none());
    let r = s.next_range().unwrap().unwrap();
    assert_eq!(r.start, FIRST_REQUEST_BYTES);
    s.push(r.start, &bytes[r.start as usize..r.end as usize]).unwrap();
    let info = s.info().expect("the preamble is complete after the second request");
    assert_eq!(r.end, info.preamble_size);
    assert_eq!(s.ready_level(), None);
}

#[test]
fn a_truncated_file_shows_its_complete_levels_then_names_the_cut() {
    let bytes = file(0);
    let info = octowrap_format::read_info(&bytes[..], &octowrap_format::Limits::default()).unwrap();
    let last = info.levels.last().unwrap();
    let cut = (last.offset + last.stored_size / 2) as usize;
    let mut s = Stream::new(u64::MAX);
    let (_, levels, err) = drive(&mut s, &bytes[..cut]);
    assert_eq!(*levels.last().unwrap() as usize, info.levels.len() - 2, "every complete level is shown");
    let msg = err.expect("the cut is reported").to_string();
    let want = format!(
        "truncated file: it ends at byte {cut}, but level {} needs bytes {}..{}",
        info.levels.len() - 1,
        last.offset,
        last.offset + last.stored_size
    );
    assert_eq!(msg, want);
}

#[test]
fn a_corrupted_level_fails_with_its_checksum_and_offset() {
    let mut bytes = file(0);
    let info = octowrap_format::read_info(&bytes[..], &octowrap_format::Limits::default()).unwrap();
    let k = info.levels.len() - 2;
    let l = &info.levels[k];
    bytes[(l.offset + l.stored_size / 2) as usize] ^= 0x40;
    let mut s = Stream::new(u64::MAX);
    let (_, levels, err) = drive(&mut s, &bytes);
    assert_eq!(*levels.last().unwrap() as usize, k - 1);
    let err = err.expect("the damage is reported");
    assert!(
        matches!(err, StreamError::Decode(DecodeError::ChecksumMismatch { offset, .. }) if offset == l.offset),
        "{err}"
    );
    assert!(err.to_string().contains(&format!("level {k}")), "{err}");
}

#[test]
fn bytes_after_the_last_level_are_reported() {
    let mut bytes = file(0);
    let end = bytes.len() as u64;
    bytes.extend_from_slice(&[0; 5]);
    let mut s = Stream::new(u64::MAX);
    let (_, _, err) = drive(&mut s, &bytes);
    assert!(matches!(err, Some(StreamError::TrailingBytes { end: e, extra: 5 }) if e == end), "{err:?}");
}

#[test]
fn foreign_reordered_and_changing_input_is_refused() {
    let mut s = Stream::new(u64::MAX);
    let err = s.push(0, b"<!doctype html><html>not found</html>").unwrap_err();
    assert!(matches!(err, StreamError::Decode(DecodeError::BadMagic { .. })), "{err}");

    let bytes = file(0);
    let mut s = Stream::new(u64::MAX);
    assert!(matches!(s.push(10, &bytes[10..20]), Err(StreamError::OutOfOrder { offset: 10, held: 0 })));
    s.set_file_len(bytes.len() as u64).unwrap();
    assert!(matches!(s.set_file_len(99), Err(StreamError::FileChanged { now: 99, .. })));
    // Overlapping bytes are taken once.
    s.push(0, &bytes[..100]).unwrap();
    s.push(50, &bytes[50..200]).unwrap();
    assert_eq!(s.held(), 200);
    assert!(matches!(s.decode(0), Err(StreamError::NotReady { .. })));
}

#[test]
fn the_budget_stops_the_stream_before_a_level_that_does_not_fit() {
    let bytes = file(0);
    let mut probe = Stream::new(u64::MAX);
    drive(&mut probe, &bytes);
    let n = probe.info().unwrap().levels.len() as u32;
    let estimates: Vec<u64> = (0..n).map(|k| probe.memory_estimate(k)).collect();
    assert!(estimates.windows(2).all(|w| w[0] < w[1]), "{estimates:?}");
    assert!(estimates[n as usize - 1] > 2 * bytes.len() as u64, "the estimate counts the decoded arrays");
    let mut s = Stream::new(estimates[n as usize - 2]);
    let (_, levels, err) = drive(&mut s, &bytes);
    assert!(err.is_none());
    assert_eq!(*levels.last().unwrap(), n - 2);
    assert_eq!(s.next_range().unwrap(), None);
}

#[test]
fn every_prefix_of_a_small_file_asks_for_the_rest_or_fails_cleanly() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/format/valid");
    let bytes = std::fs::read(root.join("v3_cube3_lattice_q12.mrq")).unwrap();
    for cut in 0..bytes.len() {
        let mut s = Stream::new(u64::MAX);
        s.push(0, &bytes[..cut]).unwrap();
        let r = s.next_range().unwrap().expect("more is needed");
        assert_eq!(r.start, cut as u64);
        s.set_file_len(cut as u64).unwrap();
        // Told the file ends here: a truncation error naming the cut, never a panic.
        match s.next_range() {
            Err(StreamError::Truncated { len, .. }) => assert_eq!(len, cut as u64),
            // Before the header is complete, the first request is simply cut to the file.
            Ok(Some(r)) => panic!("asks for {r:?} past the end {cut}"),
            Ok(None) => assert!(s.info().is_none_or(|i| i.levels.is_empty()), "cut {cut}"),
            Err(e) => panic!("cut {cut}: {e}"),
        }
    }
}
