//! The box structures on hostile scenes (degenerate boxes, far from the origin, huge and
//! tiny), every query against the oracle, with axis-parallel rays, rays starting on faces
//! and rays lying in face planes.

use super::oracle::{Queries, Volume, check_nearest, check_ray, check_volume, oracle_of};
use super::{Sizes, Tally};
use accel_testkit::{BoxScene, Rng, box_scene};
use glam::{Mat4, Vec3, Vec3A};
use spatial_accel::bvh::SphereBvh;
use spatial_accel::bvh::wide::{Bvh4, Bvh8, Bvh16, QBvh8};
use spatial_accel::dynamic::{LayeredIndex, StaticDynamicPair};
use spatial_accel::query::{AnyIndex, DynamicIndex, IndexKind, KeyedList};
use spatial_accel::{Aabb, BuildConfig, Bvh, DynamicBvh, Frustum, Ray, Sphere, SplitStrategy};
use std::collections::HashMap;
use std::time::Duration;

/// Every structure over `entries`, by name. A build that panics is counted and left out.
pub fn structures(tally: &mut Tally, entries: &[(u32, Aabb)]) -> Vec<(String, Box<dyn Queries>)> {
    let boxes: Vec<Aabb> = entries.iter().map(|e| e.1).collect();
    let mut out: Vec<(String, Box<dyn Queries>)> = Vec::new();
    let mut add = |tally: &mut Tally, name: &str, build: &dyn Fn() -> Box<dyn Queries>| {
        if let Some(s) = tally.guard(name, "build", |_| build()) {
            out.push((name.to_string(), s));
        }
    };
    for (cfg_name, cfg) in [
        ("binned", BuildConfig::default()),
        ("midpoint", BuildConfig::with_split(SplitStrategy::Midpoint)),
        ("sweep", BuildConfig::with_split(SplitStrategy::SweepSah)),
        ("lbvh", BuildConfig::with_split(SplitStrategy::Lbvh)),
        ("ploc", BuildConfig::with_split(SplitStrategy::PLOC)),
    ] {
        add(tally, &format!("Bvh {cfg_name}"), &|| {
            Box::new(Bvh::build(&boxes, &cfg))
        });
    }
    let bvh = Bvh::build(&boxes, &BuildConfig::default());
    add(tally, "Bvh parallel", &|| {
        Box::new(Bvh::build_parallel(&boxes, &BuildConfig::default()))
    });
    add(tally, "Bvh4", &|| Box::new(Bvh4::from_bvh(&bvh)));
    add(tally, "Bvh8", &|| Box::new(Bvh8::from_bvh(&bvh)));
    add(tally, "Bvh16", &|| Box::new(Bvh16::from_bvh(&bvh)));
    add(tally, "Bvh16 inlined", &|| {
        let mut t = Bvh16::from_bvh(&bvh);
        t.inline_single_leaves();
        Box::new(t)
    });
    add(tally, "QBvh8", &|| Box::new(QBvh8::from_bvh(&bvh)));
    add(tally, "SphereBvh", &|| {
        Box::new(SphereBvh::from_bvh(&bvh, &boxes))
    });
    add(tally, "DynamicBvh", &|| {
        let mut t = DynamicBvh::new();
        for &(id, b) in entries {
            let _ = t.insert(id, b);
        }
        t.maintain();
        Box::new(t)
    });
    for kind in IndexKind::ALL {
        add(tally, &format!("{kind:?}"), &|| {
            let mut t = AnyIndex::new(kind);
            for &(id, b) in entries {
                let _ = t.insert(id, b);
            }
            t.maintain(Duration::ZERO);
            Box::new(t)
        });
    }
    add(tally, "KeyedList", &|| {
        // In spatial order, with its runs' bounds computed: narrow runs that queries skip,
        // their margins taken at the scene's coordinates (far away, blown up, shrunk).
        let mut order: Vec<(u32, Aabb)> = entries.to_vec();
        order.sort_by(|a, b| a.1.min.x.total_cmp(&b.1.min.x));
        let mut list = KeyedList::new();
        for (key, &(id, b)) in order.iter().enumerate() {
            let _ = list.insert(key as u32, 0, id, b, 0);
        }
        list.tighten_chunk_bounds();
        Box::new(list)
    });
    let half = entries.len() / 2;
    let static_half: Vec<Aabb> = boxes[..half].to_vec();
    add(tally, "StaticDynamicPair", &|| {
        let mut p = StaticDynamicPair::new(
            Bvh::build(&static_half, &BuildConfig::default()),
            DynamicBvh::new(),
        );
        for &(id, b) in &entries[half..] {
            let _ = p.dynamic_mut().insert(id, b);
        }
        p.maintain_dynamic();
        p.snapshot_dynamic_for_rays(&BuildConfig::default());
        Box::new(p)
    });
    add(tally, "LayeredIndex grid", &|| {
        let mut p = LayeredIndex::new(
            Bvh::build(&static_half, &BuildConfig::default()),
            AnyIndex::new(IndexKind::Grid),
        );
        for &(id, b) in &entries[half..] {
            let _ = p.dynamic_mut().insert(id, b);
        }
        p.dynamic_mut().maintain(Duration::ZERO);
        Box::new(p)
    });
    out
}

