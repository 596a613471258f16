//! View frusta as six planes, and the three-way classification that lets trees accept whole
//! subtrees at once.

use crate::{Aabb, Sphere};
use glam::{DMat4, DVec4, Mat4, Vec3A, Vec4};

/// Where a volume lies with respect to a frustum (or any convex region).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Containment {
    /// Entirely outside: behind at least one plane.
    Outside,
    /// Possibly crossing the boundary: neither test could decide.
    Intersecting,
    /// Entirely inside every plane: a tree can accept the whole subtree without further tests.
    Inside,
}

/// A plane `normal . p + d = 0`; points with `normal . p + d >= 0` are on its inner side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// Unit normal pointing to the inner side (zero for the planes of an infinite far plane).
    pub normal: Vec3A,
    /// Signed offset: the signed distance of the world origin from the plane.
    pub d: f32,
}

impl Plane {
    /// A plane from `(a, b, c, d)` with `a x + b y + c z + d >= 0` inside, normalised. A zero
    /// normal (the far plane of Bevy's infinite reverse-z projection) keeps its sign of `d`:
    /// all space is inside when `d >= 0`, none when `d < 0`.
    pub fn from_vec4(v: Vec4) -> Self {
        let normal = Vec3A::new(v.x, v.y, v.z);
        let len = normal.length();
        if len > 0.0 && len.is_finite() {
            Self {
                normal: normal / len,
                d: v.w / len,
            }
        } else {
            Self {
                normal: Vec3A::ZERO,
                d: if v.w >= 0.0 { 1.0 } else { -1.0 },
            }
        }
    }

    /// Signed distance of a point (positive inside).
    #[inline]
    pub fn signed_distance(&self, p: Vec3A) -> f32 {
        self.normal.dot(p) + self.d
    }

    /// [`Plane::from_vec4`] from `f64` coefficients, normalised in `f64` and rounded once:
    /// planes derived from a matrix (a difference of its rows, a transformed plane) keep the
    /// precision of the matrix instead of adding the roundings of an `f32` derivation.
    pub(crate) fn from_dvec4(v: DVec4) -> Self {
        let len = v.truncate().length();
        if len > 0.0 && len.is_finite() {
            let v = v / len;
            Self {
                normal: Vec3A::new(v.x as f32, v.y as f32, v.z as f32),
                d: v.w as f32,
            }
        } else {
            Self {
                normal: Vec3A::ZERO,
                d: if v.w >= 0.0 { 1.0 } else { -1.0 },
            }
        }
    }

    /// The plane as `(a, b, c, d)` in `f64`.
    pub(crate) fn to_dvec4(self) -> DVec4 {
        self.normal.as_dvec3().extend(f64::from(self.d))
    }

    /// The plane that holds all space: what a frustum without a far plane keeps in that
    /// slot (the form [`Plane::from_vec4`] gives the far plane of an infinite projection).
    pub(crate) const EVERYWHERE: Self = Self {
        normal: Vec3A::ZERO,
        d: 1.0,
    };

    /// The plane that holds nothing: what a plane whose numbers are lost to overflow or NaN
    /// becomes, so that the region is empty rather than undecided.
    pub(crate) const NOWHERE: Self = Self {
        normal: Vec3A::ZERO,
        d: -1.0,
    };

    /// Whether the plane's numbers are all finite.
    pub(crate) fn is_finite(&self) -> bool {
        self.normal.is_finite() && self.d.is_finite()
    }
}

/// A convex region bounded by six planes, all normals pointing inwards.
///
/// Plane order: left, right, bottom, top, near, far (Bevy's `ViewFrustum` keeps near at 4 and far
/// at 5 too).
///
/// ```
/// use spatial_accel::{Aabb, Containment, Frustum};
/// use glam::{Mat4, Vec3, Vec3A};
/// let proj = Mat4::perspective_rh(1.0, 1.0, 0.1, 100.0);
/// let view = Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
/// let f = Frustum::from_clip_from_world(&(proj * view));
/// let ahead = Aabb::new(Vec3A::new(-1.0, -1.0, -11.0), Vec3A::new(1.0, 1.0, -9.0));
/// let behind = Aabb::new(Vec3A::new(-1.0, -1.0, 9.0), Vec3A::new(1.0, 1.0, 11.0));
/// assert_eq!(f.classify_aabb(&ahead), Containment::Inside);
/// assert_eq!(f.classify_aabb(&behind), Containment::Outside);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frustum {
    /// The six bounding planes.
    pub planes: [Plane; 6],
}

impl Frustum {
    /// Index of the near plane in [`Frustum::planes`].
    pub const NEAR: usize = 4;
    /// Index of the far plane in [`Frustum::planes`].
    pub const FAR: usize = 5;

