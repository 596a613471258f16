//! Which of a mesh's triangles a frustum reaches: box selection by touching, on the mesh's
//! own tree.

use super::MeshBvh;
use crate::geometry::touch_band;
use crate::query::walks::visit_primitives_where;
use crate::{Aabb, Frustum, Plane};
use core::ops::ControlFlow;
use glam::Vec3A;

/// How far, in touching bands ([`crate::TOUCH_TOLERANCE`]), the frustum that culls nodes is
/// widened past the one triangles are tested against. A triangle that
/// [`Frustum::touches_triangle`] accepts has a point within one band outside every plane (a
/// band computed from its own corners, which lie within the mesh's box); the `f32` test of a
/// node box holding that point errs by a few half ulps of the same magnitudes (four for a
/// dot product and an offset), a band at most. Four bands leave room to spare, so no node
/// holding an accepted triangle is culled.
const CULL_BANDS: f64 = 4.0;

impl MeshBvh {
    /// Whether any triangle of the mesh meets the frustum ([`Frustum::touches_triangle`]):
    /// box selection by touching ([`SelectionMode::Touching`](crate::SelectionMode)) decided
    /// on the mesh instead of its box. Exactly the answer of that test over every triangle,
    /// found by a walk that skips the subtrees outside and stops at the first triangle found.
    ///
    /// The frustum is in the mesh's own space: for an entity placed by `world_from_local`,
    /// pass `world_frustum.transformed(&world_from_local)` ([`Frustum::transformed`]).
    ///
    /// ```
    /// use spatial_accel::Frustum;
    /// use spatial_accel::mesh::MeshBvh;
    /// use glam::{Mat4, Vec2, Vec3};
    /// // A unit quad, placed 10 ahead of a camera looking down -z.
    /// let vertices = [Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(1., 1., 0.), Vec3::new(0., 1., 0.)];
    /// let mesh = MeshBvh::new(&vertices, &[0, 1, 2, 0, 2, 3]).unwrap();
    /// let world_from_local = Mat4::from_translation(Vec3::new(0.0, 0.0, -10.0));
    /// let proj = Mat4::perspective_infinite_reverse_rh(1.0, 1.0, 0.1);
    /// let view = Mat4::look_at_rh(Vec3::ZERO, Vec3::NEG_Z, Vec3::Y);
    /// let rect = |min, max| Frustum::from_clip_rect(&(proj * view), min, max).unwrap();
    /// // The right half of the screen holds the quad; the left half only touches its edge at
    /// // x = 0; a band at the far left misses it.
    /// for (min, max, hit) in [(0.0, 1.0, true), (-1.0, 0.0, true), (-1.0, -0.5, false)] {
    ///     let frustum = rect(Vec2::new(min, -1.0), Vec2::new(max, 1.0)).transformed(&world_from_local);
    ///     assert_eq!(mesh.any_triangle_in_frustum(&frustum), hit);
    /// }
    /// ```
    pub fn any_triangle_in_frustum(&self, frustum: &Frustum) -> bool {
        let mut found = false;
        self.walk_frustum(frustum, |_| {
            found = true;
            ControlFlow::Break(())
        });
        found
    }

    /// Calls `visit(triangle index)` once for each triangle that meets the frustum
    /// ([`Frustum::touches_triangle`]), in no particular order: the triangles a selection by
    /// touching reaches, to highlight them. The frustum is in the mesh's own space, as for
    /// [`MeshBvh::any_triangle_in_frustum`].
    pub fn for_each_triangle_in_frustum(&self, frustum: &Frustum, mut visit: impl FnMut(u32)) {
        if !self.split {
            self.walk_frustum(frustum, |t| {
                visit(t);
                ControlFlow::Continue(())
            });
            return;
        }
        // Pieces of one triangle in several leaves: visited once.
        let mut found = Vec::new();
        self.walk_frustum(frustum, |t| {
            found.push(t);
            ControlFlow::Continue(())
        });
        found.sort_unstable();
        found.dedup();
        found.into_iter().for_each(visit);
    }

    /// Visits the triangles that meet the frustum, from the leaves a widened frustum reaches
    /// (see [`CULL_BANDS`]), until `visit` breaks.
    fn walk_frustum(&self, frustum: &Frustum, mut visit: impl FnMut(u32) -> ControlFlow<()>) {
        let cull = cull_frustum(frustum, &self.bounds());
        visit_primitives_where(
            self.tree(),
            |b| cull.intersects_aabb(b),
            |packet| {
                for lane in self.packets.used_lanes(packet) {
                    if cull.intersects_aabb(&self.packets.lane_bounds(packet, lane))
                        && frustum.touches_triangle(&self.packets.corners(packet, lane))
                    {
                        visit(self.packets.triangle(packet, lane))?;
                    }
                }
                ControlFlow::Continue(())
            },
        );
    }
}

/// The frustum with every plane moved outwards by [`CULL_BANDS`] touching bands of a
/// triangle within `bounds` (rounded up to the next `f32`, so that the moved plane holds at
/// least the `f64` one): a cull that keeps every node holding a triangle that
/// [`Frustum::touches_triangle`] accepts, whatever the `f32` rounding of the node test.
fn cull_frustum(frustum: &Frustum, bounds: &Aabb) -> Frustum {
    let scale = f64::from(bounds.min.abs().max(bounds.max.abs()).max_element());
    if !scale.is_finite() {
        return *frustum;
    }
    Frustum {
        planes: frustum.planes.map(|plane| {
            if plane.normal == Vec3A::ZERO {
                return plane;
            }
            let d = f64::from(plane.d) + CULL_BANDS * touch_band(&plane, scale);
            let rounded = d as f32;
            Plane {
                normal: plane.normal,
                d: if f64::from(rounded) >= d || !rounded.is_finite() {
                    rounded
                } else {
                    rounded.next_up()
                },
            }
        }),
    }
}
