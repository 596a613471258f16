//! Rays per second on the benchmark's 1M-triangle bunny scene (the scene of
//! `benches/bvh_rays.rs`), ours against obvhs 0.3.3's CWBVH, interleaved round by round in one
//! process, for four kinds of rays, 20,000 of each:
//!
//! - primary: closest hit, a pinhole camera's 141 x 141 pixel grid in scanline order, from
//!   outside the scene cube towards its centre (coherent);
//! - shadow: any hit, from each primary hit point (moved back 1e-3 along the primary ray)
//!   towards a point light above the scene, limited to the light's distance;
//! - diffuse: closest hit, one bounce from each primary hit (moved off the surface by 1e-3
//!   along its normal), in a cosine-weighted direction about the normal on the side the
//!   primary ray came from (the secondary rays of a path tracer: tinybvh's "diffuse");
//! - incoherent: closest hit, origins uniform in the scene cube, directions uniform on the
//!   sphere (the rays of `benches/bvh_rays.rs`).
//!
//! `cargo run --release -p accel --example ray_timing [rounds] [only]`
//!
//! Contenders: `MeshBvh` (`MeshBvh::new`: 16-wide, over pre-split triangles, leaf triangles
//! in 4-wide packets), `MeshBvh(whole)` (the same build over whole triangles) and obvhs CWBVH
//! (medium preset, its Möller-Trumbore test, triangles in leaf order) on every kind; on incoherent
//! rays also the 8-wide, quantized 8-wide and 4-wide `WideBvh` over the triangle boxes with the
//! single watertight test in the callback. `only` keeps the contenders whose name contains it.
//! The environment variable `MESH_CONFIGS` (comma-separated `leaf:traversal:intersection`
//! SAH settings, `ploc` / `ploc-fastest`, or `split=B`: the default build over triangles
//! pre-split with budget `B`; `sbvh` or `sbvh=budget:bins:overlap:traversal`: the spatial-split build,
//! `MeshBvh::with_spatial_splits`) adds `MeshBvh`s built other ways.
//!
//! `InstancedScene` and `InstancedScene(sbvh)` trace the same triangles as a two-level scene:
//! one bunny mesh BVH (`MeshBvh::new`, or the spatial-split build) under each copy's transform,
//! and the large triangles as one more mesh in place, or, with `LOOSE_CELLS=n`, as one mesh
//! per cell of an n x n x n grid over the scene (instances whose boxes overlap).
//!
//! tinybvh (C++) joins every round when `TINYBVH_PEER` names the binary that
//! `benches/peers/tinybvh.sh` builds, traced in the layouts `TINYBVH_LAYOUTS` lists
//! (comma-separated; `bvh8_cpu` unless set; also `bvh4_cpu`, `bvh8_cpu_hq`):
//! `TINYBVH_PEER=$(crates/accel/benches/peers/tinybvh.sh) cargo run --release -p accel
//! --example ray_timing`.
//!
//! The machine is shared: each round runs every contender once, and the summary is the median
//! over rounds of each contender's ratio to obvhs *in the same round*.

#[path = "../benches/common/mod.rs"]
mod common;

use accel::bvh::wide::{Bvh4, Bvh8, QBvh8};
use accel::mesh::{Instance, InstancedScene, MeshBvh, SpatialSplits};
use accel::{
    Aabb, Backfaces, BuildConfig, Bvh, Ray, SahCosts, SpatialQuery, SplitStrategy, Triangle,
    WatertightRay,
};
use accel_testkit::{InstancedTriangles, TRI_EXTENT, instanced_triangle_scene};
use glam::{Affine3A, Vec3A};
use obvhs::BvhBuildParams;
use std::sync::Arc;
use std::time::{Duration, Instant};

const RAYS: usize = 20_000;

/// One kind of ray, in both crates' types.
struct RaySet {
    name: &'static str,
    ours: Vec<Ray>,
    theirs: Vec<obvhs::ray::Ray>,
    /// Any hit (shadow rays) instead of the closest.
    any_hit: bool,
}

