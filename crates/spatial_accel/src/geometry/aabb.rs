//! Axis-aligned bounding boxes: the bound every tree in this crate is built from.

use glam::{Affine3A, Vec3, Vec3A};

/// An axis-aligned box given by its two extreme corners.
///
/// `Aabb::EMPTY` (min = +inf, max = -inf) is the identity of [`Aabb::union`], so bounds can be
/// accumulated without a first-element special case. A box is *valid* when no coordinate is NaN
/// and `min <= max` on every axis; a zero-thickness box (min == max on an axis) is valid and is
/// hit by rays (see [`crate::Ray::intersect_aabb`]).
///
/// ```
/// use spatial_accel::Aabb;
/// use glam::Vec3A;
/// let a = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
/// let b = Aabb::new(Vec3A::splat(2.0), Vec3A::splat(3.0));
/// let u = a.union(&b);
/// assert_eq!(u.min, Vec3A::ZERO);
/// assert_eq!(u.max, Vec3A::splat(3.0));
/// assert_eq!(u.surface_area(), 54.0);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Aabb {
    /// The corner with the smallest coordinates.
    pub min: Vec3A,
    /// The corner with the largest coordinates.
    pub max: Vec3A,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

impl Aabb {
    /// The empty box: contains nothing, and is the identity of [`Aabb::union`].
    pub const EMPTY: Self = Self {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };

    /// The box that contains all of space.
    pub const EVERYTHING: Self = Self {
        min: Vec3A::NEG_INFINITY,
        max: Vec3A::INFINITY,
    };

    /// A box from its corners. No check is made: see [`Aabb::is_valid`].
    #[inline]
    pub fn new(min: impl Into<Vec3A>, max: impl Into<Vec3A>) -> Self {
        Self {
            min: min.into(),
            max: max.into(),
        }
    }

    /// The zero-size box at a point.
    #[inline]
    pub fn from_point(p: impl Into<Vec3A>) -> Self {
        let p = p.into();
        Self { min: p, max: p }
    }

    /// The smallest box containing every point (empty for no points).
    pub fn from_points<P: Into<Vec3A>>(points: impl IntoIterator<Item = P>) -> Self {
        points
            .into_iter()
            .fold(Self::EMPTY, |b, p| b.grow(p.into()))
    }

    /// A box from its centre and half extents (as Bevy's `Aabb` stores it).
    #[inline]
    pub fn from_center_half_extents(center: impl Into<Vec3A>, half: impl Into<Vec3A>) -> Self {
        let (c, h) = (center.into(), half.into());
        Self {
            min: c - h,
            max: c + h,
        }
    }

    /// True when no coordinate is NaN and `min <= max` on every axis.
    ///
    /// Infinite coordinates are allowed (a box may be unbounded); NaN never is, because a NaN
    /// bound makes every comparison false and silently removes a subtree from every query.
    #[inline]
    pub fn is_valid(&self) -> bool {
        // `min <= max` is false for NaN on either side, so this one test covers both rules.
        self.min.cmple(self.max).all()
    }

    /// True when every coordinate is finite and the box is valid.
    #[inline]
    pub fn is_finite(&self) -> bool {
        self.is_valid() && self.min.is_finite() && self.max.is_finite()
    }

    /// True when the box contains no point (min > max on some axis). NaN boxes are empty too.
    #[inline]
    pub fn is_empty(&self) -> bool {
        !self.is_valid()
    }

    /// The smallest box containing both.
    #[inline]
    pub fn union(&self, other: &Self) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// The overlap of two boxes (empty when they are disjoint).
    #[inline]
    pub fn intersection(&self, other: &Self) -> Self {
        Self {
            min: self.min.max(other.min),
            max: self.max.min(other.max),
        }
    }

