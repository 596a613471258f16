//! Build time against tree quality: every split strategy and arity on testkit's box scenes
//! and on triangles (the bunny; the bunny-copies scene in the full run), rated by SAH cost
//! and by measured closest-hit ray time; the sphere-bounded BVH against the box trees; the
//! mesh BVH's builds on the triangle scenes.
//!
//! This covers `examples/build_timing.rs` (split strategies over random boxes, time and SAH
//! cost), which it replaces. BENCHMARKS.md's "Static BVH builds" table, with its peers timed
//! round by round, comes from [`super::static_builds`].

use super::{incoherent_rays, point};
use crate::json::{Point, Report};
use crate::progress::Progress;
use crate::timing::{best_of, per_item};
use accel_testkit::{BoxScene, box_scene};
use spatial_accel::bvh::SphereBvh;
use spatial_accel::bvh::stats::tree_stats;
use spatial_accel::bvh::wide::{Bvh4, Bvh8, Bvh16, QBvh8};
use spatial_accel::mesh::{MeshBvh, SpatialSplits};
use spatial_accel::query::BoundingTree;
use spatial_accel::{
    Aabb, Backfaces, BuildConfig, Bvh, Ray, SahCosts, SpatialQuery, SplitStrategy, Triangle,
    WatertightRay,
};

const SPLITS: [(&str, SplitStrategy); 9] = [
    ("midpoint", SplitStrategy::Midpoint),
    ("median", SplitStrategy::Median),
    ("binned8", SplitStrategy::BinnedSah { bins: 8 }),
    ("binned16", SplitStrategy::BinnedSah { bins: 16 }),
    ("binned32", SplitStrategy::BinnedSah { bins: 32 }),
    ("sweep", SplitStrategy::SweepSah),
    ("lbvh", SplitStrategy::Lbvh),
    ("ploc-fastest", SplitStrategy::PLOC_FASTEST),
    ("ploc", SplitStrategy::PLOC),
];

/// A scene: boxes, and the triangles inside them when it is a mesh.
struct Scene {
    name: String,
    boxes: Vec<Aabb>,
    triangles: Option<Vec<Triangle>>,
    /// Closest-hit rays timed per tree.
    rays: usize,
}

fn scenes(quick: bool) -> Vec<Scene> {
    let n = if quick { 20_000 } else { 200_000 };
    let rays = if quick { 1_000 } else { 10_000 };
    let mut out: Vec<Scene> = [BoxScene::Uniform, BoxScene::Clustered, BoxScene::Degenerate]
        .into_iter()
        .map(|kind| Scene {
            name: format!("{kind:?} {n}"),
            boxes: box_scene(kind, n, 0xb01d ^ kind as u64),
            triangles: None,
            // Three in four degenerate boxes pile up in the cube the rays start in, so every
            // ray tests most of the scene whatever the tree: a tenth of the rays gives the
            // same per-ray figure in a tenth of the time (the full run spent minutes here).
            rays: if kind == BoxScene::Degenerate {
                rays / 10
            } else {
                rays
            },
        })
        .collect();
    let mut meshes = vec![(
        "bunny".to_string(),
        accel_testkit::bunny().normalized(100.0).to_triangles(),
    )];
    if !quick {
        meshes.push((
            "bunny copies 300k".into(),
            accel_testkit::triangle_scene(300_000, 7),
        ));
    }
    for (name, tris) in meshes {
        out.push(Scene {
            name,
            boxes: tris.iter().map(Triangle::aabb).collect(),
            triangles: Some(tris),
            rays,
        });
    }
    out
}

/// Seconds per closest-hit ray through `tree`, with the scene's exact test.
fn ray_time<T: SpatialQuery>(tree: &T, scene: &Scene, rays: &[Ray], runs: usize) -> f64 {
    match &scene.triangles {
        Some(tris) => per_item(runs, rays.len(), |i| {
            let wt = WatertightRay::new(&rays[i]);
            tree.cast_ray(&rays[i], |p, _| {
                wt.intersect(&tris[p as usize], Backfaces::Include)
                    .map(|h| h.t)
            })
        }),
        None => per_item(runs, rays.len(), |i| {
            tree.cast_ray(&rays[i], |p, r| r.intersect_aabb(&scene.boxes[p as usize]))
        }),
    }
}

