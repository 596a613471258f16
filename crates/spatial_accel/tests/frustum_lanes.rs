//! `FrustumLanes::classify_aabb` against `Frustum::classify_aabb`, verdict for verdict: random
//! cameras and boxes, boxes whose corners lie on a plane or an ulp either side of it, planes
//! with zero, negative-zero, infinite and NaN components, and invalid boxes.

use accel_testkit::Rng;
use glam::{Mat4, Vec3, Vec3A, Vec4};
use spatial_accel::{Aabb, Frustum, FrustumLanes};

/// A random camera's frustum: perspective, infinite reversed or orthographic, anywhere.
fn random_frustum(rng: &mut Rng) -> Frustum {
    let eye = Vec3::from(rng.vec3a(-1e3, 1e3));
    let forward = Vec3::from(rng.unit_vector_f64());
    let up = Vec3::from(rng.unit_vector_f64());
    let view = Mat4::look_to_rh(eye, forward, up);
    let near = rng.log_range(0.01, 1.0);
    let (fov, aspect) = (rng.range(0.3, 2.5), rng.range(0.5, 2.5));
    let projection = match rng.below(3) {
        0 => Mat4::perspective_rh(fov, aspect, near, near * rng.log_range(10.0, 1e4)),
        1 => Mat4::perspective_infinite_reverse_rh(fov, aspect, near),
        _ => {
            let h = rng.log_range(1.0, 1e3);
            Mat4::orthographic_rh(-h * aspect, h * aspect, -h, h, near, h * 10.0)
        }
    };
    Frustum::from_clip_from_world(&(projection * view))
}

/// A random box near `around`: from a point to a large slab, sometimes flat on an axis.
fn random_box(rng: &mut Rng, around: Vec3A) -> Aabb {
    let centre = around + rng.vec3a(-1e3, 1e3) * rng.log_range(1e-3, 1.0);
    let mut half = rng.vec3a(0.0, 1.0) * rng.log_range(1e-4, 1e3);
    if rng.below(4) == 0 {
        half.y = 0.0;
    }
    Aabb::new(centre - half, centre + half)
}

/// Boxes with their far corner along a random plane's normal moved onto that plane, then
/// nudged by up to two ulps either way.
fn boxes_on_plane(rng: &mut Rng, frustum: &Frustum, out: &mut Vec<Aabb>) {
    let plane = frustum.planes[rng.below(6)];
    if plane.normal == Vec3A::ZERO {
        return;
    }
    let b = random_box(rng, Vec3A::ZERO);
    let corner = Vec3A::select(plane.normal.cmpge(Vec3A::ZERO), b.max, b.min);
    let shift = plane.normal * -plane.signed_distance(corner);
    for ulps in [-2i32, -1, 0, 1, 2] {
        let nudge = |v: Vec3A| {
            Vec3A::from_array(v.to_array().map(|x| {
                let step = ulps * if x >= 0.0 { 1 } else { -1 };
                f32::from_bits((x.to_bits() as i32 + step) as u32)
            }))
        };
        out.push(Aabb::new(nudge(b.min + shift), nudge(b.max + shift)));
    }
}

/// Boxes on which the two tests disagree (printed).
fn differences(frustum: &Frustum, boxes: &[Aabb]) -> usize {
    let lanes = FrustumLanes::new(frustum);
    boxes
        .iter()
        .filter(|b| {
            let (planewise, lanewise) = (frustum.classify_aabb(b), lanes.classify_aabb(b));
            if planewise != lanewise {
                eprintln!("{b:?}: plane by plane {planewise:?}, lane-wise {lanewise:?}");
            }
            planewise != lanewise
        })
        .count()
}

#[test]
fn lane_wise_verdicts_equal_the_plane_by_plane_ones() {
    let mut rng = Rng::new(0x1a4e5);
    let mut different = 0;
    let mut verdicts = [0usize; 3];
    for _ in 0..400 {
        let frustum = random_frustum(&mut rng);
        let near = frustum.planes[Frustum::NEAR];
        let on_near_plane = near.normal * -near.d;
        let mut boxes: Vec<Aabb> = (0..200)
            .map(|_| random_box(&mut rng, on_near_plane))
            .collect();
        for _ in 0..50 {
            boxes_on_plane(&mut rng, &frustum, &mut boxes);
        }
        for b in &boxes {
            verdicts[frustum.classify_aabb(b) as usize] += 1;
        }
        different += differences(&frustum, &boxes);
    }
    assert_eq!(different, 0);
    // The scenes reach every verdict, so agreement means something.
    assert!(verdicts.iter().all(|&n| n > 1_000), "{verdicts:?}");
}

#[test]
fn odd_planes_and_invalid_boxes_get_the_plane_by_plane_verdicts() {
    let mut rng = Rng::new(0x0dd);
    let base = random_frustum(&mut rng);
    let odd_planes = [
        Vec4::new(0.0, 0.0, 0.0, 1.0),
        Vec4::new(0.0, 0.0, 0.0, -1.0),
        Vec4::new(-0.0, 1.0, -0.0, 0.0),
        Vec4::new(f32::NAN, 0.0, 1.0, 0.0),
        Vec4::new(0.0, 1.0, 0.0, f32::NAN),
        Vec4::new(1.0, 0.0, 0.0, f32::INFINITY),
    ];
    let odd_boxes = [
        Aabb::new(Vec3A::splat(f32::NAN), Vec3A::ONE),
        Aabb::new(Vec3A::ONE, Vec3A::ZERO),
        Aabb::EMPTY,
        Aabb::new(Vec3A::splat(f32::NEG_INFINITY), Vec3A::splat(f32::INFINITY)),
        Aabb::new(Vec3A::splat(-0.0), Vec3A::splat(0.0)),
        Aabb::new(Vec3A::splat(-1e30), Vec3A::splat(1e30)),
    ];
    let mut different = 0;
    for odd in odd_planes {
        for slot in 0..6 {
            let mut planes = base.planes.map(|p| p.normal.extend(p.d));
            planes[slot] = odd;
            let frustum = Frustum::from_planes(planes);
            let mut boxes: Vec<Aabb> = odd_boxes.to_vec();
            boxes.extend((0..100).map(|_| random_box(&mut rng, Vec3A::ZERO)));
            different += differences(&frustum, &boxes);
        }
    }
    assert_eq!(different, 0);
}
