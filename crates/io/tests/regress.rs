//! Every file in `tests/fixtures/regress/` (inputs that once broke a reader) reads cleanly: a mesh
//! or an error, never a panic, quickly, within a 256 MiB memory ceiling.

use std::path::Path;
use std::time::{Duration, Instant};

use octowrap_io::{Format, ReadOptions, read_from};

#[test]
fn every_regression_reads_cleanly() {
    let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/tests/fixtures/regress"));
    let mut opts = ReadOptions::default();
    opts.limits.max_memory = Some(256 << 20);
    let mut seen = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let Some(format) = Format::from_path(&path) else { continue };
        let mut o = opts.clone();
        o.format = Some(format);
        let data = std::fs::read(&path).unwrap();
        let t = Instant::now();
        let outcome = read_from(&data[..], &path, &o);
        assert!(t.elapsed() < Duration::from_secs(5), "{}: {:?}", path.display(), t.elapsed());
        if let Ok((_, mesh)) = outcome {
            assert!(mesh.vertices.attributes_consistent(), "{}", path.display());
        }
        seen += 1;
    }
    assert!(seen > 0 || std::fs::read_dir(dir).unwrap().count() == 1, "no regression files read");
}
