//! A ray laid out lane-wise, for the boxes of a flat list.

use super::{Aabb, Ray, SLAB_WIDENING};
use glam::{BVec4A, Mat4, Vec3A, Vec4};

/// A [`Ray`] with its origin, reciprocal direction and slab choices broadcast to four lanes:
/// [`RayLanes::hits`] runs [`Ray::hits_aabb`] on four boxes at once, with the same verdict
/// for each, bit for bit, at the range it was given.
///
/// Why: a flat list (the busy movers, a brute-force index) is tested box after box, and the
/// scalar slab test spends most of its time in the two horizontal reductions (`max_element`,
/// `min_element`) of one box; laid out a box a lane, those become two lane-wise `max`/`min`
/// over the axes. Each lane computes the scalar test's operations in its order: the
/// per-axis distances round alike, NaN distances are replaced alike, and `max`/`min` over
/// values that are never NaN give the same numbers (a `-0.0` against a `0.0` may differ in
/// sign, which no comparison sees).
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayLanes {
    origin: [Vec4; 3],
    inv_direction: [Vec4; 3],
    /// Where the reciprocal direction is negative on each axis (the scalar test's `cmplt`):
    /// there the entry plane is the box's maximum.
    negative: [BVec4A; 3],
}

impl RayLanes {
    /// `ray`, broadcast to four lanes (its range is given to each test).
    #[inline]
    pub(crate) fn new(ray: &Ray) -> Self {
        let splat = |v: Vec3A| [Vec4::splat(v.x), Vec4::splat(v.y), Vec4::splat(v.z)];
        let inv_direction = splat(ray.inv_direction);
        Self {
            origin: splat(ray.origin),
            negative: inv_direction.map(|i| i.cmplt(Vec4::ZERO)),
            inv_direction,
        }
    }

    /// A bit per box (bit `i` for `boxes[i]`), set where [`Ray::hits_aabb`] of the ray over
    /// `[t_min, t_max]` would be true; neither bound NaN (a traceable ray's range).
    #[inline]
    pub(crate) fn hits(&self, boxes: [&Aabb; 4], t_min: f32, t_max: f32) -> u32 {
        let min_rows = axis_rows(boxes.map(|b| b.min));
        let max_rows = axis_rows(boxes.map(|b| b.max));
        let mut near = Vec4::NEG_INFINITY;
        let mut far = Vec4::INFINITY;
        for axis in 0..3 {
            let negative = self.negative[axis];
            let entry_plane = Vec4::select(negative, max_rows[axis], min_rows[axis]);
            let exit_plane = Vec4::select(negative, min_rows[axis], max_rows[axis]);
            let entry = (entry_plane - self.origin[axis]) * self.inv_direction[axis];
            let exit = (exit_plane - self.origin[axis]) * self.inv_direction[axis];
            // As in `Ray::slab_interval`: an axis whose distance is NaN does not constrain.
            let entry = Vec4::select(entry.is_nan_mask(), Vec4::NEG_INFINITY, entry);
            let exit = Vec4::select(exit.is_nan_mask(), Vec4::INFINITY, exit);
            near = near.max(entry);
            far = far.min(exit);
        }
        let near = near * (Vec4::ONE - Vec4::splat(SLAB_WIDENING).copysign(near));
        let far = far * (Vec4::ONE + Vec4::splat(SLAB_WIDENING).copysign(far));
        let near = near.max(Vec4::splat(t_min));
        let far = far.min(Vec4::splat(t_max));
        near.cmple(far).bitmask()
    }
}

/// Four corners laid out by axis: row `a` holds axis `a` of all four (the corners as the
/// columns of a matrix, transposed).
#[inline]
fn axis_rows(corners: [Vec3A; 4]) -> [Vec4; 3] {
    let rows = Mat4::from_cols(
        corners[0].extend(0.0),
        corners[1].extend(0.0),
        corners[2].extend(0.0),
        corners[3].extend(0.0),
    )
    .transpose();
    [rows.x_axis, rows.y_axis, rows.z_axis]
}