    /// The frustum of a clip-from-world (view-projection) matrix, by the method of Gribb and
    /// Hartmann (2001). Depth is taken as `0 <= z <= w` (wgpu's and Bevy's clip space); with
    /// Bevy's reverse-z, plane 4 (`z <= w`) is the near plane and plane 5 (`z >= 0`) is the far
    /// plane, which for an infinite projection contains all space.
    pub fn from_clip_from_world(clip_from_world: &Mat4) -> Self {
        let m = clip_from_world.transpose();
        let (r0, r1, r2, r3) = (m.x_axis, m.y_axis, m.z_axis, m.w_axis);
        Self::from_planes([r3 + r0, r3 - r0, r3 + r1, r3 - r1, r3 - r2, r2])
    }

    /// A frustum from six `(a, b, c, d)` half-spaces with `a x + b y + c z + d >= 0` inside (the
    /// form of Bevy's `HalfSpace::normal_d`).
    pub fn from_planes(planes: [Vec4; 6]) -> Self {
        Self {
            planes: planes.map(Plane::from_vec4),
        }
    }

    /// The same region in a mesh's or an entity's own space, for a frustum in world space and
    /// the transform that places that space in the world: a point `p` is inside the result
    /// exactly when `world_from_local * p` is inside `self`. What a query over a mesh's own
    /// tree takes (see [`MeshBvh::any_triangle_in_frustum`](crate::mesh::MeshBvh::any_triangle_in_frustum)),
    /// so that the mesh need not be moved into the world.
    ///
    /// Each plane `(n, d)` maps to `world_from_local^T * (n, d)` and is normalised again, in
    /// `f64`: the normal of a plane seen through a non-uniform scale changes its length and
    /// direction, and every test here reads distances against unit normals. Any invertible
    /// affine transform works, mirrored ones (a negative scale) included: the map keeps
    /// which side of each plane is inside, whatever the handedness. A plane that holds all
    /// space (or none) stays so; a singular transform (a zero scale) may turn a plane into
    /// one of those, which is right (the flattened space lies wholly on one side). A plane
    /// that a non-finite transform (or an overflow) leaves without finite numbers holds
    /// nothing, so the result is empty rather than undecided.
    ///
    /// ```
    /// use spatial_accel::{Aabb, Containment, Frustum};
    /// use glam::{Mat4, Vec3, Vec3A};
    /// let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1);
    /// let world = Frustum::from_clip_from_world(&(proj * Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y)));
    /// // A mesh 10 ahead, scaled by 2 on x and mirrored on z.
    /// let world_from_local = Mat4::from_translation(Vec3::new(0.0, 0.0, -10.0))
    ///     * Mat4::from_scale(Vec3::new(2.0, 1.0, -1.0));
    /// let local = world.transformed(&world_from_local);
    /// let unit = Aabb::new(Vec3A::splat(-1.0), Vec3A::splat(1.0));
    /// assert_eq!(local.classify_aabb(&unit), Containment::Inside);
    /// // Local x = 3 is world x = 6, outside a 1-radian view at depth 10.
    /// assert!(!local.contains_point(Vec3A::new(3.0, 0.0, 0.0)));
    /// ```
    pub fn transformed(&self, world_from_local: &Mat4) -> Self {
        let transpose: DMat4 = world_from_local.as_dmat4().transpose();
        Self {
            planes: self.planes.map(|p| {
                let local = Plane::from_dvec4(transpose * p.to_dvec4());
                if local.is_finite() {
                    local
                } else {
                    Plane::NOWHERE
                }
            }),
        }
    }

    /// Classifies a box: outside (behind a plane), inside (in front of every plane), or
    /// intersecting (undecided). Conservative: a box touching the region is never outside. An
    /// empty or NaN box is outside.
    ///
    /// Monotone: a box inside another is never classified further out than it (never
    /// outside when the larger one is not, always inside when the larger one is). A tree
    /// culls a node by its box and accepts a leaf by the leaf's box, so without this a leaf
    /// box that passes could sit under a node box that fails.
    #[inline]
    pub fn classify_aabb(&self, aabb: &Aabb) -> Containment {
        if !aabb.is_valid() {
            return Containment::Outside;
        }
        // The corners farthest along and against each normal (the p- and n-vertices), not
        // centre and half extents: rounded sums and products are monotone in their
        // arguments, so the distance of a larger box's p-vertex never rounds below a smaller
        // box's. The centre form rounds the centre and the radius apart, which far from the
        // origin (1e7) loses boxes whose own test passes (the stress suite's frustum misses).
        let mut inside = true;
        for plane in &self.planes {
            let positive = plane.normal.cmpge(Vec3A::ZERO);
            let far_corner = Vec3A::select(positive, aabb.max, aabb.min);
            if plane.signed_distance(far_corner) < 0.0 {
                return Containment::Outside;
            }
            let near_corner = Vec3A::select(positive, aabb.min, aabb.max);
            inside &= plane.signed_distance(near_corner) >= 0.0;
        }
        if inside {
            Containment::Inside
        } else {
            Containment::Intersecting
        }
    }

