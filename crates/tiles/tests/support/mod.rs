//! Test support: a coverage rasterizer, GLB triangle reading, the glTF-Validator gate.

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

use octowrap_geom::DVec3;

/// A pinhole camera over a square image; coverage only, back faces culled (counter-clockwise on
/// screen is front, as glTF's default).
pub struct Raster {
    eye: DVec3,
    right: DVec3,
    up: DVec3,
    forward: DVec3,
    focal: f64,
    size: usize,
}

impl Raster {
    pub fn new(eye: DVec3, target: DVec3, fov_y: f64, size: usize) -> Self {
        let forward = (target - eye).normalize();
        let right = forward.cross(DVec3::Z).normalize();
        let up = right.cross(forward);
        let focal = size as f64 * 0.5 / (fov_y * 0.5).tan();
        Self { eye, right, up, forward, focal, size }
    }

    pub fn focal_px(&self) -> f64 {
        self.focal
    }

    pub fn blank(&self) -> Vec<bool> {
        vec![false; self.size * self.size]
    }

    fn project(&self, p: DVec3) -> Option<(f64, f64)> {
        let d = p - self.eye;
        let z = d.dot(self.forward);
        (z > 1e-6).then(|| {
            let half = self.size as f64 * 0.5;
            (half + self.focal * d.dot(self.right) / z, half - self.focal * d.dot(self.up) / z)
        })
    }

    /// Marks the pixel centres inside the front-facing triangle `t`.
    pub fn fill(&self, image: &mut [bool], t: [DVec3; 3]) {
        let (Some(a), Some(b), Some(c)) = (self.project(t[0]), self.project(t[1]), self.project(t[2])) else {
            return;
        };
        // Screen y grows downwards, so counter-clockwise in the world is negative area here.
        let area = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
        if area >= 0.0 {
            return;
        }
        let edge = |p: (f64, f64), q: (f64, f64), x: f64, y: f64| (q.0 - p.0) * (y - p.1) - (q.1 - p.1) * (x - p.0);
        let n = self.size as f64;
        let x0 = a.0.min(b.0).min(c.0).floor().max(0.0) as usize;
        let x1 = (a.0.max(b.0).max(c.0).ceil().min(n - 1.0)).max(0.0) as usize;
        let y0 = a.1.min(b.1).min(c.1).floor().max(0.0) as usize;
        let y1 = (a.1.max(b.1).max(c.1).ceil().min(n - 1.0)).max(0.0) as usize;
        for y in y0..=y1 {
            for x in x0..=x1 {
                let (px, py) = (x as f64 + 0.5, y as f64 + 0.5);
                if edge(a, b, px, py) <= 0.0 && edge(b, c, px, py) <= 0.0 && edge(c, a, px, py) <= 0.0 {
                    image[y * self.size + x] = true;
                }
            }
        }
    }
}

/// The triangles of a GLB written without quantization, in the tileset's z-up frame (glTF's y-up
/// turned as 3D Tiles clients turn it), node transforms applied.
pub fn glb_triangles(file: &Path) -> Vec<[DVec3; 3]> {
    let bytes = std::fs::read(file).unwrap();
    let glb = gltf::Gltf::from_slice_without_validation(&bytes).unwrap();
    let blob = glb.blob.clone().unwrap();
    let mut out = Vec::new();
    for node in glb.document.nodes() {
        let Some(mesh) = node.mesh() else { continue };
        let m = node.transform().matrix();
        for prim in mesh.primitives() {
            let reader = prim.reader(|_| Some(&blob[..]));
            let pos: Vec<DVec3> = reader
                .read_positions()
                .unwrap()
                .map(|p| {
                    let p = [0, 1, 2].map(|r| m[0][r] * p[0] + m[1][r] * p[1] + m[2][r] * p[2] + m[3][r]);
                    DVec3::new(f64::from(p[0]), -f64::from(p[2]), f64::from(p[1]))
                })
                .collect();
            let idx: Vec<u32> = reader.read_indices().unwrap().into_u32().collect();
            for t in idx.chunks_exact(3) {
                out.push([pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize]]);
            }
        }
    }
    out
}

fn tools() -> PathBuf {
    octowrap_testdata::workspace_root().join("tools/tiles-check")
}

/// Prints SKIPPED with `why`, or fails when `OCTOWRAP_TILES_CHECKS=required` (set by `.ci/run`
/// when the tools are installed).
pub fn skip_or_fail(what: &str, why: &str) {
    assert!(
        std::env::var("OCTOWRAP_TILES_CHECKS").as_deref() != Ok("required"),
        "{what} is required here (OCTOWRAP_TILES_CHECKS=required) but cannot run: {why}"
    );
    #[allow(clippy::print_stdout)] // the SKIPPED line the test policy asks for
    {
        println!("SKIPPED {what}: {why}");
    }
}

/// Runs the Khronos glTF-Validator on every content of a tileset: 0 errors and 0 warnings.
pub fn validate_gltf(tileset: &Path) {
    let dir = tools();
    if !dir.join("node_modules/gltf-validator").is_dir() {
        return skip_or_fail("glTF-Validator on every tile", "tools/tiles-check is not installed (npm ci)");
    }
    let out = match Command::new("node").arg(dir.join("validate-tiles.mjs")).arg(tileset).output() {
        Ok(o) => o,
        Err(e) => return skip_or_fail("glTF-Validator on every tile", &format!("node cannot run: {e}")),
    };
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}\n{}", String::from_utf8_lossy(&out.stderr));
    assert!(text.contains(" 0 errors, 0 warnings"), "{text}");
}
