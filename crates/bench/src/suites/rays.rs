//! Ray time against error on triangles: coherent (a camera's pixel grid), incoherent and
//! shadow (any-hit) rays through the bunny-copies scene, as one mesh BVH, as a two-level
//! `InstancedScene`, as box trees with the watertight test in the callback, and through the
//! peers obvhs 0.3.3 (CWBVH, BVH2) and bvh 0.13. The error is the share of checked rays
//! whose answer differs from `BruteForceMesh` (hit or miss, or the distance by more than
//! 1e-4 relative). Measures what `examples/ray_timing.rs` measures, at bench sizes, without
//! its round-by-round ratios.

use super::common::peers::{self, BvhShape};
use super::{camera_rays, incoherent_rays, point};
use crate::json::{Point, Report};
use crate::progress::Progress;
use crate::timing::per_item;
use accel::bvh::wide::Bvh8;
use accel::mesh::{Instance, InstancedScene, MeshBvh};
use accel::query::{BruteForceMesh, TriangleQuery};
use accel::{Backfaces, BuildConfig, Bvh, Ray, SpatialQuery, Triangle, WatertightRay};
use accel_testkit::{TRI_EXTENT, instanced_triangle_scene};
use glam::{Affine3A, Vec3, Vec3A};
use obvhs::BvhBuildParams;
use std::sync::Arc;
use std::time::Duration;

/// A tracer: ray `i` of a set, closest `t` (or `Some(0.0)` when an any-hit ray is blocked).
type Tracer<'a> = Box<dyn Fn(&Ray, bool) -> Option<f32> + 'a>;

fn triangle_list(tris: &[Triangle]) -> (Vec<Vec3>, Vec<u32>) {
    let v: Vec<Vec3> = tris
        .iter()
        .flat_map(|t| t.vertices.map(Vec3::from))
        .collect();
    let i = (0..v.len() as u32).collect();
    (v, i)
}

/// Shadow rays: from each primary hit, moved back along the ray, to a light above.
fn shadow_rays(primary: &[Ray], mesh: &MeshBvh) -> Vec<Ray> {
    let light = Vec3A::new(0.3, 4.0, 0.2) * TRI_EXTENT;
    primary
        .iter()
        .filter_map(|r| {
            mesh.cast_ray(r, Backfaces::Include)
                .map(|h| r.at(h.t - 1e-3))
        })
        .map(|p| Ray::with_range(p, (light - p).normalize(), 0.0, (light - p).length()))
        .collect()
}

