//! Any bytes as a Stanford `.conf` beside two small scans (`a.ply`, and `b.xyz` stored gzipped),
//! read by path as the CLI reads it: never panics, stays within the ceiling.
#![no_main]

use std::path::PathBuf;
use std::sync::OnceLock;

use libfuzzer_sys::fuzz_target;
use octowrap_fuzz::{holds, options};

fn folder() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("octowrap-fuzz-conf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("a scratch folder");
        let ply = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n\
                   end_header\n0 0 0\n1 0 0\n0 1 0\n";
        std::fs::write(dir.join("a.ply"), ply).expect("writing a.ply");
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        std::io::Write::write_all(&mut e, b"1 2 3\n4 5 6\n").expect("writing to memory");
        std::fs::write(dir.join("b.xyz.gz"), e.finish().expect("writing to memory")).expect("writing b.xyz.gz");
        dir
    })
}

fuzz_target!(|data: &[u8]| {
    let path = folder().join("set.conf");
    std::fs::write(&path, data).expect("writing set.conf");
    let mut opts = options(Some(octowrap_io::Format::Conf));
    opts.limits.max_scans = 64;
    if let Ok(mesh) = octowrap_io::read_path(&path, &opts) {
        holds(&mesh);
    }
});
