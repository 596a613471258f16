//! Incoherent closest-hit rays per second on the benchmark's 1M-triangle bunny scene (the
//! scene and rays of `benches/bvh_rays.rs`), ours against obvhs 0.3.3's CWBVH, interleaved
//! round by round in one process: a quick, low-noise look before the criterion bench, and a
//! `perf` target.
//!
//! `cargo run --release -p accel --example ray_timing [rounds] [only]`
//!
//! Contenders: `MeshBvh` (8-wide, leaf triangles in 4-wide packets), the 8-wide, quantized
//! 8-wide and 4-wide `WideBvh` over the triangle boxes with the single watertight test in the
//! callback, and obvhs CWBVH (medium preset, its Möller-Trumbore test, triangles in leaf
//! order). `only` keeps the contenders whose name contains it. The environment variable
//! `MESH_CONFIGS` (`leaf:traversal:intersection,...`) adds `MeshBvh`s built with other SAH
//! settings.
//!
//! The machine is shared: each round runs every contender once, and the summary is the median
//! over rounds of each contender's ratio to obvhs *in the same round*.

#[path = "../benches/common/mod.rs"]
mod common;

use accel::bvh::wide::{Bvh4, Bvh8, QBvh8};
use accel::mesh::MeshBvh;
use accel::{
    Aabb, Backfaces, BuildConfig, Bvh, Ray, SahCosts, SpatialQuery, Triangle, WatertightRay,
};
use obvhs::BvhBuildParams;
use std::time::{Duration, Instant};

const RAYS: usize = 20_000;

type Tracer<'a> = Box<dyn Fn(usize) -> Option<f32> + 'a>;

fn rays_per_second(trace: &Tracer<'_>) -> f64 {
    let start = Instant::now();
    let hits = (0..RAYS).filter(|&i| trace(i).is_some()).count();
    std::hint::black_box(hits);
    RAYS as f64 / start.elapsed().as_secs_f64()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A `WideBvh` over the triangle boxes, tracing with the single watertight test.
fn wide_tracer<'a, T: SpatialQuery + 'a>(
    tree: T,
    tris: &'a [Triangle],
    rays: &'a [Ray],
) -> Tracer<'a> {
    Box::new(move |i| {
        let wt = WatertightRay::new(&rays[i]);
        tree.cast_ray(&rays[i], |p, _| {
            wt.intersect(&tris[p as usize], Backfaces::Include)
                .map(|h| h.t)
        })
        .map(|h| h.t)
    })
}

fn mesh_tracer<'a>(mesh: MeshBvh, rays: &'a [Ray]) -> Tracer<'a> {
    Box::new(move |i| mesh.cast_ray(&rays[i], Backfaces::Include).map(|h| h.t))
}

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(11);
    let only = std::env::args().nth(2).unwrap_or_default();
    let tris = common::triangle_scene(1_000_000, 2);
    let boxes: Vec<Aabb> = tris.iter().map(Triangle::aabb).collect();
    let scene_rays = common::incoherent_rays(RAYS, common::TRI_EXTENT, 3);
    let rays: Vec<Ray> = scene_rays.iter().map(|&(o, d)| Ray::new(o, d)).collect();
    let vertices: Vec<glam::Vec3> = tris
        .iter()
        .flat_map(|t| t.vertices.map(glam::Vec3::from))
        .collect();
    let indices: Vec<u32> = (0..vertices.len() as u32).collect();

    let ot: Vec<obvhs::triangle::Triangle> = tris.iter().map(common::peers::to_obvhs_tri).collect();
    let orays: Vec<obvhs::ray::Ray> = scene_rays
        .iter()
        .map(|&(o, d)| obvhs::ray::Ray::new_inf(o, d))
        .collect();
    let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(
        &ot,
        BvhBuildParams::medium_build(),
        &mut Duration::default(),
    );
    let leaf_tris: Vec<_> = cw
        .primitive_indices
        .iter()
        .map(|&p| ot[p as usize])
        .collect();
    let mut contenders: Vec<(String, Tracer)> = Vec::new();
    let mesh = MeshBvh::new(&vertices, &indices).expect("a triangle list");
    println!(
        "MeshBvh: {:.1} bytes/triangle",
        mesh.memory_bytes() as f64 / tris.len() as f64
    );
    contenders.push(("MeshBvh".into(), mesh_tracer(mesh, &rays)));
    for c in std::env::var("MESH_CONFIGS")
        .unwrap_or_default()
        .split_terminator(',')
    {
        let p: Vec<f32> = c.split(':').map(|x| x.parse().expect("a number")).collect();
        let config = BuildConfig {
            max_leaf_size: p[0] as u32,
            sah: SahCosts {
                traversal: p[1],
                intersection: p[2],
            },
            ..BuildConfig::default()
        };
        let mesh = MeshBvh::with_config(&vertices, &indices, &config).expect("a triangle list");
        contenders.push((format!("MeshBvh({c})"), mesh_tracer(mesh, &rays)));
    }
    let bvh = Bvh::build(&boxes, &BuildConfig::default());
    contenders.push((
        "Bvh8 + single test".into(),
        wide_tracer(Bvh8::from_bvh(&bvh), &tris, &rays),
    ));
    contenders.push((
        "QBvh8 + single test".into(),
        wide_tracer(QBvh8::from_bvh(&bvh), &tris, &rays),
    ));
    contenders.push((
        "Bvh4 + single test".into(),
        wide_tracer(Bvh4::from_bvh(&bvh), &tris, &rays),
    ));

    let reference = "obvhs cwbvh medium";
    contenders.push((
        reference.into(),
        Box::new(|i| {
            let mut hit = obvhs::ray::RayHit::none();
            cw.ray_traverse(orays[i], &mut hit, |ray, id| leaf_tris[id].intersect(ray))
                .then_some(hit.t)
        }),
    ));
    contenders.retain(|(name, _)| name.contains(&only) || name == reference);

    // No comparison against wrong answers: every contender's closest t must equal obvhs'.
    let (_, obvhs_trace) = contenders.last().expect("obvhs is always run");
    for (name, trace) in &contenders {
        let mismatches = (0..2_000)
            .filter(|&i| match (trace(i), obvhs_trace(i)) {
                (Some(a), Some(b)) => (a - b).abs() > 1e-4 * a.max(1.0),
                (a, b) => a.is_some() != b.is_some(),
            })
            .count();
        assert_eq!(
            mismatches, 0,
            "{name} disagrees with obvhs on {mismatches} rays"
        );
    }

    let mut samples: Vec<Vec<f64>> = vec![Vec::new(); contenders.len()];
    for _ in 0..rounds {
        for ((_, trace), s) in contenders.iter().zip(&mut samples) {
            s.push(rays_per_second(trace));
        }
    }
    let reference_samples = samples.last().expect("obvhs is always run").clone();
    println!(
        "{RAYS} rays x {rounds} rounds; median rays/s and median per-round ratio to {reference}:"
    );
    for ((name, _), s) in contenders.iter().zip(&samples) {
        let ratio = median(
            s.iter()
                .zip(&reference_samples)
                .map(|(a, b)| a / b)
                .collect(),
        );
        println!(
            "  {name}: {:.1}k rays/s ({ratio:.2}x)",
            median(s.clone()) / 1e3
        );
    }
}
