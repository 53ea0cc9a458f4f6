//! Issue 7: the Stanford dragon (871,414 triangles) decimated to 10 % and 1 % by octowrap and by
//! meshoptimizer (`meshopt::simplify`, default options, no error limit), side by side: time,
//! faces reached, and the symmetric Hausdorff distance to the input, certified
//! (`metrics::certified_hausdorff`, an upper bound within 1 % of a distance found, the figure
//! octowrap reports) and sampled (`metrics::distance`, 1 M area samples per mesh plus the
//! vertices), and the sampled RMS distance. octowrap's time is the decimation alone
//! (`measure: false`, as meshoptimizer does not measure); the time of its certified measurement
//! is a column of its own. The last column is each tool's own quick estimate: octowrap's quadric
//! error, meshoptimizer's `result_error` (converted from its largest-extent unit to the
//! diagonal).

use octowrap_decimate::metrics::{Sampling, certified_hausdorff, distance};
use octowrap_decimate::{DecimateOptions, decimate};
use octowrap_io::{ReadOptions, read_path};
use octowrap_mesh::{FaceList, Mesh};

use crate::util::{best_of, shared_data};

/// Prints the decimation table.
pub fn report() {
    println!("## Decimation (issue 7)");
    println!();
    let Some(dir) = shared_data() else {
        println!("(shared data absent: the dragon is needed; skipped)");
        return;
    };
    let path = dir.join("stanford-dragon/dragon_vrip.ply.gz");
    let mesh = match read_path(&path, &ReadOptions::default()) {
        Ok(m) => m,
        Err(e) => {
            println!("(cannot read {}: {e}; skipped)", path.display());
            return;
        }
    };
    let faces = mesh.faces.len();
    let bounds = mesh.vertices.bounds();
    let diag = bounds.diagonal();
    // meshoptimizer reports its error relative to the largest side of the bounding box.
    let extent = bounds.size().max_element();
    let threads = rayon::current_num_threads();
    println!(
        "dragon: {faces} triangles, {} vertices, bbox diagonal {diag:.6}; octowrap on {threads} rayon threads, meshoptimizer on one; time = best of 5",
        mesh.vertex_count()
    );
    println!();
    println!(
        "| tool | target | faces reached | time (s) | measuring (s) | Hausdorff certified (% diag) | Hausdorff sampled (% diag) | RMS sampled (% diag) | quick estimate (% diag) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let indices: Vec<u32> = mesh.triangles().into_iter().flatten().collect();
    let bytes: Vec<u8> = mesh
        .vertices
        .positions
        .iter()
        .flat_map(|p| [p.x as f32, p.y as f32, p.z as f32])
        .flat_map(f32::to_ne_bytes)
        .collect();
    let sampling = Sampling::with_samples(1_000_000);
    for (label, ratio) in [("10 %", 0.1), ("1 %", 0.01)] {
        let target = (faces as f64 * ratio).round() as usize;
        let mut opts = DecimateOptions::target_faces(target);
        opts.measure = false;
        let (t, out) = best_of(5, || decimate(&mesh, &opts));
        match out {
            Ok(out) => {
                let (tm, c) = best_of(1, || certified_hausdorff(&mesh, &out.mesh));
                let d = distance(&mesh, &out.mesh, &sampling);
                println!(
                    "| octowrap | {label} ({target}) | {} | {t:.3} | {tm:.3} | {:.4} | {:.4} | {:.4} | {:.4} |",
                    out.mesh.faces.len(),
                    100.0 * c.upper / diag,
                    100.0 * d.hausdorff / diag,
                    100.0 * d.rms / diag,
                    100.0 * out.report.quadric_error / diag
                );
            }
            Err(e) => println!("| octowrap | {label} | failed: {e} | | | | | | |"),
        }
        let adapter = match meshopt::VertexDataAdapter::new(&bytes, 12, 0) {
            Ok(a) => a,
            Err(e) => {
                println!("| meshoptimizer | {label} | not run: {e} | | | | | | |");
                continue;
            }
        };
        let mut err = 0.0f32;
        let (t, idx) = best_of(5, || {
            meshopt::simplify(&indices, &adapter, target * 3, f32::MAX, meshopt::SimplifyOptions::None, Some(&mut err))
        });
        let tris: Vec<[u32; 3]> = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        let mut simplified = Mesh::from_positions(mesh.vertices.positions.clone());
        simplified.faces = FaceList::from_triangles(&tris);
        let d = distance(&mesh, &simplified, &sampling);
        let c = certified_hausdorff(&mesh, &simplified);
        println!(
            "| meshoptimizer 1.x | {label} ({target}) | {} | {t:.3} | | {:.4} | {:.4} | {:.4} | {:.4} |",
            tris.len(),
            100.0 * c.upper / diag,
            100.0 * d.hausdorff / diag,
            100.0 * d.rms / diag,
            100.0 * f64::from(err) * extent / diag
        );
    }
    println!();
}
