//! A frustum with its side planes laid out lane-wise, for the boxes of a view's walk.

use super::{Aabb, Containment, Frustum};
use glam::{BVec4A, Vec4};

/// A [`Frustum`] with its first four planes (the side planes of a camera's frustum) also laid
/// out lane-wise: [`FrustumLanes::classify_aabb`] drops a box behind any of them in one
/// step, and otherwise gives [`Frustum::classify_aabb`]'s verdict; both verdicts are the same,
/// bit for bit.
///
/// Why: a view that sees a small part of the world drops most boxes it tests, each by
/// whichever side plane it lies behind. The plane-by-plane test leaves its loop at that plane,
/// a branch the predictor cannot learn when the boxes come in no spatial order (movers in the
/// order they joined a list, the children of a tree over scattered objects); the lane-wise
/// step has one branch a box, taken the same way for nearly every box. The boxes it keeps go
/// through the plane-by-plane test: testing every plane lane-wise for every box costs more
/// where boxes do come in spatial order and the loop's early exit is cheap. The distances are
/// computed in the same operations and order as [`Plane::signed_distance`](super::Plane::signed_distance)
/// (`(nx·x + ny·y) + nz·z`, then `+ d`), so each rounds alike.
///
/// ```
/// use spatial_accel::{Aabb, Containment, Frustum, FrustumLanes};
/// use glam::{Mat4, Vec3};
///
/// let view = Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
/// let projection = Mat4::perspective_rh(1.0, 1.0, 0.1, 100.0);
/// let frustum = Frustum::from_clip_from_world(&(projection * view));
/// let lanes = FrustumLanes::new(&frustum);
/// let ahead = Aabb::new(Vec3::new(-1.0, -1.0, -11.0), Vec3::new(1.0, 1.0, -9.0));
/// let aside = Aabb::new(Vec3::new(50.0, -1.0, -11.0), Vec3::new(52.0, 1.0, -9.0));
/// assert_eq!(lanes.classify_aabb(&ahead), Containment::Inside);
/// assert_eq!(lanes.classify_aabb(&aside), Containment::Outside);
/// assert_eq!(lanes.classify_aabb(&aside), frustum.classify_aabb(&aside));
/// ```
#[derive(Clone, Copy, Debug)]
pub struct FrustumLanes {
    frustum: Frustum,
    /// Normal components and offsets of planes 0-3, a plane a lane.
    nx: Vec4,
    ny: Vec4,
    nz: Vec4,
    d: Vec4,
    /// Where each normal's component is not negative (`Vec3A::cmpge(ZERO)` in the
    /// plane-by-plane test, true for -0.0 too): there the corner farthest along the normal
    /// takes the box's maximum.
    px: BVec4A,
    py: BVec4A,
    pz: BVec4A,
}

impl FrustumLanes {
    /// `frustum`, with its side planes laid out lane-wise.
    pub fn new(frustum: &Frustum) -> Self {
        let [a, b, c, d] =
            [0, 1, 2, 3].map(|i| frustum.planes[i].normal.extend(frustum.planes[i].d));
        // The planes as columns, so each row holds one component of all four.
        let rows = glam::Mat4::from_cols(a, b, c, d).transpose();
        let (nx, ny, nz) = (rows.x_axis, rows.y_axis, rows.z_axis);
        Self {
            frustum: *frustum,
            px: nx.cmpge(Vec4::ZERO),
            py: ny.cmpge(Vec4::ZERO),
            pz: nz.cmpge(Vec4::ZERO),
            nx,
            ny,
            nz,
            d: rows.w_axis,
        }
    }

    /// How `aabb` stands with the frustum: [`Frustum::classify_aabb`]'s verdict, bit for bit.
    #[inline]
    pub fn classify_aabb(&self, aabb: &Aabb) -> Containment {
        // `Frustum::classify_aabb` answers `Outside` as soon as any plane has the box's far
        // corner behind it, whichever plane that is: one such side plane settles it here.
        // NaN distances compare false, and an invalid box is left to the full test.
        let far = |n: Vec4, positive: BVec4A, max: f32, min: f32| {
            n * Vec4::select(positive, Vec4::splat(max), Vec4::splat(min))
        };
        let distance = far(self.nx, self.px, aabb.max.x, aabb.min.x)
            + far(self.ny, self.py, aabb.max.y, aabb.min.y)
            + far(self.nz, self.pz, aabb.max.z, aabb.min.z)
            + self.d;
        if aabb.is_valid() && distance.cmplt(Vec4::ZERO).any() {
            return Containment::Outside;
        }
        self.frustum.classify_aabb(aabb)
    }
}