impl RaySet {
    fn new(name: &'static str, rays: &[(Vec3A, Vec3A, f32)], any_hit: bool) -> Self {
        Self {
            name,
            ours: rays
                .iter()
                .map(|&(o, d, t_max)| {
                    let mut r = Ray::new(o, d);
                    r.t_max = t_max;
                    r
                })
                .collect(),
            theirs: rays
                .iter()
                .map(|&(o, d, t_max)| obvhs::ray::Ray::new(o, d, 0.0, t_max))
                .collect(),
            any_hit,
        }
    }
}

/// Traces ray `i` of a set: the closest `t`, or for any-hit sets `Some(0.0)` when blocked.
type Tracer<'a> = Box<dyn Fn(&RaySet, usize) -> Option<f32> + 'a>;

fn rays_per_second(trace: &Tracer<'_>, set: &RaySet) -> f64 {
    let start = Instant::now();
    let hits = (0..set.ours.len())
        .filter(|&i| trace(set, i).is_some())
        .count();
    std::hint::black_box(hits);
    set.ours.len() as f64 / start.elapsed().as_secs_f64()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// A pinhole camera's pixel grid in scanline order, looking at the scene's centre from outside.
fn primary_rays() -> Vec<(Vec3A, Vec3A, f32)> {
    let side = (RAYS as f64).sqrt().ceil() as usize;
    let eye = Vec3A::new(0.0, 0.5, 2.5) * TRI_EXTENT;
    let forward = (-eye).normalize();
    let right = forward.cross(Vec3A::Y).normalize();
    let up = right.cross(forward);
    let half = (30f32).to_radians().tan();
    (0..RAYS)
        .map(|i| {
            let (x, y) = ((i % side) as f32, (i / side) as f32);
            let sx = (2.0 * (x + 0.5) / side as f32 - 1.0) * half;
            let sy = (1.0 - 2.0 * (y + 0.5) / side as f32) * half;
            (
                eye,
                (forward + right * sx + up * sy).normalize(),
                f32::INFINITY,
            )
        })
        .collect()
}

/// From each primary hit (moved back along the primary ray), towards a point light above.
fn shadow_rays(primary: &[(Vec3A, Vec3A, f32)], mesh: &MeshBvh) -> Vec<(Vec3A, Vec3A, f32)> {
    let light = Vec3A::new(0.3, 4.0, 0.2) * TRI_EXTENT;
    let points: Vec<Vec3A> = primary
        .iter()
        .filter_map(|&(o, d, _)| {
            let hit = mesh.cast_ray(&Ray::new(o, d), Backfaces::Include)?;
            Some(o + d * (hit.t - 1e-3))
        })
        .collect();
    (0..RAYS)
        .map(|i| {
            let p = points[i % points.len()];
            let to_light = light - p;
            (p, to_light.normalize(), to_light.length())
        })
        .collect()
}

/// One bounce from each primary hit: a cosine-weighted direction about the surface normal,
/// on the side the primary ray came from (Malley's method: uniform on the disc, lifted to the
/// hemisphere). Primary rays that miss are skipped; the hits are cycled to make `RAYS` rays.
fn diffuse_rays(primary: &[(Vec3A, Vec3A, f32)], mesh: &MeshBvh) -> Vec<(Vec3A, Vec3A, f32)> {
    let surfaces: Vec<(Vec3A, Vec3A)> = primary
        .iter()
        .filter_map(|&(o, d, _)| {
            let hit = mesh.cast_ray(&Ray::new(o, d), Backfaces::Include)?;
            let n = hit.geometric_normal;
            let n = if n.dot(d) > 0.0 { -n } else { n };
            Some((o + d * hit.t + n * 1e-3, n))
        })
        .collect();
    let mut rng = accel_testkit::Rng::new(0x2545_f491_4f6c_dd1d);
    let mut uniform = move || rng.f32();
    (0..RAYS)
        .map(|i| {
            let (p, n) = surfaces[i % surfaces.len()];
            let tangent = if n.x.abs() > 0.9 { Vec3A::Y } else { Vec3A::X }
                .cross(n)
                .normalize();
            let bitangent = n.cross(tangent);
            let (r, phi) = (uniform().sqrt(), std::f32::consts::TAU * uniform());
            let lift = (1.0 - r * r).max(0.0).sqrt();
            let d = tangent * (r * phi.cos()) + bitangent * (r * phi.sin()) + n * lift;
            (p, d.normalize(), f32::INFINITY)
        })
        .collect()
}

/// A `WideBvh` over the triangle boxes, tracing with the single watertight test.
fn wide_tracer<'a, T: SpatialQuery + 'a>(tree: T, tris: &'a [Triangle]) -> Tracer<'a> {
    Box::new(move |set, i| {
        let ray = &set.ours[i];
        let wt = WatertightRay::new(ray);
        tree.cast_ray(ray, |p, _| {
            wt.intersect(&tris[p as usize], Backfaces::Include)
                .map(|h| h.t)
        })
        .map(|h| h.t)
    })
}

fn mesh_tracer<'a>(mesh: MeshBvh) -> Tracer<'a> {
    Box::new(move |set, i| {
        if set.any_hit {
            mesh.cast_ray_any(&set.ours[i], Backfaces::Include)
                .then_some(0.0)
        } else {
            mesh.cast_ray(&set.ours[i], Backfaces::Include).map(|h| h.t)
        }
    })
}

/// Triangles as a mesh: three vertices each, indexed in order.
fn triangle_list(tris: &[Triangle]) -> (Vec<glam::Vec3>, Vec<u32>) {
    let vertices: Vec<glam::Vec3> = tris
        .iter()
        .flat_map(|t| t.vertices.map(glam::Vec3::from))
        .collect();
    let indices = (0..vertices.len() as u32).collect();
    (vertices, indices)
}

/// The scene as two levels: one bunny mesh BVH under every copy's transform, and the large
/// triangles as one more mesh in place; each mesh built by `MeshBvh::new`, or with spatial
/// splits when `splits` is given.
fn instanced_scene(parts: &InstancedTriangles, splits: Option<&SpatialSplits>) -> InstancedScene {
    let build = |tris: &[Triangle]| {
        let (vertices, indices) = triangle_list(tris);
        Arc::new(
            match splits {
                Some(s) => {
                    MeshBvh::with_spatial_splits(&vertices, &indices, &BuildConfig::default(), s)
                }
                None => MeshBvh::new(&vertices, &indices),
            }
            .expect("a triangle list"),
        )
    };
    let bunny = build(&parts.mesh);
    let mut instances: Vec<Instance> = parts
        .placements
        .iter()
        .map(|m| Instance {
            mesh: bunny.clone(),
            world_from_local: Affine3A::from_mat4(*m),
        })
        .collect();
    // The large triangles as one mesh, or split by a grid of `cells` a side over the scene
    // cube (`LOOSE_CELLS`): instances whose boxes overlap.
    let cells = loose_cells();
    let mut groups: Vec<Vec<Triangle>> = vec![Vec::new(); cells * cells * cells];
    for t in &parts.loose {
        let cell = ((t.aabb().center() / TRI_EXTENT * 0.5 + 0.5) * cells as f32)
            .as_uvec3()
            .min(glam::UVec3::splat(cells as u32 - 1));
        groups[(cell.x as usize * cells + cell.y as usize) * cells + cell.z as usize].push(*t);
    }
    let started = Instant::now();
    let loose_meshes: Vec<Arc<MeshBvh>> = groups
        .iter()
        .filter(|g| !g.is_empty())
        .map(|g| build(g))
        .collect();
    if let [mesh] = loose_meshes.as_slice() {
        let name = if splits.is_some() {
            "InstancedScene(sbvh)"
        } else {
            "InstancedScene"
        };
        report_build(
            &format!("{name}, the large triangles' mesh"),
            mesh,
            started.elapsed().as_secs_f64(),
            parts.loose.len(),
        );
    }
    instances.extend(loose_meshes.into_iter().map(|mesh| Instance {
        mesh,
        world_from_local: Affine3A::IDENTITY,
    }));
    InstancedScene::new(instances)
}

/// Cells a side of the grid that splits the large triangles into instances: `LOOSE_CELLS`,
/// 1 (one mesh) unless set.
fn loose_cells() -> usize {
    std::env::var("LOOSE_CELLS")
        .ok()
        .and_then(|v| v.parse().ok())
        .map_or(1, |c: usize| c.max(1))
}

fn scene_tracer<'a>(scene: InstancedScene) -> Tracer<'a> {
    Box::new(move |set, i| {
        if set.any_hit {
            scene
                .cast_ray_any(&set.ours[i], Backfaces::Include)
                .then_some(0.0)
        } else {
            scene
                .cast_ray(&set.ours[i], Backfaces::Include)
                .map(|h| h.hit.t)
        }
    })
}

/// How many rays of each set every contender's answers are checked on.
const CHECKED_RAYS: usize = 2_000;

/// No timing of wrong answers: `answer(i)` must agree with obvhs on the first rays of `set`
/// (the closest `t` within 1e-4 relative, or blocked / not blocked). Möller-Trumbore and the
/// watertight test may disagree on a ray through a shared edge, so up to two differences are
/// allowed, and printed.
fn check_against_obvhs(
    name: &str,
    set: &RaySet,
    answer: impl Fn(usize) -> Option<f32>,
    obvhs: &Tracer<'_>,
) {
    let mismatches = (0..CHECKED_RAYS)
        .filter(|&i| match (answer(i), obvhs(set, i)) {
            (Some(a), Some(b)) => (a - b).abs() > 1e-4 * a.max(1.0),
            (a, b) => a.is_some() != b.is_some(),
        })
        .count();
    assert!(
        mismatches <= 2,
        "{name} disagrees with obvhs on {mismatches} of {CHECKED_RAYS} {} rays",
        set.name
    );
    if mismatches > 0 {
        println!(
            "  ({name}: {mismatches} of {CHECKED_RAYS} {} rays differ from obvhs)",
            set.name
        );
    }
}

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(11);
    let only = std::env::args().nth(2).unwrap_or_default();
    let parts = instanced_triangle_scene(1_000_000, 2);
    let tris = parts.flatten();
    let boxes: Vec<Aabb> = tris.iter().map(Triangle::aabb).collect();
    let (vertices, indices) = triangle_list(&tris);
    let started = Instant::now();
    let mesh = MeshBvh::new(&vertices, &indices).expect("a triangle list");
    let split_build = started.elapsed().as_secs_f64();
    let started = Instant::now();
    let whole = MeshBvh::with_config(&vertices, &indices, &MeshBvh::default_config(tris.len()))
        .expect("a triangle list");
    let whole_build = started.elapsed().as_secs_f64();
    for (name, m, seconds) in [
        ("MeshBvh", &mesh, split_build),
        ("MeshBvh(whole)", &whole, whole_build),
    ] {
        report_build(name, m, seconds, tris.len());
    }
    let primary = primary_rays();
    let shadow = shadow_rays(&primary, &mesh);
    let diffuse = diffuse_rays(&primary, &mesh);
    let incoherent: Vec<_> = common::incoherent_rays(RAYS, TRI_EXTENT, 3)
        .into_iter()
        .map(|(o, d)| (o, d, f32::INFINITY))
        .collect();
    let kinds = [
        ("primary", &primary, false),
        ("shadow", &shadow, true),
        ("diffuse", &diffuse, false),
        ("incoherent", &incoherent, false),
    ];
    let sets = kinds.map(|(name, rays, any_hit)| RaySet::new(name, rays, any_hit));
    // tinybvh in a child process, when `TINYBVH_PEER` names it (see `benches/peers/tinybvh.sh`).
    let mut tinybvh = common::tinybvh::TinyBvh::from_env(&tris);
    let layouts: Vec<String> = std::env::var("TINYBVH_LAYOUTS")
        .unwrap_or_else(|_| "bvh8_cpu".into())
        .split_terminator(',')
        .map(str::to_owned)
        .collect();
    let peer_sets: Vec<_> = match &mut tinybvh {
        Some(peer) => {
            for layout in &layouts {
                let seconds = peer.layout(layout);
                println!("{} {layout}: built in {seconds:.2} s", peer.version);
            }
            kinds
                .iter()
                .map(|&(name, rays, any_hit)| peer.rays(name, rays, any_hit))
                .collect()
        }
        None => Vec::new(),
    };

    let ot: Vec<obvhs::triangle::Triangle> = tris.iter().map(common::peers::to_obvhs_tri).collect();
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
    // (name, tracer, incoherent rays only)
    let mut contenders: Vec<(String, Tracer, bool)> = vec![
        ("MeshBvh".into(), mesh_tracer(mesh), false),
        ("MeshBvh(whole)".into(), mesh_tracer(whole), false),
    ];
    for c in std::env::var("MESH_CONFIGS")
        .unwrap_or_default()
        .split_terminator(',')
    {
        if let Some(params) = c.strip_prefix("sbvh") {
            // `sbvh` or `sbvh=budget:bins:overlap_threshold:traversal_cost`.
            let mut splits = SpatialSplits::default();
            if let Some(params) = params.strip_prefix('=') {
                let p: Vec<f32> = params
                    .split(':')
                    .map(|x| x.parse().expect("a number"))
                    .collect();
                splits.reference_budget = p[0];
                splits.bins = p.get(1).map_or(splits.bins, |&b| b as u32);
                splits.overlap_threshold = p.get(2).copied().unwrap_or(splits.overlap_threshold);
            }
            let started = Instant::now();
            let mut config = BuildConfig::default();
            if let Some(traversal) = params.split(':').nth(3) {
                config.sah.traversal = traversal.parse().expect("a traversal cost");
            }
            let mesh = MeshBvh::with_spatial_splits(&vertices, &indices, &config, &splits)
                .expect("a triangle list");
            let name = format!("MeshBvh({c})");
            report_build(&name, &mesh, started.elapsed().as_secs_f64(), tris.len());
            contenders.push((name, mesh_tracer(mesh), false));
            continue;
        }
        if let Some(budget) = c.strip_prefix("split=") {
            let budget: f32 = budget.parse().expect("a split budget");
            let config = MeshBvh::default_config(tris.len());
            let mesh = MeshBvh::with_splits(&vertices, &indices, &config, budget)
                .expect("a triangle list");
            contenders.push((format!("MeshBvh({c})"), mesh_tracer(mesh), false));
            continue;
        }
        let config = match c {
            "ploc" => BuildConfig::with_split(SplitStrategy::PLOC),
            "ploc-fastest" => BuildConfig::with_split(SplitStrategy::PLOC_FASTEST),
            _ => {
                let p: Vec<f32> = c.split(':').map(|x| x.parse().expect("a number")).collect();
                BuildConfig {
                    max_leaf_size: p[0] as u32,
                    sah: SahCosts {
                        traversal: p[1],
                        intersection: p[2],
                    },
                    ..BuildConfig::default()
                }
            }
        };
        let mesh = MeshBvh::with_config(&vertices, &indices, &config).expect("a triangle list");
        contenders.push((format!("MeshBvh({c})"), mesh_tracer(mesh), false));
    }
    for (name, splits) in [
        ("InstancedScene", None),
        ("InstancedScene(sbvh)", Some(SpatialSplits::default())),
    ] {
        let scene = instanced_scene(&parts, splits.as_ref());
        contenders.push((name.into(), scene_tracer(scene), false));
    }
    let bvh = Bvh::build(&boxes, &BuildConfig::default());
    contenders.push((
        "Bvh8 + single test".into(),
        wide_tracer(Bvh8::from_bvh(&bvh), &tris),
        true,
    ));
    contenders.push((
        "QBvh8 + single test".into(),
        wide_tracer(QBvh8::from_bvh(&bvh), &tris),
        true,
    ));
    contenders.push((
        "Bvh4 + single test".into(),
        wide_tracer(Bvh4::from_bvh(&bvh), &tris),
        true,
    ));
    let reference = "obvhs cwbvh medium";
    contenders.push((
        reference.into(),
        Box::new(|set, i| {
            let ray = set.theirs[i];
            let test = |ray: &obvhs::ray::Ray, id: usize| leaf_tris[id].intersect(ray);
            if set.any_hit {
                (!cw.ray_traverse_miss(ray, test)).then_some(0.0)
            } else {
                let mut hit = obvhs::ray::RayHit::none();
                cw.ray_traverse(ray, &mut hit, test).then_some(hit.t)
            }
        }),
        false,
    ));
    contenders.retain(|(name, _, _)| name.contains(&only) || name == reference);

    for (k, set) in sets.iter().enumerate() {
        let runs: Vec<&(String, Tracer, bool)> = contenders
            .iter()
            .filter(|c| !c.2 || set.name == "incoherent")
            .collect();
        let obvhs_trace = &runs.last().expect("obvhs is always run").1;
        for (name, trace, _) in &runs {
            check_against_obvhs(name, set, |i| trace(set, i), obvhs_trace);
        }
        if let Some(peer) = &mut tinybvh {
            for layout in &layouts {
                let theirs = peer.hits(peer_sets[k], CHECKED_RAYS, layout);
                check_against_obvhs(
                    &format!("tinybvh {layout}"),
                    set,
                    |i| theirs[i],
                    obvhs_trace,
                );
            }
        }
        let mut samples: Vec<Vec<f64>> = vec![Vec::new(); runs.len()];
        let mut peer_samples: Vec<Vec<f64>> = vec![Vec::new(); layouts.len()];
        for _ in 0..rounds {
            for ((_, trace, _), s) in runs.iter().zip(&mut samples) {
                s.push(rays_per_second(trace, set));
            }
            if let Some(peer) = &mut tinybvh {
                for (layout, s) in layouts.iter().zip(&mut peer_samples) {
                    s.push(peer.trace(peer_sets[k], layout));
                }
            }
        }
        let reference_samples = samples.last().expect("obvhs is always run").clone();
        let hits = (0..set.ours.len())
            .filter(|&i| obvhs_trace(set, i).is_some())
            .count();
        println!(
            "{} rays ({RAYS}, {:.1}% hit), {rounds} rounds; median rays/s and median per-round ratio to {reference}:",
            set.name,
            100.0 * hits as f64 / RAYS as f64
        );
        let peer_rows = tinybvh.as_ref().map_or(Vec::new(), |peer| {
            layouts
                .iter()
                .map(|l| format!("{} {l}", peer.version))
                .collect()
        });
        let rows = runs
            .iter()
            .map(|(name, _, _)| name.clone())
            .chain(peer_rows)
            .zip(samples.iter().chain(&peer_samples));
        for (name, s) in rows {
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
}

/// Prints how long a mesh BVH took to build, its memory per triangle, and how many triangles
/// its leaves hold (more than the mesh has where pieces of one triangle reached several).
fn report_build(name: &str, mesh: &MeshBvh, seconds: f64, triangles: usize) {
    println!(
        "{name}: built in {seconds:.2} s, {:.1} bytes/triangle, {} triangles in leaves",
        mesh.memory_bytes() as f64 / triangles as f64,
        mesh.leaf_triangle_count()
    );
}