    /// The smallest box containing this one and a point.
    #[inline]
    pub fn grow(&self, p: impl Into<Vec3A>) -> Self {
        let p = p.into();
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// This box pushed outwards by `margin` on every side (the "fat" bounds of dynamic trees).
    #[inline]
    pub fn expanded(&self, margin: impl Into<Vec3A>) -> Self {
        let m = margin.into();
        Self {
            min: self.min - m,
            max: self.max + m,
        }
    }

    /// `max - min`; negative for the empty box.
    #[inline]
    pub fn extent(&self) -> Vec3A {
        self.max - self.min
    }

    /// Half of [`Aabb::extent`].
    #[inline]
    pub fn half_extents(&self) -> Vec3A {
        (self.max - self.min) * 0.5
    }

    /// The centre of the box.
    #[inline]
    pub fn center(&self) -> Vec3A {
        (self.min + self.max) * 0.5
    }

    /// The centre of the box (the centroid of its volume); an alias of [`Aabb::center`] that
    /// reads better in build code, where primitives are split by centroid.
    #[inline]
    pub fn centroid(&self) -> Vec3A {
        self.center()
    }

    /// Surface area; 0 for the empty box (so empty children cost nothing under SAH).
    #[inline]
    pub fn surface_area(&self) -> f32 {
        2.0 * self.half_area()
    }

    /// Half the surface area, `xy + yz + zx`: the SAH only ever compares ratios of areas, so
    /// builders use this and save the multiply.
    #[inline]
    pub fn half_area(&self) -> f32 {
        let e = self.extent().max(Vec3A::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// [`Aabb::half_area`] in f64, from f64 extents: finite for every finite box, where the
    /// f32 products overflow to infinity past extents of about `1.8e19` (and `max - min`
    /// itself past half the float range). Sums of areas kept across edits use this: an
    /// infinite term never leaves a sum again (`inf - inf` is NaN).
    #[inline]
    pub(crate) fn half_area_f64(&self) -> f64 {
        let e = (self.max.as_dvec3() - self.min.as_dvec3()).max(glam::DVec3::ZERO);
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// Volume; 0 for the empty box.
    #[inline]
    pub fn volume(&self) -> f32 {
        let e = self.extent().max(Vec3A::ZERO);
        e.x * e.y * e.z
    }

    /// The axis (0 = x, 1 = y, 2 = z) along which the box is longest; ties go to the lowest axis.
    #[inline]
    pub fn longest_axis(&self) -> usize {
        let e = self.extent();
        if e.x >= e.y && e.x >= e.z {
            0
        } else if e.y >= e.z {
            1
        } else {
            2
        }
    }

    /// True when the point lies inside or on the boundary.
    #[inline]
    pub fn contains_point(&self, p: impl Into<Vec3A>) -> bool {
        let p = p.into();
        (self.min.cmple(p) & p.cmple(self.max)).all()
    }

    /// True when `other` lies entirely inside this box (boundaries may touch).
    #[inline]
    pub fn contains_aabb(&self, other: &Self) -> bool {
        (self.min.cmple(other.min) & other.max.cmple(self.max)).all()
    }

    /// True when the boxes share at least one point (touching counts).
    #[inline]
    pub fn intersects_aabb(&self, other: &Self) -> bool {
        (self.min.cmple(other.max) & other.min.cmple(self.max)).all()
    }

    /// Squared distance from a point to the box (0 inside).
    #[inline]
    pub fn distance_squared_to_point(&self, p: impl Into<Vec3A>) -> f32 {
        let p = p.into();
        let d = (self.min - p).max(p - self.max).max(Vec3A::ZERO);
        d.length_squared()
    }

    /// The world box of this local box under an affine transform.
    ///
    /// Arvo's method (Graphics Gems, 1990) in its min/max form: each output coordinate is the
    /// translation plus, per input axis, the smaller (larger) of the matrix entry times the
    /// box's low and high coordinate. This is the bound of the eight transformed corners, in
    /// a fraction of the work of transforming them. An empty box stays empty.
    ///
    /// Why not the centre/half-extent form: its rounding is relative to the centre and the
    /// extent, not to the corners. A box from `-100` to `1e30` has its centre and half extent
    /// at `5e29`, and `c - h` rounds its low corner up to `0`: the world box of an instance
    /// of such a mesh would leave out the mesh's ordinary triangles, and the top level would
    /// never offer rays to them.
    ///
    /// ```
    /// use spatial_accel::Aabb;
    /// use glam::{Affine3A, Vec3, Vec3A};
    /// let b = Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0));
    /// let m = Affine3A::from_scale_rotation_translation(
    ///     Vec3::splat(2.0), glam::Quat::IDENTITY, Vec3::new(10.0, 0.0, 0.0));
    /// let w = b.transformed(&m);
    /// assert_eq!(w.min, Vec3A::new(8.0, -2.0, -2.0));
    /// assert_eq!(w.max, Vec3A::new(12.0, 2.0, 2.0));
    /// ```
    pub fn transformed(&self, m: &Affine3A) -> Self {
        if self.is_empty() {
            return Self::EMPTY;
        }
        let (mut min, mut max) = (m.translation, m.translation);
        for (column, lo, hi) in [
            (m.matrix3.x_axis, self.min.x, self.max.x),
            (m.matrix3.y_axis, self.min.y, self.max.y),
            (m.matrix3.z_axis, self.min.z, self.max.z),
        ] {
            let (a, b) = (column * lo, column * hi);
            min += a.min(b);
            max += a.max(b);
        }
        Self { min, max }
    }

    /// The eight corners, in binary order of (x, y, z) = (min or max).
    pub fn corners(&self) -> [Vec3A; 8] {
        core::array::from_fn(|i| {
            Vec3A::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            )
        })
    }

    /// Component `axis` of the minimum corner.
    #[inline]
    pub fn min_on(&self, axis: usize) -> f32 {
        self.min[axis]
    }

    /// Component `axis` of the maximum corner.
    #[inline]
    pub fn max_on(&self, axis: usize) -> f32 {
        self.max[axis]
    }

    /// The box as plain `Vec3` corners (for callers outside the SIMD types).
    #[inline]
    pub fn to_vec3(&self) -> (Vec3, Vec3) {
        (self.min.into(), self.max.into())
    }
}