/// The scenes: testkit's uniform, clustered and degenerate boxes, and copies moved far
/// away, blown up and shrunk.
fn scenes(n: usize) -> Vec<(String, Vec<Aabb>)> {
    let mut out = Vec::new();
    for kind in [BoxScene::Uniform, BoxScene::Clustered, BoxScene::Degenerate] {
        out.push((
            format!("{kind:?}"),
            box_scene(kind, n, 0x57e55 ^ kind as u64),
        ));
    }
    let base = box_scene(BoxScene::Degenerate, n, 0xfa5);
    for offset in [1e3f32, 1e5, 1e7] {
        let shift = Vec3A::new(offset, -0.7 * offset, 0.3 * offset);
        out.push((
            format!("degenerate at {offset:e}"),
            base.iter()
                .map(|b| Aabb::new(b.min + shift, b.max + shift))
                .collect(),
        ));
    }
    for scale in [1e-6f32, 1e-3, 1e3, 1e6] {
        out.push((
            format!("degenerate scaled {scale:e}"),
            base.iter()
                .map(|b| Aabb::new(b.min * scale, b.max * scale))
                .collect(),
        ));
    }
    out
}

/// Rays for a scene: random, axis-parallel with signed zeros, starting on a box's face or
/// corner, and lying in a face plane (grazing).
fn rays(rng: &mut Rng, boxes: &[Aabb], n: usize) -> Vec<Ray> {
    let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let (c, h) = (
        bounds.center(),
        bounds.half_extents().max(Vec3A::splat(1e-30)),
    );
    let mut out = Vec::new();
    for i in 0..n {
        let o = c + rng.vec3a(-1.5, 1.5) * h;
        out.push(Ray::new(o, rng.unit_vector()));
        let mut d = Vec3A::ZERO;
        d[i % 3] = if rng.bool() { 1.0 } else { -1.0 };
        d[(i + 1) % 3] = -0.0;
        out.push(Ray::new(o, d));
        let b = boxes[rng.below(boxes.len())];
        let corner = b.corners()[rng.below(8)];
        out.push(Ray::new(corner, rng.unit_vector()));
        // In the plane of a face, across it.
        let mut start = b.center();
        let axis = rng.below(3);
        start[axis] = b.min[axis];
        let mut along = rng.unit_vector();
        along[axis] = 0.0;
        out.push(Ray::new(start - along * h.max_element(), along));
        // A segment ending on a box's face.
        out.push(Ray::segment(o, start));
    }
    out
}

/// Volume queries for a scene.
fn volumes(rng: &mut Rng, boxes: &[Aabb], n: usize) -> Vec<Volume> {
    let bounds = boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
    let (c, h) = (
        bounds.center(),
        bounds.half_extents().max(Vec3A::splat(1e-30)),
    );
    let mut out = Vec::new();
    for _ in 0..n {
        let p = c + rng.vec3a(-1.2, 1.2) * h;
        let b = boxes[rng.below(boxes.len())];
        out.push(Volume::Box(Aabb::from_center_half_extents(
            p,
            rng.vec3a(0.0, 0.3) * h,
        )));
        out.push(Volume::Box(b));
        out.push(Volume::Sphere(Sphere::new(p, rng.f32() * h.max_element())));
        out.push(Volume::Point(p));
        out.push(Volume::Point(b.corners()[rng.below(8)]));
        let eye = c + rng.vec3a(-2.0, 2.0) * h;
        let view = Mat4::look_at_rh(eye.into(), Vec3::from(c), Vec3::Y);
        let proj = Mat4::perspective_rh(
            rng.range(0.3, 1.5),
            1.5,
            h.max_element() * 1e-3,
            h.max_element() * 4.0,
        );
        out.push(Volume::Frustum(Frustum::from_clip_from_world(
            &(proj * view),
        )));
    }
    out
}

/// Every structure on every scene, every query.
pub fn run(tally: &mut Tally, sizes: &Sizes) {
    let mut rng = Rng::new(0xb0c5);
    for (_scene, boxes) in scenes(300) {
        let entries: Vec<(u32, Aabb)> = boxes
            .iter()
            .enumerate()
            .map(|(i, &b)| (i as u32, b))
            .collect();
        let live: HashMap<u32, Aabb> = entries.iter().copied().collect();
        let oracle = oracle_of(&live);
        let rays = rays(&mut rng, &boxes, sizes.box_queries);
        let volumes = volumes(&mut rng, &boxes, sizes.box_queries);
        let points: Vec<Vec3A> = volumes
            .iter()
            .filter_map(|v| {
                if let Volume::Point(p) = v {
                    Some(*p)
                } else {
                    None
                }
            })
            .collect();
        for (name, s) in structures(tally, &entries) {
            for ray in &rays {
                check_ray(tally, &name, &*s, &oracle, &live, ray);
            }
            for q in &volumes {
                check_volume(tally, &name, &*s, &oracle, &live, q);
            }
            for (i, &p) in points.iter().enumerate() {
                check_nearest(tally, &name, &*s, &oracle, &live, p, [1, 5, 40][i % 3]);
            }
        }
    }
}