    /// [`Frustum::classify_aabb`] on a box given by centre and half extents.
    #[inline]
    pub fn classify_center_half_extents(&self, center: Vec3A, half: Vec3A) -> Containment {
        let mut inside = true;
        for plane in &self.planes {
            let s = plane.signed_distance(center);
            // The projected radius of the box onto the plane normal.
            let r = plane.normal.abs().dot(half);
            if s + r < 0.0 {
                return Containment::Outside;
            }
            inside &= s - r >= 0.0;
        }
        if inside {
            Containment::Inside
        } else {
            Containment::Intersecting
        }
    }

    /// Classifies a sphere the same way. An invalid sphere is outside.
    #[inline]
    pub fn classify_sphere(&self, sphere: &Sphere) -> Containment {
        if !sphere.is_valid() {
            return Containment::Outside;
        }
        let mut inside = true;
        for plane in &self.planes {
            let s = plane.signed_distance(sphere.center);
            if s + sphere.radius < 0.0 {
                return Containment::Outside;
            }
            inside &= s - sphere.radius >= 0.0;
        }
        if inside {
            Containment::Inside
        } else {
            Containment::Intersecting
        }
    }

    /// True unless the box is certainly outside.
    #[inline]
    pub fn intersects_aabb(&self, aabb: &Aabb) -> bool {
        self.classify_aabb(aabb) != Containment::Outside
    }

    /// True when the point is on the inner side of every plane.
    #[inline]
    pub fn contains_point(&self, p: Vec3A) -> bool {
        self.planes.iter().all(|pl| pl.signed_distance(p) >= 0.0)
    }

    /// The frustum's eight corners, for drawing it: the near face first, then the far one,
    /// each as left-bottom, right-bottom, right-top, left-top. A plane at infinity (the far
    /// plane of Bevy's perspective) is replaced by one `max_depth` past the opposite plane,
    /// parallel to it. `None` when three planes do not meet in a point (a degenerate frustum).
    ///
    /// Why the near face is told by its size: planes 4 and 5 swap roles between reverse-z
    /// (Bevy's) and standard depth, and six planes do not say where the eye is; a perspective
    /// view's near face is the smaller one (an orthographic view's faces are alike, and either
    /// order draws the same box).
    ///
    /// ```
    /// use spatial_accel::Frustum;
    /// use glam::{Mat4, Vec3};
    /// let proj = Mat4::perspective_rh(1.0, 1.0, 1.0, 10.0);
    /// let view = Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
    /// let corners = Frustum::from_clip_from_world(&(proj * view)).corners(100.0).unwrap();
    /// assert!((corners[0].z + 1.0).abs() < 1e-4); // near plane at z = -1
    /// assert!((corners[4].z + 10.0).abs() < 1e-3); // far plane at z = -10
    ///
    /// // Bevy's infinite reverse-z projection: the far corners come `max_depth` past the near.
    /// let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 1.0);
    /// let corners = Frustum::from_clip_from_world(&(proj * view)).corners(100.0).unwrap();
    /// assert!((corners[0].z + 1.0).abs() < 1e-4);
    /// assert!((corners[4].z + 101.0).abs() < 1e-2);
    /// ```
    pub fn corners(&self, max_depth: f32) -> Option<[Vec3A; 8]> {
        let [left, right, bottom, top, mut a, mut b] = self.planes;
        // Inside a stand-in for a plane at infinity: at most `max_depth` past the other.
        let opposite = |p: &Plane| Plane {
            normal: -p.normal,
            d: max_depth - p.d,
        };
        if b.normal == Vec3A::ZERO {
            b = opposite(&a);
        } else if a.normal == Vec3A::ZERO {
            a = opposite(&b);
        }
        let face = |depth: &Plane| -> Option<[Vec3A; 4]> {
            Some([
                meet(&left, &bottom, depth)?,
                meet(&right, &bottom, depth)?,
                meet(&right, &top, depth)?,
                meet(&left, &top, depth)?,
            ])
        };
        let (mut near, mut far) = (face(&a)?, face(&b)?);
        let area = |f: &[Vec3A; 4]| (f[2] - f[0]).cross(f[3] - f[1]).length();
        if area(&near) > area(&far) {
            core::mem::swap(&mut near, &mut far);
        }
        let mut corners = [Vec3A::ZERO; 8];
        corners[..4].copy_from_slice(&near);
        corners[4..].copy_from_slice(&far);
        Some(corners)
    }
}

/// The point where three planes meet (Cramer's rule on their normals), if they meet in one.
fn meet(a: &Plane, b: &Plane, c: &Plane) -> Option<Vec3A> {
    let bc = b.normal.cross(c.normal);
    let det = a.normal.dot(bc);
    if det.abs() < 1e-12 {
        return None;
    }
    let p = (-a.d * bc - b.d * c.normal.cross(a.normal) - c.d * a.normal.cross(b.normal)) / det;
    p.is_finite().then_some(p)
}
