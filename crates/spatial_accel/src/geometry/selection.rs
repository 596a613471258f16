//! Box selection: the frustum of a rectangle dragged on the screen, and the tests that decide
//! which entities it selects.

use crate::{Aabb, Containment, Frustum, Plane};
use glam::{DVec4, Mat4, Vec2};

/// How a box selection decides whether an entity is in the rectangle.
///
/// Games differ: a strategy game selects a unit when its centre is in the rectangle (a unit
/// half behind the edge of the drag is still picked, one merely brushed is not); an editor
/// offers "enclosed" (only what lies wholly inside) and "touching" (anything the rectangle
/// reaches, judged on the mesh, not on its box, so a long diagonal beam is not picked by the
/// empty corner of its box).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum SelectionMode {
    /// The centre of the entity's box is inside ([`Frustum::contains_aabb_center`]).
    #[default]
    Center,
    /// The whole box is inside ([`Frustum::encloses_aabb`]).
    Enclosed,
    /// Some triangle of the entity's mesh meets the frustum ([`Frustum::touches_triangle`],
    /// [`MeshBvh::any_triangle_in_frustum`](crate::mesh::MeshBvh::any_triangle_in_frustum)).
    Touching,
}

impl SelectionMode {
    /// The verdict the entity's box alone gives: `Some` for [`SelectionMode::Center`] and
    /// [`SelectionMode::Enclosed`], which the box decides, and for a box outside the frustum
    /// under [`SelectionMode::Touching`] (no triangle in it can reach the frustum); `None`
    /// when the mesh must decide. An invalid box (empty or NaN) is not selected.
    pub fn select_by_aabb(self, frustum: &Frustum, aabb: &Aabb) -> Option<bool> {
        match self {
            Self::Center => Some(frustum.contains_aabb_center(aabb)),
            Self::Enclosed => Some(frustum.encloses_aabb(aabb)),
            Self::Touching if frustum.intersects_aabb(aabb) => None,
            Self::Touching => Some(false),
        }
    }
}

impl Frustum {
    /// The frustum of a rectangle on the screen: what a box selection dragged from `ndc_min`
    /// to `ndc_max` covers, seen through the camera whose view-projection is
    /// `clip_from_world`.
    ///
    /// The rectangle is in normalised device coordinates, `[-1, 1]` on both axes with y up,
    /// whatever the viewport: the caller maps its pixels there (Bevy's
    /// `Camera::viewport_to_ndc` does, flipping y). Its corners may come in any order (a drag
    /// up and to the left gives `min > max`; they are sorted), and it may reach past the
    /// screen's edges (its planes then simply lie outside the view).
    ///
    /// The side planes are the rectangle's edges read from the rows of the matrix: `x_clip >=
    /// x_min * w_clip` and so on, exact for any projection, perspective or orthographic, since
    /// a point projects inside the edge exactly when that holds (with `w_clip > 0`). The planes
    /// are derived and normalised in `f64` and rounded once.
    ///
    /// Depth is Bevy's reverse-z (`0 <= z_clip <= w_clip`, the near plane at `z_clip =
    /// w_clip`, as `perspective_infinite_reverse_rh` and Bevy's orthographic projection give
    /// it). The near plane is kept, as Bevy culls by it (an entity between the eye and the near
    /// plane is not drawn, so not selected); there is no far plane, as an infinite
    /// perspective has none and a selection should reach everything drawn: plane
    /// [`Frustum::FAR`] holds all space. A caller that wants a limit sets that plane. A
    /// standard-depth matrix (near at `z_clip = 0`) is not what this reads: its far plane
    /// would be kept in place of the near one.
    ///
    /// A rectangle of zero width or height (a click, or a drag along one axis) gives a frustum
    /// of zero thickness: two opposite planes with exactly negated numbers, so that a point
    /// is inside only when it lies exactly on them (which points almost never do: such a
    /// frustum selects nothing by [`SelectionMode::Center`] or [`SelectionMode::Enclosed`]),
    /// while [`Frustum::touches_triangle`] still finds the triangles that cross it, as a
    /// picking ray would.
    ///
    /// `None` when the matrix or the rectangle is not finite, or a plane's numbers overflow.
    ///
    /// ```
    /// use spatial_accel::{Aabb, Frustum};
    /// use glam::{Mat4, Vec2, Vec3, Vec3A};
    /// // Bevy's perspective camera at the origin, looking down -z.
    /// let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1);
    /// let view = Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
    /// // The right half of the screen, dragged from its top right to its bottom centre.
    /// let rect = Frustum::from_clip_rect(&(proj * view), Vec2::new(1.0, 1.0), Vec2::new(0.0, -1.0))
    ///     .unwrap();
    /// let unit_at = |x: f32, z: f32| {
    ///     Aabb::from_center_half_extents(Vec3A::new(x, 0.0, z), Vec3A::splat(0.5))
    /// };
    /// let boxes = [unit_at(2.0, -10.0), unit_at(-2.0, -10.0), unit_at(0.0, -10.0), unit_at(2.0, 10.0)];
    /// let enclosed: Vec<bool> = boxes.iter().map(|b| rect.encloses_aabb(b)).collect();
    /// // Right of centre: yes; left: no; across the middle: no; behind the camera: no.
    /// assert_eq!(enclosed, [true, false, false, false]);
    /// // The box across the middle has its centre on the edge, and is touched.
    /// assert!(rect.intersects_aabb(&boxes[2]));
    /// ```
    pub fn from_clip_rect(clip_from_world: &Mat4, ndc_min: Vec2, ndc_max: Vec2) -> Option<Self> {
        if !(clip_from_world.is_finite() && ndc_min.is_finite() && ndc_max.is_finite()) {
            return None;
        }
        let (lo, hi) = (
            ndc_min.min(ndc_max).as_dvec2(),
            ndc_min.max(ndc_max).as_dvec2(),
        );
        let m = clip_from_world.as_dmat4().transpose();
        let (r0, r1, r2, r3) = (m.x_axis, m.y_axis, m.z_axis, m.w_axis);
        let side = |v: DVec4| Plane::from_dvec4(v);
        let frustum = Self {
            planes: [
                side(r0 - r3 * lo.x),
                side(r3 * hi.x - r0),
                side(r1 - r3 * lo.y),
                side(r3 * hi.y - r1),
                side(r3 - r2),
                Plane::EVERYWHERE,
            ],
        };
        frustum
            .planes
            .iter()
            .all(Plane::is_finite)
            .then_some(frustum)
    }

    /// Whether the centre of the box is inside: [`SelectionMode::Center`]. The centre is the
    /// box's own ([`Aabb::center`]), tested with [`Frustum::contains_point`]. An invalid box
    /// (empty or NaN) is not selected.
    #[inline]
    pub fn contains_aabb_center(&self, aabb: &Aabb) -> bool {
        aabb.is_valid() && self.contains_point(aabb.center())
    }

    /// Whether the whole box is inside (its eight corners, so everything in it: the frustum
    /// is convex): [`SelectionMode::Enclosed`], [`Containment::Inside`] of
    /// [`Frustum::classify_aabb`]. An invalid box (empty or NaN) is not selected.
    #[inline]
    pub fn encloses_aabb(&self, aabb: &Aabb) -> bool {
        self.classify_aabb(aabb) == Containment::Inside
    }
}
