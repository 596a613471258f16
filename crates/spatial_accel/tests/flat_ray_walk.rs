//! The flat lists' ray walk (four boxes a step, lane-wise) against the one-by-one loop it
//! replaced: the same boxes visited in the same order, for rays that collect every hit,
//! rays that shrink their range at each hit (a closest-hit search) and walks stopped early;
//! list lengths that leave a tail of one to three boxes.

use accel_testkit::Rng;
use core::ops::ControlFlow;
use glam::Vec3A;
use spatial_accel::query::{BruteForceIndex, DynamicIndex, KeyedList, RayWalk};
use spatial_accel::{Aabb, Ray};

fn random_box(rng: &mut Rng) -> Aabb {
    let centre = rng.vec3a(-30.0, 30.0);
    let mut half = rng.vec3a(0.0, 1.0) * rng.log_range(1e-3, 10.0);
    if rng.below(5) == 0 {
        half[rng.below(3)] = 0.0;
    }
    Aabb::new(centre - half, centre + half)
}

fn random_ray(rng: &mut Rng, boxes: &[Aabb]) -> Ray {
    let origin = rng.vec3a(-40.0, 40.0);
    let mut direction = if rng.bool() {
        // Aimed at a box's corner.
        let b = boxes[rng.below(boxes.len())];
        Vec3A::new(b.min.x, b.max.y, b.min.z) - origin
    } else {
        rng.unit_vector()
    };
    if rng.below(4) == 0 {
        direction[rng.below(3)] = if rng.bool() { 0.0 } else { -0.0 };
    }
    let t_max = [f32::INFINITY, rng.log_range(0.1, 100.0)][rng.below(2)];
    Ray::with_range(origin, direction, 0.0, t_max)
}

/// What a walk visited, and the ray's range at each visit, under three ways of visiting.
fn visits(
    walk: impl Fn(&mut Ray, &mut dyn FnMut(u32, &mut Ray) -> ControlFlow<()>),
    ray: Ray,
    boxes: &[Aabb],
) -> [Vec<(u32, u32)>; 3] {
    let mut all = Vec::new();
    walk(&mut ray.clone(), &mut |id, r| {
        all.push((id, r.t_max.to_bits()));
        ControlFlow::Continue(())
    });
    let mut closest = Vec::new();
    walk(&mut ray.clone(), &mut |id, r| {
        closest.push((id, r.t_max.to_bits()));
        // Shrink to the box's centre distance along the ray, as a closest-hit search does.
        let centre = boxes[id as usize].center();
        let t = (centre - r.origin).dot(r.direction) / r.direction.length_squared();
        if t >= r.t_min && t < r.t_max {
            r.t_max = t;
        }
        ControlFlow::Continue(())
    });
    let mut first_three = Vec::new();
    walk(&mut ray.clone(), &mut |id, r| {
        first_three.push((id, r.t_max.to_bits()));
        if first_three.len() == 3 {
            ControlFlow::Break(())
        } else {
            ControlFlow::Continue(())
        }
    });
    [all, closest, first_three]
}

/// The loop the lane-wise walk replaced.
fn one_by_one(
    boxes: &[Aabb],
    ray: &mut Ray,
    visit: &mut dyn FnMut(u32, &mut Ray) -> ControlFlow<()>,
) {
    if !ray.is_traceable() {
        return;
    }
    for (id, b) in boxes.iter().enumerate() {
        if ray.intersect_aabb(b).is_some() && visit(id as u32, ray).is_break() {
            return;
        }
    }
}

#[test]
fn flat_lists_visit_what_the_one_by_one_loop_visits() {
    let mut rng = Rng::new(0xf1a7);
    let mut visited = 0;
    for round in 0..600 {
        let n = 1 + rng.below(120) + round % 4;
        let boxes: Vec<Aabb> = (0..n).map(|_| random_box(&mut rng)).collect();
        let mut brute = BruteForceIndex::new();
        let mut keyed = KeyedList::new();
        for (i, b) in boxes.iter().enumerate() {
            brute.insert(i as u32, *b).unwrap();
            keyed.insert(i as u32, 0, i as u32, *b, 0).unwrap();
        }
        for _ in 0..8 {
            let ray = random_ray(&mut rng, &boxes);
            let expected = visits(|r, v| one_by_one(&boxes, r, v), ray, &boxes);
            let from_brute = visits(|r, v| brute.walk_ray(r, |id, r| v(id, r)), ray, &boxes);
            let from_keyed = visits(|r, v| keyed.walk_ray(r, |id, r| v(id, r)), ray, &boxes);
            assert_eq!(from_brute, expected, "brute force, ray {ray:?}");
            assert_eq!(from_keyed, expected, "keyed list, ray {ray:?}");
            visited += expected[0].len();
        }
    }
    assert!(
        visited > 1_000,
        "{visited} hits: the rays must hit something"
    );
}

/// The keyed list skips whole chunks whose bounds the ray misses at its current range: with
/// entries in spatial order (chunks over small regions) and bounds tightened, it must still
/// visit what the one-by-one loop visits, in its order, also while a closest-hit search
/// shrinks the range between chunks, and for rays lying on a chunk's planes.
#[test]
fn chunk_skipping_keeps_the_visits_of_the_one_by_one_loop() {
    let mut rng = Rng::new(0xc4a);
    let (mut visited, mut skippable) = (0, 0);
    for _ in 0..120 {
        let n = 200 + rng.below(500);
        let mut boxes: Vec<Aabb> = (0..n).map(|_| random_box(&mut rng)).collect();
        boxes.sort_by(|a, b| a.min.x.total_cmp(&b.min.x));
        let mut keyed = KeyedList::new();
        for (i, b) in boxes.iter().enumerate() {
            keyed.insert(i as u32, 0, i as u32, *b, 0).unwrap();
        }
        keyed.tighten_chunk_bounds();
        let planes: Vec<Aabb> = keyed.chunks().filter_map(|c| c.bounds.copied()).collect();
        for _ in 0..20 {
            let mut ray = random_ray(&mut rng, &boxes);
            if rng.below(3) == 0 {
                // Starting on a chunk's face, along it or through it.
                let chunk = planes[rng.below(planes.len())];
                ray.origin.x = [chunk.min.x, chunk.max.x][rng.below(2)];
                ray = Ray::with_range(ray.origin, ray.direction, ray.t_min, ray.t_max);
            }
            skippable += planes.iter().filter(|b| !ray.hits_aabb(b)).count();
            let expected = visits(|r, v| one_by_one(&boxes, r, v), ray, &boxes);
            let from_keyed = visits(|r, v| keyed.walk_ray(r, |id, r| v(id, r)), ray, &boxes);
            assert_eq!(from_keyed, expected, "keyed list, ray {ray:?}");
            visited += expected[0].len();
        }
    }
    assert!(
        visited > 1_000,
        "{visited} hits: the rays must hit something"
    );
    assert!(
        skippable > 10_000,
        "{skippable} chunks missed: the walk must skip some"
    );
}
