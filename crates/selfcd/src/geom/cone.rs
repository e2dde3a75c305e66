//! Normal cones: the paper's "positive vector", after Volino & Magnenat-Thalmann.
//!
//! A cone (axis a, half-angle h) bounds a set of unit normals n when
//! angle(n, a) <= h for each. If h < 90 degrees, a itself is a positive vector:
//! a . n > 0 for every normal under the cone.

use glam::DVec3;
use std::f64::consts::{FRAC_PI_2, PI};

/// Safety margin (radians) kept below 90 degrees before a cone counts as positive.
const POSITIVE_MARGIN: f64 = 1e-9;

/// A cone of directions: unit `axis` and `half_angle` in [0, PI]; PI means every direction.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NormalCone {
    /// Unit axis.
    pub axis: DVec3,
    /// Half-angle in radians; `PI` is the full sphere.
    pub half_angle: f64,
}

impl NormalCone {
    /// The cone holding every direction.
    pub const FULL: NormalCone = NormalCone { axis: DVec3::Z, half_angle: PI };

    /// The cone of triangle (a, b, c)'s normal, widened by the rounding error of
    /// the cross product so that it holds the exact normal. A degenerate
    /// triangle (no normal) gets the full cone.
    #[inline]
    pub fn of_triangle(a: DVec3, b: DVec3, c: DVec3) -> NormalCone {
        let (e1, e2) = (b - a, c - a);
        let n = e1.cross(e2);
        let len = n.length();
        let scale = e1.length() * e2.length();
        if !(len > 0.0) || len <= 64.0 * f64::EPSILON * scale {
            return NormalCone::FULL;
        }
        // |computed - exact| <= ~4 eps |e1||e2| per component; turn it into an angle.
        let err = (8.0 * f64::EPSILON * scale / len).min(1.0).asin();
        NormalCone { axis: n / len, half_angle: err }
    }

    /// True when a positive vector exists: every normal under the cone has a
    /// positive dot product with the axis.
    #[inline]
    pub fn is_positive(&self) -> bool {
        self.half_angle < FRAC_PI_2 - POSITIVE_MARGIN
    }

    /// Smallest cone (around the great-circle arc between the axes) holding both.
    pub fn merge(&self, o: &NormalCone) -> NormalCone {
        if self.half_angle >= PI || o.half_angle >= PI {
            return NormalCone::FULL;
        }
        let cross = self.axis.cross(o.axis);
        let s = cross.length();
        let d = s.atan2(self.axis.dot(o.axis)); // angle between axes, accurate at 0 and PI
        if d + o.half_angle <= self.half_angle {
            return *self;
        }
        if d + self.half_angle <= o.half_angle {
            return *o;
        }
        let half = 0.5 * (self.half_angle + d + o.half_angle);
        if half >= PI || s == 0.0 {
            return NormalCone::FULL;
        }
        // Rotate self.axis towards o.axis by (half - self.half_angle) about k = unit(a x b).
        let t = half - self.half_angle;
        let k = cross / s;
        let axis = (self.axis * t.cos() + k.cross(self.axis) * t.sin()).normalize();
        NormalCone { axis, half_angle: half + 4.0 * f64::EPSILON }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn merge_holds_both_cones() {
        let a = NormalCone::of_triangle(DVec3::ZERO, DVec3::X, DVec3::Y); // +z
        assert!(a.half_angle < 1e-12 && (a.axis - DVec3::Z).length() < 1e-15);
        let tilted = DVec3::new(1.0, 0.0, 1.0).normalize();
        let b = NormalCone { axis: tilted, half_angle: 0.1 };
        let m = a.merge(&b);
        for c in [a, b] {
            assert!(m.axis.dot(c.axis).clamp(-1.0, 1.0).acos() + c.half_angle <= m.half_angle + 1e-12);
        }
        assert!((m.half_angle - (FRAC_PI_4 + 0.1) / 2.0).abs() < 1e-12);
        assert!(m.is_positive());
        let down = NormalCone { axis: -DVec3::Z, half_angle: 0.0 };
        assert!(!a.merge(&down).is_positive());
        // Normals 90 degrees apart still have a positive vector (their bisector).
        let side = NormalCone { axis: DVec3::X, half_angle: 0.0 };
        assert!((a.merge(&side).half_angle - FRAC_PI_4).abs() < 1e-12);
    }

    #[test]
    fn degenerate_triangle_has_full_cone() {
        let c = NormalCone::of_triangle(DVec3::ZERO, DVec3::X, 2.0 * DVec3::X);
        assert_eq!(c.half_angle, PI);
        assert!(!c.is_positive());
    }

    use std::f64::consts::FRAC_PI_4;
}
