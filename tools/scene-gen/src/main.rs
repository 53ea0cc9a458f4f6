//! `scene-gen N -o scene.ply [--seed S] [--density D]`: a deterministic synthetic aerial scan of
//! `N` points written as binary PLY (x y z as doubles), streamed, so any size fits in memory.
//!
//! Point `i` depends only on `(seed, i)` (a SplitMix64 hash), so the same arguments give the
//! same bytes, and any range of points can be made on its own. The scene is a square of
//! `sqrt(N / D)` metres (`D` points per square metre, default 4):
//! * terrain (60 %): rolling hills, `z = 5 sin(x/80) cos(y/60) + 2 sin(x/17 + y/23)`;
//! * buildings (25 %): on a 60 m grid, half of the cells hold a box of 20-40 m sides and
//!   6-40 m height standing on the terrain; roofs take 60 % of a building's points, walls the rest;
//! * trees (12 %): on a 15 m grid, 30 % of the cells without a building hold a crown, a sphere
//!   of radius 2-5 m whose centre is 5-12 m above the terrain;
//! * noise (3 %): uniform up to 50 m above the terrain (birds, multipath).

use std::io::Write;
use std::path::PathBuf;

use anyhow::Context;
use clap::Parser;

/// Writes a deterministic synthetic scene as binary PLY.
#[derive(Debug, Parser)]
struct Args {
    /// Number of points.
    points: u64,
    /// Output file (.ply).
    #[arg(short = 'o', long)]
    output: PathBuf,
    /// Seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Points per square metre.
    #[arg(long, default_value_t = 4.0)]
    density: f64,
}

