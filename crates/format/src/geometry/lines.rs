//! Prediction lines (spec §6.6 Line geometry, modes 1 and 2): the grid points along a vertex's
//! predicted normal through its base prediction, and the parameter of a point on them.

use crate::block::{LINE_PARAM_LIMIT, MAX_LINE_SHIFT};
use crate::geometry::predict::round_away;

/// A vertex's prediction line (spec §6.6): the grid points `base + round_away(j * u)` for integer
/// `j`, where `u` is the predicted normal scaled so that its largest component is exactly ±1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Line {
    /// The line's point for `j = 0` (the base prediction).
    pub base: [i64; 3],
    /// The direction, largest component `±2^shift`.
    pub u: [f64; 3],
}

impl Line {
    /// The line through `base` along `n` (`(0, 0, 1)` when `n` is zero), its points `2^shift`
    /// apart along the largest axis (`shift <= MAX_LINE_SHIFT`).
    #[inline]
    pub fn new(base: [i64; 3], n: [f64; 3], shift: u32) -> Self {
        Self { base, u: Self::direction(n, shift) }
    }

    /// The direction `u` of spec §6.6 for normal `n` and spacing exponent `shift`.
    #[inline]
    pub fn direction(n: [f64; 3], shift: u32) -> [f64; 3] {
        let m = n[0].abs().max(n[1].abs()).max(n[2].abs());
        let u = if m > 0.0 { [n[0] / m, n[1] / m, n[2] / m] } else { [0.0, 0.0, 1.0] };
        // Scaling by a power of two is exact.
        let scale = f64::from(1u32 << shift.min(MAX_LINE_SHIFT));
        [u[0] * scale, u[1] * scale, u[2] * scale]
    }

    /// The grid point of parameter `j` (`|j| <= LINE_PARAM_LIMIT`), saturating.
    #[inline]
    pub fn point(&self, j: i64) -> [i64; 3] {
        let jf = j as f64;
        [
            self.base[0].saturating_add(round_away(jf * self.u[0])),
            self.base[1].saturating_add(round_away(jf * self.u[1])),
            self.base[2].saturating_add(round_away(jf * self.u[2])),
        ]
    }

    /// The parameter of grid point `q` when `q` lies on the line (within the parameter limit).
    pub fn param(&self, q: [i64; 3]) -> Option<i64> {
        // The largest component is exactly ±2^shift by construction (spec §6.6).
        let top = self.u[0].abs().max(self.u[1].abs()).max(self.u[2].abs());
        #[allow(clippy::float_cmp)]
        let a = (0..3).find(|&a| self.u[a].abs() == top)?;
        let d = q[a].checked_sub(self.base[a])?;
        let step = self.u[a] as i64;
        if step == 0 || d % step != 0 {
            return None;
        }
        let j = d / step;
        (j.abs() <= LINE_PARAM_LIMIT && self.point(j) == q).then_some(j)
    }
}
