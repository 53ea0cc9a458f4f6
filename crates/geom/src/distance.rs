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
    let [a, b, c] = *t;
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return ap.length_squared();
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return bp.length_squared();
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return (p - (a + ab * v)).length_squared();
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return cp.length_squared();
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return (p - (a + ac * w)).length_squared();
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (p - (b + (c - b) * w)).length_squared();
    }
    let denom = va + vb + vc;
    if denom.abs() <= 0.0 || !denom.is_finite() {
        // Degenerate triangle: the nearest of its three edges.
        return seg2(p, a, b).min(seg2(p, b, c)).min(seg2(p, c, a));
    }
    let (v, w) = (vb / denom, vc / denom);
    (p - (a + ab * v + ac * w)).length_squared()
}

fn seg2(p: DVec3, a: DVec3, b: DVec3) -> f64 {
    let d = b - a;
    let l = d.length_squared();
    let t = if l > 0.0 { ((p - a).dot(d) / l).clamp(0.0, 1.0) } else { 0.0 };
    (p - (a + d * t)).length_squared()
}