/// The two points of one tree: build time against SAH cost and against ray time.
fn points_of<T: SpatialQuery + BoundingTree<Volume = Aabb>>(
    out: &mut Vec<Point>,
    scene: &Scene,
    (method, setting): (&str, &str),
    build_s: f64,
    tree: &T,
    rays: &[Ray],
    runs: usize,
) {
    let sah = tree_stats(tree, &SahCosts::default()).sah_cost as f64;
    let ray = ray_time(tree, scene, rays, runs) * 1e9;
    let time = ("build ms", build_s * 1e3);
    out.push(point(
        &scene.name,
        method,
        setting,
        time,
        ("SAH cost", Some(sah)),
    ));
    out.push(point(
        &scene.name,
        method,
        setting,
        time,
        ("ns per ray", Some(ray)),
    ));
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let runs = if quick { 1 } else { 3 };
    let scenes = scenes(quick);
    let mut progress = Progress::new("build", scenes.len() * (SPLITS.len() + 2));
    let mut points = Vec::new();
    for scene in &scenes {
        let bounds = scene.boxes.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        let rays = incoherent_rays(scene.rays, bounds.half_extents().max_element(), 0x5eed);
        for (name, split) in SPLITS {
            progress.step(&format!("{} {name}", scene.name));
            let cfg = BuildConfig::with_split(split);
            let (t, bvh) = best_of(runs, || Bvh::build(&scene.boxes, &cfg));
            points_of(&mut points, scene, (name, "binary"), t, &bvh, &rays, runs);
            let (c, wide) = best_of(runs, || Bvh4::from_bvh(&bvh));
            points_of(
                &mut points,
                scene,
                (name, "4-wide"),
                t + c,
                &wide,
                &rays,
                runs,
            );
            let (c, wide) = best_of(runs, || Bvh8::from_bvh(&bvh));
            points_of(
                &mut points,
                scene,
                (name, "8-wide"),
                t + c,
                &wide,
                &rays,
                runs,
            );
            let (c, wide) = best_of(runs, || Bvh16::from_bvh(&bvh));
            points_of(
                &mut points,
                scene,
                (name, "16-wide"),
                t + c,
                &wide,
                &rays,
                runs,
            );
            let (c, wide) = best_of(runs, || QBvh8::from_bvh(&bvh));
            points_of(
                &mut points,
                scene,
                (name, "8-wide quantized"),
                t + c,
                &wide,
                &rays,
                runs,
            );
            if name == "binned16" {
                let (t, par) = best_of(runs, || Bvh::build_parallel(&scene.boxes, &cfg));
                points_of(
                    &mut points,
                    scene,
                    ("binned16 parallel", "binary"),
                    t,
                    &par,
                    &rays,
                    runs,
                );
                // Spheres instead of boxes: no box SAH, so only the ray time.
                let (c, spheres) = best_of(runs, || SphereBvh::from_bvh(&bvh, &scene.boxes));
                let ray = ray_time(&spheres, scene, &rays, runs) * 1e9;
                let time = ("build ms", (t + c) * 1e3);
                points.push(point(
                    &scene.name,
                    "binned16 spheres",
                    "binary",
                    time,
                    ("ns per ray", Some(ray)),
                ));
                points.push(point(
                    &scene.name,
                    "binned16 spheres",
                    "binary",
                    time,
                    ("SAH cost", None),
                ));
            }
        }
        progress.step(&format!("{} mesh BVHs", scene.name));
        if let Some(tris) = &scene.triangles {
            let vertices: Vec<glam::Vec3> = tris
                .iter()
                .flat_map(|t| t.vertices.map(glam::Vec3::from))
                .collect();
            let indices: Vec<u32> = (0..vertices.len() as u32).collect();
            let builds: [(&str, &dyn Fn() -> MeshBvh); 3] = [
                ("MeshBvh presplit", &|| {
                    MeshBvh::new(&vertices, &indices).expect("a triangle list")
                }),
                ("MeshBvh whole", &|| {
                    MeshBvh::with_config(&vertices, &indices, &MeshBvh::default_config(tris.len()))
                        .expect("a triangle list")
                }),
                ("MeshBvh sbvh", &|| {
                    MeshBvh::with_spatial_splits(
                        &vertices,
                        &indices,
                        &BuildConfig::default(),
                        &SpatialSplits::default(),
                    )
                    .expect("a triangle list")
                }),
            ];
            for (name, build) in builds {
                let (t, mesh) = best_of(runs, build);
                let sah = tree_stats(mesh.tree(), &SahCosts::default()).sah_cost as f64;
                let ray = per_item(runs, rays.len(), |i| {
                    mesh.cast_ray(&rays[i], Backfaces::Include)
                }) * 1e9;
                let time = ("build ms", t * 1e3);
                points.push(point(
                    &scene.name,
                    name,
                    "16-wide",
                    time,
                    ("SAH cost", Some(sah)),
                ));
                points.push(point(
                    &scene.name,
                    name,
                    "16-wide",
                    time,
                    ("ns per ray", Some(ray)),
                ));
            }
        }
        progress.step(&scene.name);
    }
    progress.finish();
    let mut report = Report {
        suite: "build".into(),
        quick,
        points,
        ..Report::default()
    };
    super::static_builds::add(quick, &mut report);
    report
}
