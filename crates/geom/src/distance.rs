//! Point-to-triangle distance.

use glam::DVec3;

/// Squared distance from `p` to triangle `t` (Ericson, "Real-Time Collision Detection", §5.1.5);
/// a degenerate triangle (zero area) measures as the nearest of its edges.
///
/// ```
/// use octowrap_geom::{DVec3, point_triangle_squared};
/// let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
/// assert_eq!(point_triangle_squared(DVec3::new(0.2, 0.2, 1.0), &t), 1.0);
/// ```
pub fn point_triangle_squared(p: DVec3, t: &[DVec3; 3]) -> f64 {
    closest_on_triangle(p, t).1
}

/// The point of triangle `t` nearest to `p`, as barycentric weights `[u, v, w]` of `t`'s corners
/// (non-negative, summing to 1: the point is `u t[0] + v t[1] + w t[2]`), with its squared
/// distance to `p` (the same as [`point_triangle_squared`]). A degenerate triangle (zero area)
/// gives the nearest point of its nearest edge.
///
/// ```
/// use octowrap_geom::{DVec3, closest_on_triangle};
/// let t = [DVec3::ZERO, DVec3::X, DVec3::Y];
/// let (w, d2) = closest_on_triangle(DVec3::new(0.25, 0.5, 2.0), &t);
/// assert_eq!((w, d2), ([0.25, 0.25, 0.5], 4.0));
/// // Beyond the corner `t[1]`: the corner itself.
/// assert_eq!(closest_on_triangle(DVec3::new(3.0, -1.0, 0.0), &t), ([0.0, 1.0, 0.0], 5.0));
/// ```
pub fn closest_on_triangle(p: DVec3, t: &[DVec3; 3]) -> ([f64; 3], f64) {
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ([1.0, 0.0, 0.0], ap.length_squared());
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return ([0.0, 1.0, 0.0], bp.length_squared());
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return ([1.0 - v, v, 0.0], (p - (a + ab * v)).length_squared());
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return ([0.0, 0.0, 1.0], cp.length_squared());
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return ([1.0 - w, 0.0, w], (p - (a + ac * w)).length_squared());
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return ([0.0, 1.0 - w, w], (p - (b + (c - b) * w)).length_squared());
    }
    let denom = va + vb + vc;
    if denom.abs() <= 0.0 || !denom.is_finite() {
        // Degenerate triangle: the nearest point of its three edges.
        let edges = [(0, 1), (1, 2), (2, 0)];
        let mut best = ([1.0, 0.0, 0.0], f64::INFINITY);
        for (i, j) in edges {
            let (s, d2) = seg(p, t[i], t[j]);
            if d2 < best.1 {
                let mut w = [0.0; 3];
                w[i] = 1.0 - s;
                w[j] = s;
                best = (w, d2);
            }
        }
        return best;
    }
    let (v, w) = (vb / denom, vc / denom);
    ([1.0 - v - w, v, w], (p - (a + ab * v + ac * w)).length_squared())
}

/// The parameter `s` of the point of segment `a b` nearest to `p` (`a + s (b - a)`), with its
/// squared distance.
fn seg(p: DVec3, a: DVec3, b: DVec3) -> (f64, f64) {
    let d = b - a;
    let l = d.length_squared();
    let s = if l > 0.0 { ((p - a).dot(d) / l).clamp(0.0, 1.0) } else { 0.0 };
    (s, (p - (a + d * s)).length_squared())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The weights rebuild a point whose distance is the one returned, on random triangles,
    /// including degenerate ones.
    #[test]
    fn weights_rebuild_the_nearest_point() {
        let mut s = 0x9e37_79b9_7f4a_7c15_u64;
        let mut r = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 11) as f64 / (1u64 << 53) as f64 * 4.0 - 2.0
        };
        for i in 0..2000 {
            let mut t = [DVec3::new(r(), r(), r()), DVec3::new(r(), r(), r()), DVec3::new(r(), r(), r())];
            if i % 10 == 0 {
                t[2] = t[0].lerp(t[1], 0.3); // collinear
            }
            let p = DVec3::new(r(), r(), r()) * 2.0;
            let (w, d2) = closest_on_triangle(p, &t);
            assert!(w.iter().all(|&x| (-1e-12..=1.0 + 1e-12).contains(&x)), "{w:?}");
            assert!((w.iter().sum::<f64>() - 1.0).abs() < 1e-12);
            let q = t[0] * w[0] + t[1] * w[1] + t[2] * w[2];
            assert!((q.distance_squared(p) - d2).abs() <= 1e-9 * (1.0 + d2), "{i}: {} vs {d2}", q.distance_squared(p));
            // No point of the triangle is nearer (sampled).
            for a in 0..=10 {
                for b in 0..=(10 - a) {
                    let (u, v) = (f64::from(a) / 10.0, f64::from(b) / 10.0);
                    let x = t[0] * (1.0 - u - v) + t[1] * u + t[2] * v;
                    assert!(x.distance_squared(p) >= d2 - 1e-9);
                }
            }
        }
    }
}
