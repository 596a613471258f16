//! The four-wide watertight test must give, lane by lane, exactly what the single test gives:
//! the same hits, bit-for-bit the same `t`, barycentrics and facing, on random and adversarial
//! inputs (shared edges and vertices hit exactly, axis-aligned rays, degenerate and NaN
//! triangles, edge functions that overflow, culling, clipped ranges).

use accel_testkit::Rng;
use glam::Vec3A;
use spatial_accel::{Aabb, Backfaces, Ray, Triangle4, WatertightRay};

fn random_point(rng: &mut Rng, extent: f32) -> Vec3A {
    Vec3A::new(
        rng.range(-extent, extent),
        rng.range(-extent, extent),
        rng.range(-extent, extent),
    )
}

/// A triangle from a small pool of shared corners (so rays through shared edges and vertices
/// come up), sometimes degenerate, sometimes NaN.
fn random_triangle(rng: &mut Rng, pool: &[Vec3A]) -> [Vec3A; 3] {
    let mut t = [rng.pick(pool), rng.pick(pool), rng.pick(pool)];
    match rng.below(20) {
        0 => t[2] = t[0],
        1 => t[1] = Vec3A::splat(f32::NAN),
        2 => t[2] = (t[0] + t[1]) * 0.5,
        _ => {}
    }
    t
}

#[test]
fn four_wide_test_equals_the_single_test_lane_by_lane() {
    let mut rng = Rng::new(0x7a11);
    let mut hits = 0usize;
    let mut aimed_at_corners = 0usize;
    for round in 0..40_000 {
        // At 1e19 the edge functions' products overflow to infinities of either sign.
        let extent = [1.0, 1e3, 1e5, 1e19][round % 4];
        let pool: Vec<Vec3A> = (0..6).map(|_| random_point(&mut rng, extent)).collect();
        let mut tris = Triangle4::default();
        let lanes = 1 + rng.below(4);
        let corners: Vec<[Vec3A; 3]> = (0..lanes)
            .map(|_| random_triangle(&mut rng, &pool))
            .collect();
        for (lane, c) in corners.iter().enumerate() {
            tris.set(lane, *c);
        }
        // Aim at a corner, an edge midpoint or a random point; from random or axis directions.
        let target = match rng.below(3) {
            0 => rng.pick(&pool),
            1 => (rng.pick(&pool) + rng.pick(&pool)) * 0.5,
            _ => random_point(&mut rng, extent),
        };
        let origin = if rng.below(4) == 0 {
            let mut o = target;
            let axis = rng.below(3);
            o[axis] += extent * 3.0;
            o
        } else {
            random_point(&mut rng, extent * 3.0)
        };
        let mut ray = Ray::new(origin, target - origin);
        if rng.below(5) == 0 {
            ray.t_max = rng.range(0.0, 1.5);
        }
        let wt = WatertightRay::new(&ray);
        for backfaces in [Backfaces::Include, Backfaces::Cull] {
            let four = wt.intersect4(&tris, backfaces);
            for lane in 0..4 {
                let single = corners
                    .get(lane)
                    .and_then(|&[a, b, c]| wt.intersect_vertices(a, b, c, backfaces));
                let got = (four.mask & (1 << lane) != 0).then(|| four.hit(lane));
                let same = match (single, got) {
                    (Some(a), Some(b)) => {
                        a.t.to_bits() == b.t.to_bits()
                            && a.u.to_bits() == b.u.to_bits()
                            && a.v.to_bits() == b.v.to_bits()
                            && a.front_face == b.front_face
                    }
                    (None, None) => true,
                    _ => false,
                };
                assert!(
                    same,
                    "round {round} lane {lane}: single {single:?}, four {got:?}"
                );
                hits += usize::from(single.is_some());
            }
            let closest = corners
                .iter()
                .enumerate()
                .filter_map(|(i, &[a, b, c])| {
                    wt.intersect_vertices(a, b, c, backfaces).map(|h| (i, h.t))
                })
                .fold(None, |best: Option<(usize, f32)>, (i, t)| match best {
                    Some((_, bt)) if bt <= t => best,
                    _ => Some((i, t)),
                });
            assert_eq!(
                four.closest().map(|(i, h)| (i, h.t)),
                closest,
                "round {round}"
            );
        }
        // Rays aimed exactly at corners hit edge functions of exactly zero.
        let [a, b, c] = corners[0];
        aimed_at_corners += usize::from([a, b, c].contains(&target));
        // The packet's box is the union of its finite lanes' boxes.
        let want = corners
            .iter()
            .filter(|c| c.iter().all(|v| v.is_finite()))
            .fold(Aabb::EMPTY, |acc, c| acc.union(&Aabb::from_points(*c)));
        assert_eq!(tris.bounds(), want, "round {round}");
        let bits = |c: [Vec3A; 3]| c.map(|v| v.to_array().map(f32::to_bits));
        assert_eq!(bits(tris.get(0)), bits(corners[0]));
    }
    assert!(hits > 10_000, "too few hits to mean anything: {hits}");
    assert!(aimed_at_corners > 1_000, "{aimed_at_corners}");
}
