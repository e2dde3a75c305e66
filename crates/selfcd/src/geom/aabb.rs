//! Axis-aligned bounding boxes.

use glam::DVec3;

/// A closed axis-aligned box `[min, max]`; empty when any `min > max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: DVec3,
    /// Upper corner.
    pub max: DVec3,
}

impl Aabb {
    /// The empty box: the identity of `union`.
    pub const EMPTY: Aabb = Aabb {
        min: DVec3::INFINITY,
        max: DVec3::NEG_INFINITY,
    };

    /// Smallest box containing `points`. Exact: min and max are not rounded.
    #[inline]
    pub fn from_points(points: &[DVec3]) -> Aabb {
        points.iter().fold(Aabb::EMPTY, |b, &p| Aabb {
            min: b.min.min(p),
            max: b.max.max(p),
        })
    }

    /// Smallest box containing both.
    #[inline]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// True when the closed boxes share a point (touching counts).
    #[inline]
    pub fn overlaps(&self, o: &Aabb) -> bool {
        self.min.cmple(o.max).all() && o.min.cmple(self.max).all()
    }

    /// True when the gap between the boxes is at most `gap` along every axis
    /// (`gap` = 0: the closed boxes share a point, as [`overlaps`](Self::overlaps)).
    /// Both sides are compared and combined without an early exit, so loops
    /// of box tests (whose outcomes a branch predictor cannot guess) can fold
    /// them into masks without a branch.
    #[inline(always)]
    pub fn within(&self, o: &Aabb, gap: f64) -> bool {
        ((self.min - o.max).max_element() <= gap) & ((o.min - self.max).max_element() <= gap)
    }

    /// The box grown by `r` on every side.
    #[inline]
    pub fn inflate(&self, r: f64) -> Aabb {
        Aabb {
            min: self.min - DVec3::splat(r),
            max: self.max + DVec3::splat(r),
        }
    }

    /// Surface area (2 (xy + yz + zx)); zero-thickness boxes still have area.
    #[inline]
    pub fn surface_area(&self) -> f64 {
        let d = (self.max - self.min).max(DVec3::ZERO);
        2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
    }

    /// The largest coordinate magnitude of the box's corners: the scale the
    /// rounding slacks are taken against ([`super::magnitude`] of its points).
    #[inline]
    pub fn magnitude(&self) -> f64 {
        self.min.abs().max(self.max.abs()).max_element()
    }

    /// Centre of the box.
    #[inline]
    pub fn center(&self) -> DVec3 {
        0.5 * (self.min + self.max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn touching_boxes_overlap() {
        let a = Aabb::from_points(&[DVec3::ZERO, DVec3::ONE]);
        let b = Aabb::from_points(&[DVec3::new(1.0, 0.0, 0.0), DVec3::new(2.0, 1.0, 1.0)]);
        let c = Aabb::from_points(&[DVec3::new(1.5, 0.0, 0.0), DVec3::new(2.0, 1.0, 1.0)]);
        assert!(a.overlaps(&b) && b.overlaps(&a));
        assert!(!a.overlaps(&c));
        assert!(a.inflate(0.25).overlaps(&c.inflate(0.25)));
        assert_eq!(a.union(&c).surface_area(), 2.0 * (2.0 + 1.0 + 2.0));
        assert!(!Aabb::EMPTY.overlaps(&a));
        assert!(a.within(&b, 0.0) && !a.within(&c, 0.0) && a.within(&c, 0.5));
        assert!(!a.within(&c, 0.4999) && !Aabb::EMPTY.within(&a, 1.0));
    }
}