/// SplitMix64 of `x`.
fn mix(mut x: u64) -> u64 {
    x = x.wrapping_add(0x9E37_79B9_7F4A_7C15);
    x = (x ^ (x >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    x = (x ^ (x >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    x ^ (x >> 31)
}

/// A uniform number in `[0, 1)` from a hash.
fn unit(h: u64) -> f64 {
    (h >> 11) as f64 / (1u64 << 53) as f64
}

/// Uniform numbers in `[0, 1)` for stream `k` of point `i`.
struct Draw {
    seed: u64,
    i: u64,
    k: u64,
}

impl Draw {
    fn next(&mut self) -> f64 {
        self.k += 1;
        unit(mix(self.seed ^ mix(self.i.wrapping_mul(64).wrapping_add(self.k))))
    }
}

fn terrain(x: f64, y: f64) -> f64 {
    5.0 * (x / 80.0).sin() * (y / 60.0).cos() + 2.0 * (x / 17.0 + y / 23.0).sin()
}

/// The building of the 60 m cell `(cx, cy)`: (min x, min y, size x, size y, height), if any.
fn building(seed: u64, cx: i64, cy: i64) -> Option<[f64; 5]> {
    let h = mix(seed ^ mix((cx as u64).wrapping_mul(0x1_0000_0001) ^ (cy as u64).rotate_left(32) ^ 0xB1D));
    if unit(h) >= 0.5 {
        return None;
    }
    let r = |k: u64| unit(mix(h ^ k));
    let (sx, sy) = (20.0 + 20.0 * r(1), 20.0 + 20.0 * r(2));
    let (x0, y0) = (cx as f64 * 60.0 + (60.0 - sx) * r(3), cy as f64 * 60.0 + (60.0 - sy) * r(4));
    Some([x0, y0, sx, sy, 6.0 + 34.0 * r(5)])
}

/// Point `i` of the scene of side `side`.
fn point(seed: u64, i: u64, side: f64) -> [f64; 3] {
    let mut d = Draw { seed, i, k: 0 };
    let class = d.next();
    let (x, y) = (d.next() * side, d.next() * side);
    if class < 0.60 {
        return [x, y, terrain(x, y)];
    }
    if class < 0.85 {
        let (cx, cy) = ((x / 60.0).floor() as i64, (y / 60.0).floor() as i64);
        if let Some([x0, y0, sx, sy, h]) = building(seed, cx, cy) {
            let base = terrain(x0 + sx / 2.0, y0 + sy / 2.0);
            let (u, v) = (d.next(), d.next());
            if d.next() < 0.6 {
                return [x0 + u * sx, y0 + v * sy, base + h];
            }
            // A wall: one of the four sides, by perimeter.
            let t = u * 2.0 * (sx + sy);
            let (px, py) = if t < sx {
                (x0 + t, y0)
            } else if t < 2.0 * sx {
                (x0 + t - sx, y0 + sy)
            } else if t < 2.0 * sx + sy {
                (x0, y0 + t - 2.0 * sx)
            } else {
                (x0 + sx, y0 + t - 2.0 * sx - sy)
            };
            return [px, py, base + v * h];
        }
        return [x, y, terrain(x, y)];
    }
    if class < 0.97 {
        let (cx, cy) = ((x / 15.0).floor(), (y / 15.0).floor());
        let h = mix(seed ^ mix((cx as i64 as u64).wrapping_mul(0x9E37) ^ (cy as i64 as u64).rotate_left(29) ^ 0x7EE));
        let (tx, ty) = (cx * 15.0 + 7.5, cy * 15.0 + 7.5);
        let blocked = building(seed, (tx / 60.0).floor() as i64, (ty / 60.0).floor() as i64).is_some_and(
            |[x0, y0, sx, sy, _]| tx >= x0 - 5.0 && tx <= x0 + sx + 5.0 && ty >= y0 - 5.0 && ty <= y0 + sy + 5.0,
        );
        if unit(h) < 0.3 && !blocked {
            let r = 2.0 + 3.0 * unit(mix(h ^ 1));
            let cz = terrain(tx, ty) + 5.0 + 7.0 * unit(mix(h ^ 2));
            let z = 2.0 * d.next() - 1.0;
            let phi = d.next() * std::f64::consts::TAU;
            let s = (1.0 - z * z).sqrt();
            return [tx + r * s * phi.cos(), ty + r * s * phi.sin(), cz + r * z];
        }
        return [x, y, terrain(x, y)];
    }
    [x, y, terrain(x, y) + 50.0 * d.next()]
}

fn main() -> anyhow::Result<()> {
    let a = Args::parse();
    anyhow::ensure!(a.points > 0, "ask for at least one point");
    anyhow::ensure!(a.density.is_finite() && a.density > 0.0, "the density must be a positive number");
    let side = (a.points as f64 / a.density).sqrt();
    octowrap_fsutil::write_file(&a.output, &octowrap_fsutil::WriteOptions::default(), |w: &mut dyn Write| {
        write!(
            w,
            "ply\nformat binary_little_endian 1.0\ncomment octowrap scene-gen seed {} density {}\nelement vertex {}\n\
             property double x\nproperty double y\nproperty double z\nend_header\n",
            a.seed, a.density, a.points
        )?;
        let mut buf = Vec::with_capacity(24 * 65_536);
        let mut i = 0;
        while i < a.points {
            buf.clear();
            let end = (i + 65_536).min(a.points);
            for j in i..end {
                for v in point(a.seed, j, side) {
                    buf.extend_from_slice(&v.to_le_bytes());
                }
            }
            w.write_all(&buf)?;
            i = end;
        }
        Ok(())
    })
    .map_err(|e| match e {
        octowrap_fsutil::WriteError::Io(e) | octowrap_fsutil::WriteError::Write(e) => e,
    })
    .with_context(|| format!("writing {}", a.output.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn points_are_deterministic_and_in_the_scene() {
        let side = 500.0;
        let a: Vec<_> = (0..10_000).map(|i| point(7, i, side)).collect();
        let b: Vec<_> = (0..10_000).map(|i| point(7, i, side)).collect();
        assert_eq!(a, b);
        assert_ne!(a, (0..10_000).map(|i| point(8, i, side)).collect::<Vec<_>>());
        assert!(a.iter().all(|p| p.iter().all(|v| v.is_finite())));
        assert!(a.iter().all(|p| p[0] >= -5.0 && p[0] <= side + 45.0 && p[2] > -10.0 && p[2] < 100.0));
        // Roofs: some points stand well above any terrain (|terrain| <= 7).
        assert!(a.iter().filter(|p| p[2] > 10.0).count() > 500);
    }
}