#[cfg(test)]
mod tests {
    //! Lane against scalar, box for box: random and adversarial rays (axis-parallel with zero
    //! and negative-zero components, starting on a box's face or corner, long and short
    //! ranges) against random, flat, touching, inverted, infinite and NaN boxes.
    use super::*;
    use accel_testkit::Rng;

    fn random_ray(rng: &mut Rng, boxes: &[Aabb]) -> Ray {
        let mut direction = rng.unit_vector() * rng.log_range(1e-3, 1e3);
        for axis in 0..3 {
            match rng.below(6) {
                0 => direction[axis] = 0.0,
                1 => direction[axis] = -0.0,
                _ => {}
            }
        }
        if direction == Vec3A::ZERO {
            direction.x = 1.0;
        }
        // Aimed at a box's corner or edge, where entry and exit meet and only the widening
        // keeps the box.
        if rng.bool() {
            let b = boxes[rng.below(boxes.len())];
            let corner = Vec3A::from_array(core::array::from_fn(|a| {
                if rng.bool() { b.min[a] } else { b.max[a] }
            }));
            let origin = rng.vec3a(-1e3, 1e3);
            let t_max = [f32::INFINITY, 1.0][rng.below(2)];
            return Ray::with_range(origin, corner - origin, 0.0, t_max);
        }
        let origin = match rng.below(3) {
            // On a face, edge or corner of one of the boxes.
            0 => {
                let b = boxes[rng.below(boxes.len())];
                Vec3A::from_array(core::array::from_fn(|a| match rng.below(3) {
                    0 => b.min[a],
                    1 => b.max[a],
                    _ => rng.range(b.min[a], b.max[a]),
                }))
            }
            _ => rng.vec3a(-50.0, 50.0),
        };
        let t_min = [0.0, -0.0, f32::NEG_INFINITY, rng.range(0.0, 10.0)][rng.below(4)];
        let t_max = [f32::INFINITY, rng.log_range(1e-3, 1e3), t_min][rng.below(3)];
        Ray::with_range(origin, direction, t_min, t_max)
    }

    fn random_box(rng: &mut Rng) -> Aabb {
        let centre = rng.vec3a(-40.0, 40.0);
        let mut half = rng.vec3a(0.0, 1.0) * rng.log_range(1e-3, 20.0);
        if rng.below(5) == 0 {
            half[rng.below(3)] = 0.0;
        }
        let mut b = Aabb::new(centre - half, centre + half);
        match rng.below(40) {
            0 => b.min[rng.below(3)] = f32::NAN,
            1 => b.max[rng.below(3)] = f32::INFINITY,
            2 => b.min[rng.below(3)] = f32::NEG_INFINITY,
            3 => core::mem::swap(&mut b.min, &mut b.max),
            4 => b = Aabb::new(Vec3A::splat(f32::NAN), Vec3A::splat(f32::NAN)),
            _ => {}
        }
        b
    }

    #[test]
    fn lanes_give_the_scalar_verdicts() {
        let mut rng = Rng::new(0x1a9e5);
        let mut checked = 0;
        for _ in 0..20_000 {
            let boxes: Vec<Aabb> = (0..64).map(|_| random_box(&mut rng)).collect();
            let ray = random_ray(&mut rng, &boxes);
            if !ray.is_traceable() {
                continue;
            }
            let lanes = RayLanes::new(&ray);
            for group in boxes.chunks_exact(4) {
                let mask = lanes.hits(
                    [&group[0], &group[1], &group[2], &group[3]],
                    ray.t_min,
                    ray.t_max,
                );
                for (i, b) in group.iter().enumerate() {
                    let lane = mask & (1 << i) != 0;
                    assert_eq!(lane, ray.hits_aabb(b), "ray {ray:?}, box {b:?}");
                    checked += 1;
                }
            }
        }
        assert!(checked > 200_000, "{checked} boxes checked");
    }
}
