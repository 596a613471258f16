//! Tests of the wide ray walk's node tests: the flat (8-lane) test against the 4-lane one, and
//! the fused test against an exact slab oracle near and far from the origin.

use super::*;
use crate::Aabb;
use glam::Vec3A;
use proptest::prelude::*;

/// Coordinates that stress the slab test: zeros of both signs, values on which a ray's
/// origin can lie, huge and infinite ones.
fn coordinate() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -10.0f32..10.0,
        1 => Just(0.0f32),
        1 => Just(-0.0f32),
        1 => Just(1.0f32),
        1 => Just(f32::MAX),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
    ]
}

fn point() -> impl Strategy<Value = Vec3A> {
    [coordinate(), coordinate(), coordinate()].prop_map(Vec3A::from_array)
}

/// A slot's box: ordinary, flat, inverted (an empty slot's) or unbounded.
fn slot_box() -> impl Strategy<Value = Aabb> {
    prop_oneof![
        6 => (point(), point()).prop_map(|(a, b)| Aabb::new(a.min(b), a.max(b))),
        1 => point().prop_map(|p| Aabb::new(p, p)),
        1 => Just(Aabb::EMPTY),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 2000, rng_seed: proptest::test_runner::RngSeed::Fixed(16), ..ProptestConfig::default() })]

    /// The flat test (8 lanes in the AVX2 walk) answers every slot exactly as the 4-lane
    /// test: the same mask, and the same entry distance to the bit.
    #[test]
    fn flat_and_four_lane_tests_agree(
        boxes in proptest::collection::vec(slot_box(), 16),
        origin in point(),
        direction in point(),
        t_min in prop_oneof![Just(0.0f32), 0.0f32..5.0],
        t_max in prop_oneof![Just(f32::INFINITY), 0.0f32..20.0],
    ) {
        let mut node = WideNode::<16>::default();
        for (slot, b) in boxes.iter().enumerate() {
            node.set_child_aabb(slot, b);
        }
        let ray = Ray::with_range(origin, direction, t_min, t_max);
        let lanes = RayLanes::new(&ray);
        let (mut four, mut flat) = ([0.0f32; 16], [0.0f32; 16]);
        let four_mask = node.intersect_slots(&lanes, ray.t_max, &mut four);
        let flat_mask = slab_test_flat::<16, false>(node.planes(), &lanes, ray.t_max, &mut flat);
        prop_assert_eq!(four_mask, flat_mask);
        prop_assert_eq!(four.map(f32::to_bits), flat.map(f32::to_bits));
    }
}

/// The exact slab interval of the ray `origin + t * direction` in a box, in f64 (exact
/// for these inputs to far below f32's precision), clipped to `[t_min, t_max]`.
fn exact_interval(ray: &Ray, direction: Vec3A, b: &Aabb) -> Option<(f64, f64)> {
    let (mut near, mut far) = (f64::from(ray.t_min), f64::from(ray.t_max));
    for k in 0..3 {
        let (o, d) = (f64::from(ray.origin[k]), f64::from(direction[k]));
        let (lo, hi) = (f64::from(b.min[k]), f64::from(b.max[k]));
        if d == 0.0 {
            if o < lo || o > hi {
                return None;
            }
            continue;
        }
        let (t1, t2) = ((lo - o) / d, (hi - o) / d);
        near = near.max(t1.min(t2));
        far = far.min(t1.max(t2));
    }
    (near <= far).then_some((near, far))
}

/// A box near `center`, from a thousandth to a thousand units across, sometimes flat.
fn box_near(center: Vec3A) -> impl Strategy<Value = Aabb> {
    (
        [-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0],
        [-3.0f32..3.0, -3.0f32..3.0, -3.0f32..3.0],
        0usize..6,
    )
        .prop_map(move |(at, log_size, flat)| {
            let size = Vec3A::from_array(log_size.map(|e| 10f32.powf(e)));
            let min = center + Vec3A::from_array(at) * 100.0;
            let mut max = min + size;
            if flat < 3 {
                max[flat] = min[flat];
            }
            Aabb::new(min, max)
        })
}

/// A direction whose components are ordinary, tiny (nearly axis-parallel rays, whose
/// reciprocals are huge) or zero.
fn direction() -> impl Strategy<Value = Vec3A> {
    let component = prop_oneof![
        4 => -1.0f32..1.0,
        1 => -1e-6f32..1e-6,
        1 => Just(0.0f32),
    ];
    [component.clone(), component.clone(), component].prop_map(Vec3A::from_array)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 4000, rng_seed: proptest::test_runner::RngSeed::Fixed(17), ..ProptestConfig::default() })]

    /// The fused test, far from the origin and near it: every box the exact ray touches
    /// within its range is hit, and entered no later than exactly. (The fused offset's
    /// rounding is absolute and grows with `|origin * inv_direction|`: without its slack,
    /// this fails on boxes a million units out.)
    #[test]
    fn fused_test_never_misses_what_the_exact_ray_touches(
        center in prop_oneof![
            Just(Vec3A::ZERO),
            [-1e6f32..1e6, -1e6f32..1e6, -1e6f32..1e6].prop_map(Vec3A::from_array),
        ],
        seed_boxes in proptest::collection::vec(box_near(Vec3A::ZERO), 16),
        from in [-150.0f32..150.0, -150.0f32..150.0, -150.0f32..150.0],
        direction in direction(),
        t_min in prop_oneof![Just(0.0f32), 0.0f32..50.0],
        t_max in prop_oneof![Just(f32::INFINITY), 0.0f32..500.0],
    ) {
        prop_assume!(direction != Vec3A::ZERO);
        let mut node = WideNode::<16>::default();
        for (slot, b) in seed_boxes.iter().enumerate() {
            node.set_child_aabb(slot, &Aabb::new(b.min + center, b.max + center));
        }
        let origin = center + Vec3A::from_array(from);
        let ray = Ray::with_range(origin, direction, t_min, t_max);
        let lanes = RayLanes::new(&ray);
        let mut entry_t = [0.0f32; 16];
        let mask = if lanes.fused {
            slab_test_flat::<16, true>(node.planes(), &lanes, ray.t_max, &mut entry_t)
        } else {
            slab_test_flat::<16, false>(node.planes(), &lanes, ray.t_max, &mut entry_t)
        };
        for (slot, &entry) in entry_t.iter().enumerate() {
            // What the node holds: the shifted boxes, rounded to f32.
            let b = node.child_aabb(slot);
            if let Some((near, _)) = exact_interval(&ray, direction, &b) {
                prop_assert!(mask & (1 << slot) != 0, "slot {} missed: {:?} {:?}", slot, ray, b);
                let late = (f64::from(entry) - near) / near.abs().max(f64::MIN_POSITIVE);
                prop_assert!(late <= 1e-12, "slot {} entered late: {} > {}", slot, entry, near);
            }
        }
    }
}

/// Axis-parallel rays (an infinite reciprocal) take the unfused test; a nearly parallel ray
/// far from the origin, whose offsets are huge but finite, the fused one.
#[test]
fn only_rays_without_finite_offsets_skip_the_fused_test() {
    let far = Vec3A::new(1e6, -1e6, 1e6);
    assert!(!RayLanes::new(&Ray::new(far, Vec3A::new(1.0, 0.0, 0.5))).fused);
    assert!(!RayLanes::new(&Ray::new(Vec3A::ZERO, Vec3A::new(1.0, -0.0, 0.5))).fused);
    assert!(RayLanes::new(&Ray::new(far, Vec3A::new(1.0, 1e-6, 0.5))).fused);
}