fn box_tracer<'a, T: SpatialQuery + 'a>(tree: T, tris: &'a [Triangle]) -> Tracer<'a> {
    Box::new(move |ray, any| {
        let wt = WatertightRay::new(ray);
        if any {
            tree.cast_ray_any(ray, |p, _| {
                wt.intersect(&tris[p as usize], Backfaces::Include)
                    .is_some()
            })
            .map(|_| 0.0)
        } else {
            tree.cast_ray(ray, |p, _| {
                wt.intersect(&tris[p as usize], Backfaces::Include)
                    .map(|h| h.t)
            })
            .map(|h| h.t)
        }
    })
}

fn tracers<'a>(
    tris: &'a [Triangle],
    parts: &accel_testkit::InstancedTriangles,
) -> Vec<(&'static str, &'static str, Tracer<'a>)> {
    let (vertices, indices) = triangle_list(tris);
    let mesh_tracer = |m: MeshBvh| -> Tracer<'a> {
        Box::new(move |r, any| {
            if any {
                m.cast_ray_any(r, Backfaces::Include).then_some(0.0)
            } else {
                m.cast_ray(r, Backfaces::Include).map(|h| h.t)
            }
        })
    };
    let mut out: Vec<(&str, &str, Tracer<'a>)> = vec![
        (
            "MeshBvh",
            "presplit",
            mesh_tracer(MeshBvh::new(&vertices, &indices).expect("a triangle list")),
        ),
        (
            "MeshBvh",
            "whole",
            mesh_tracer(
                MeshBvh::with_config(&vertices, &indices, &MeshBvh::default_config(tris.len()))
                    .expect("a triangle list"),
            ),
        ),
    ];
    // Two levels: one bunny mesh under every copy's transform, the large triangles in place.
    let (bv, bi) = triangle_list(&parts.mesh);
    let bunny = Arc::new(MeshBvh::new(&bv, &bi).expect("a triangle list"));
    let (lv, li) = triangle_list(&parts.loose);
    let mut instances: Vec<Instance> = parts
        .placements
        .iter()
        .map(|m| Instance {
            mesh: bunny.clone(),
            world_from_local: Affine3A::from_mat4(*m),
        })
        .collect();
    if !parts.loose.is_empty() {
        instances.push(Instance {
            mesh: Arc::new(MeshBvh::new(&lv, &li).expect("a triangle list")),
            world_from_local: Affine3A::IDENTITY,
        });
    }
    let scene = InstancedScene::new(instances);
    out.push((
        "InstancedScene",
        "bunny instances",
        Box::new(move |r, any| {
            if any {
                scene.cast_ray_any(r, Backfaces::Include).then_some(0.0)
            } else {
                scene.cast_ray(r, Backfaces::Include).map(|h| h.hit.t)
            }
        }),
    ));
    let boxes: Vec<_> = tris.iter().map(Triangle::aabb).collect();
    let bvh = Bvh::build(&boxes, &BuildConfig::default());
    out.push((
        "Bvh8 + watertight",
        "binned16",
        box_tracer(Bvh8::from_bvh(&bvh), tris),
    ));
    out.push(("Bvh + watertight", "binned16", box_tracer(bvh, tris)));
    // The peers, through the adapters the criterion benches use.
    let ot: Vec<obvhs::triangle::Triangle> = tris.iter().map(peers::to_obvhs_tri).collect();
    let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(
        &ot,
        BvhBuildParams::medium_build(),
        &mut Duration::default(),
    );
    let cw_tris: Vec<_> = cw
        .primitive_indices
        .iter()
        .map(|&p| ot[p as usize])
        .collect();
    out.push((
        "obvhs cwbvh",
        "medium",
        Box::new(move |r, any| {
            let ray = obvhs::ray::Ray::new(r.origin, r.direction, r.t_min, r.t_max);
            let test = |ray: &obvhs::ray::Ray, id: usize| cw_tris[id].intersect(ray);
            if any {
                (!cw.ray_traverse_miss(ray, test)).then_some(0.0)
            } else {
                let mut hit = obvhs::ray::RayHit::none();
                cw.ray_traverse(ray, &mut hit, test).then_some(hit.t)
            }
        }),
    ));
    let b2 = obvhs::bvh2::builder::build_bvh2_from_tris(
        &ot,
        BvhBuildParams::fast_build(),
        &mut Duration::default(),
    );
    let b2_tris: Vec<_> = b2
        .primitive_indices
        .iter()
        .map(|&p| ot[p as usize])
        .collect();
    out.push((
        "obvhs bvh2",
        "fast",
        Box::new(move |r, _| {
            let ray = obvhs::ray::Ray::new(r.origin, r.direction, r.t_min, r.t_max);
            let mut hit = obvhs::ray::RayHit::none();
            b2.ray_traverse(ray, &mut hit, |ray, id| b2_tris[id].intersect(ray))
                .then_some(hit.t)
        }),
    ));
    let mut shapes: Vec<BvhShape> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| BvhShape::new(i, b))
        .collect();
    let tree = bvh::bvh::Bvh::build(&mut shapes);
    out.push((
        "bvh 0.13 + watertight",
        "default",
        Box::new(move |r, _| {
            let wt = WatertightRay::new(r);
            let bray = bvh::ray::Ray::new(
                nalgebra::Point3::new(r.origin.x, r.origin.y, r.origin.z),
                nalgebra::Vector3::new(r.direction.x, r.direction.y, r.direction.z),
            );
            let mut best: Option<f32> = None;
            for s in tree.nearest_traverse_iterator(&bray, &shapes) {
                let t_best = best.unwrap_or(r.t_max);
                match r.with_t_max(t_best).intersect_aabb(&boxes[s.id as usize]) {
                    None => continue,
                    Some(entry) if entry > t_best => break,
                    Some(_) => {}
                }
                if let Some(h) = wt.intersect(&tris[s.id as usize], Backfaces::Include)
                    && h.t < t_best
                {
                    best = Some(h.t);
                }
            }
            best
        }),
    ));
    out
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let (target, n_rays, checked) = if quick {
        (60_000, 4_000, 150)
    } else {
        (1_000_000, 20_000, 400)
    };
    let parts = instanced_triangle_scene(target, 11);
    let tris = parts.flatten();
    let (vertices, indices) = triangle_list(&tris);
    let oracle = BruteForceMesh::new(&vertices, &indices).expect("a triangle list");
    let reference = MeshBvh::new(&vertices, &indices).expect("a triangle list");
    let primary = camera_rays(n_rays, Vec3A::new(0.0, 0.5, 2.5) * TRI_EXTENT);
    let sets = [
        ("coherent", false, primary.clone()),
        (
            "incoherent",
            false,
            incoherent_rays(n_rays, TRI_EXTENT, 0x1c0),
        ),
        ("shadow", true, shadow_rays(&primary, &reference)),
    ];
    let contenders = tracers(&tris, &parts);
    let mut progress = Progress::new("rays", sets.len() * contenders.len());
    let scene = format!("{} triangles", tris.len());
    let mut points: Vec<Point> = Vec::new();
    for (set, any, rays) in &sets {
        let step = (rays.len() / checked).max(1);
        let want: Vec<Option<f32>> = (0..rays.len())
            .step_by(step)
            .map(|i| {
                if *any {
                    oracle
                        .cast_ray_any(&rays[i], Backfaces::Include)
                        .then_some(0.0)
                } else {
                    oracle.cast_ray(&rays[i], Backfaces::Include).map(|h| h.t)
                }
            })
            .collect();
        for (method, setting, trace) in &contenders {
            progress.step(&format!("{set} {method}"));
            let time = per_item(3, rays.len(), |i| trace(&rays[i], *any)) * 1e9;
            let wrong = (0..rays.len())
                .step_by(step)
                .zip(&want)
                .filter(|&(i, w)| match (trace(&rays[i], *any), *w) {
                    // Any-hit rays only say blocked or not.
                    (Some(a), Some(b)) => !*any && (a - b).abs() > 1e-4 * b.abs().max(1.0),
                    (a, b) => a.is_some() != b.is_some(),
                })
                .count();
            let error = wrong as f64 / want.len() as f64;
            points.push(point(
                &format!("{scene}, {set}"),
                method,
                setting,
                ("ns per ray", time),
                ("share of rays wrong", Some(error)),
            ));
        }
    }
    progress.finish();
    Report {
        suite: "rays".into(),
        quick,
        points,
        ..Report::default()
    }
}
