//! The kd-tree (`accel::kdtree`), in one run:
//!
//! - **Build**: the event sweep (O(N log N)) and the sort-each-level build (O(N log^2 N)) on
//!   the benchmarks' triangle scene (bunny copies among large triangles) from 10k to 1M
//!   triangles, single-threaded, median of a few builds; each time also divided by
//!   `N log2 N`, which stays roughly flat for an O(N log N) build. Both builds must give the
//!   same tree (checked). Then each tree's size: nodes, leaves (empty ones too), references
//!   (triangles plus the copies straddling made), splits that straddled, depth, memory.
//! - **Rays**: closest-hit rays, random (origins uniform in the mesh's box grown by a half,
//!   directions uniform) and coherent (a pinhole camera's primary rays in scanline order),
//!   on the bunny and on the scene, against `MeshBvh::new` (our 16-wide BVH over pre-split
//!   triangles) and the `kdtree-ray` crate 1.2.2 (its `intersect` returns the candidate
//!   triangles of the leaves the ray crosses, unordered; the closest is found with our
//!   watertight test, as its docs intend). Before timing, ours and the BVH must agree on
//!   every ray's closest distance, to the bit; `kdtree-ray`'s disagreements are counted.
//!   Printed as rays per second and the ratios, then measured again by criterion.
//!
//! `--quick` (CI): builds up to 100k triangles, the scene at 100k for rays, fewer rays and
//! repetitions, and criterion's quick mode.
//!
//! Run: `CARGO_TARGET_DIR=/tmp/kd-target cargo bench -p accel --profile dev --bench kdtree
//! [-- --quick]`

use accel::kdtree::{KdBuild, KdTree, KdTreeConfig};
use accel::mesh::MeshBvh;
use accel::{Aabb, Backfaces, Ray, WatertightRay};
use accel_testkit::{Rng, triangle_scene};
use criterion::{Criterion, Throughput};
use glam::{Vec3, Vec3A};
use std::hint::black_box;
use std::time::Instant;

/// What the run measures; `--quick` shrinks it.
struct Settings {
    build_sizes: Vec<usize>,
    scene_size: usize,
    rays: usize,
    reps: usize,
}

fn settings() -> Settings {
    let quick = std::env::args().any(|a| a == "--quick");
    if quick {
        Settings {
            build_sizes: vec![10_000, 30_000, 100_000],
            scene_size: 100_000,
            rays: 5_000,
            reps: 3,
        }
    } else {
        Settings {
            build_sizes: vec![10_000, 30_000, 100_000, 300_000, 1_000_000],
            scene_size: 1_000_000,
            rays: 20_000,
            reps: 5,
        }
    }
}

/// A mesh as the trees take it.
struct TestMesh {
    vertices: Vec<Vec3>,
    indices: Vec<u32>,
}

fn scene(n: usize) -> TestMesh {
    let vertices: Vec<Vec3> = triangle_scene(n, 1)
        .iter()
        .flat_map(|t| t.vertices.map(Vec3::from))
        .collect();
    let indices = (0..vertices.len() as u32).collect();
    TestMesh { vertices, indices }
}

fn bunny() -> TestMesh {
    let m = accel_testkit::bunny();
    TestMesh {
        vertices: m.positions(),
        indices: m.flat_indices(),
    }
}

/// Median seconds of `reps` runs of `f`.
fn median_seconds<T>(reps: usize, mut f: impl FnMut() -> T) -> f64 {
    let mut times: Vec<f64> = (0..reps)
        .map(|_| {
            let start = Instant::now();
            black_box(f());
            start.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn build_kd(m: &TestMesh, build: KdBuild) -> KdTree {
    KdTree::with_config(&m.vertices, &m.indices, &KdTreeConfig::with_build(build)).unwrap()
}

fn builds(s: &Settings) {
    println!("\n## kd-tree builds (triangle scene, one thread)\n");
    println!(
        "| triangles | event sweep ms | ns / (N log2 N) | sort each level ms | ns / (N log2 N) | sort / sweep |"
    );
    println!("|---:|---:|---:|---:|---:|---:|");
    let mut sizes = Vec::new();
    for &n in &s.build_sizes {
        let m = scene(n);
        let reps = if n >= 300_000 { 1 } else { s.reps };
        let sweep = median_seconds(reps, || build_kd(&m, KdBuild::EventSweep));
        let sorted = median_seconds(reps, || build_kd(&m, KdBuild::SortEachLevel));
        let tree = build_kd(&m, KdBuild::EventSweep);
        assert_eq!(
            tree.nodes(),
            build_kd(&m, KdBuild::SortEachLevel).nodes(),
            "the builds disagree at {n}"
        );
        let nlogn = n as f64 * (n as f64).log2();
        println!(
            "| {n} | {:.1} | {:.2} | {:.1} | {:.2} | {:.2}x |",
            sweep * 1e3,
            sweep * 1e9 / nlogn,
            sorted * 1e3,
            sorted * 1e9 / nlogn,
            sorted / sweep
        );
        sizes.push((n, tree.stats(), tree.memory_bytes()));
    }
    println!("\n## kd-tree sizes (triangle scene)\n");
    println!(
        "| triangles | nodes | leaves | empty leaves | references | refs / tri | straddled | clipped away | depth | bytes / tri |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|");
    for (n, st, bytes) in sizes {
        println!(
            "| {n} | {} | {} | {} | {} | {:.3} | {} | {} | {} | {:.1} |",
            st.nodes,
            st.leaves,
            st.empty_leaves,
            st.references,
            st.references as f64 / n as f64,
            st.straddled,
            st.clipped_away,
            st.depth,
            bytes as f64 / n as f64
        );
    }
}

/// Random rays: origins uniform in `bounds` grown by half its size, unit directions.
fn random_rays(bounds: &Aabb, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed);
    let grown = bounds.expanded(bounds.extent() * 0.5);
    (0..n)
        .map(|_| {
            let o =
                grown.min + (grown.max - grown.min) * Vec3A::new(rng.f32(), rng.f32(), rng.f32());
            Ray::new(o, rng.unit_vector())
        })
        .collect()
}

/// A pinhole camera's primary rays, in scanline order, from outside the box towards its
/// centre (a 60 degree field of view that frames it).
fn coherent_rays(bounds: &Aabb, n: usize) -> Vec<Ray> {
    let side = (n as f64).sqrt().ceil() as usize;
    let center = bounds.center();
    let radius = bounds.extent().length() * 0.5;
    let eye = center + Vec3A::new(0.6, 0.35, 1.0).normalize() * radius * 2.2;
    let forward = (center - eye).normalize();
    let right = forward.cross(Vec3A::Y).normalize();
    let up = right.cross(forward);
    let half = (30.0f32).to_radians().tan();
    let mut rays = Vec::with_capacity(side * side);
    for y in 0..side {
        for x in 0..side {
            let u = ((x as f32 + 0.5) / side as f32 * 2.0 - 1.0) * half;
            let v = ((y as f32 + 0.5) / side as f32 * 2.0 - 1.0) * half;
            rays.push(Ray::new(eye, (forward + right * u + up * v).normalize()));
        }
    }
    rays.truncate(n);
    rays
}

/// A `kdtree-ray` shape: a triangle's box.
struct PeerTriangle(Aabb);

impl kdtree_ray::Bounded for PeerTriangle {
    fn bound(&self) -> kdtree_ray::AABB {
        let v = |p: Vec3A| cgmath::Vector3::new(p.x, p.y, p.z);
        kdtree_ray::AABB::new(v(self.0.min), v(self.0.max))
    }
}

/// A closest-hit tracer: ray to (triangle, t).
type Trace<'a> = Box<dyn Fn(&Ray) -> Option<(u32, f32)> + 'a>;

struct Contender<'a> {
    name: &'static str,
    build_seconds: f64,
    bytes: Option<usize>,
    trace: Trace<'a>,
}

fn contenders(m: &TestMesh) -> Vec<Contender<'_>> {
    let start = Instant::now();
    let kd = build_kd(m, KdBuild::EventSweep);
    let kd_build = start.elapsed().as_secs_f64();
    let start = Instant::now();
    let bvh = MeshBvh::new(&m.vertices, &m.indices).unwrap();
    let bvh_build = start.elapsed().as_secs_f64();
    let corners: Vec<[Vec3A; 3]> = m
        .indices
        .chunks_exact(3)
        .map(|t| [0, 1, 2].map(|k| Vec3A::from(m.vertices[t[k] as usize])))
        .collect();
    let shapes: Vec<PeerTriangle> = corners
        .iter()
        .map(|c| PeerTriangle(Aabb::from_points(*c)))
        .collect();
    let start = Instant::now();
    let peer = kdtree_ray::KDTree::build(&shapes);
    let peer_build = start.elapsed().as_secs_f64();
    vec![
        Contender {
            name: "accel KdTree",
            build_seconds: kd_build,
            bytes: Some(kd.memory_bytes()),
            trace: Box::new(move |r| {
                kd.cast_ray(r, Backfaces::Include)
                    .map(|h| (h.triangle, h.t))
            }),
        },
        Contender {
            name: "accel MeshBvh",
            build_seconds: bvh_build,
            bytes: Some(bvh.memory_bytes()),
            trace: Box::new(move |r| {
                bvh.cast_ray(r, Backfaces::Include)
                    .map(|h| (h.triangle, h.t))
            }),
        },
        Contender {
            name: "kdtree-ray 1.2.2 (+ watertight test)",
            build_seconds: peer_build,
            bytes: None,
            trace: Box::new(move |r| {
                let v = |p: Vec3A| cgmath::Vector3::new(p.x, p.y, p.z);
                let wt = WatertightRay::new(r);
                let mut best: Option<(u32, f32)> = None;
                for t in peer.intersect(&v(r.origin), &v(r.direction)) {
                    let [a, b, c] = corners[t];
                    if let Some(h) = wt.intersect_vertices(a, b, c, Backfaces::Include)
                        && best.is_none_or(|(_, bt)| h.t < bt)
                    {
                        best = Some((t as u32, h.t));
                    }
                }
                best
            }),
        },
    ]
}

fn rays(c: &mut Criterion, s: &Settings) {
    let meshes = [
        ("bunny".to_string(), bunny()),
        (format!("scene {}", s.scene_size), scene(s.scene_size)),
    ];
    let mut table = Vec::new();
    for (mesh_name, m) in &meshes {
        let bounds = Aabb::from_points(m.vertices.iter().copied());
        let cons = contenders(m);
        println!("\n## {mesh_name}: {} triangles\n", m.indices.len() / 3);
        println!("| contender | build ms | bytes / tri |\n|---|---:|---:|");
        for con in &cons {
            println!(
                "| {} | {:.1} | {} |",
                con.name,
                con.build_seconds * 1e3,
                con.bytes.map_or("n/a".into(), |b| format!(
                    "{:.1}",
                    b as f64 / (m.indices.len() / 3) as f64
                ))
            );
        }
        for (kind, rays) in [
            ("random", random_rays(&bounds, s.rays, 3)),
            ("coherent", coherent_rays(&bounds, s.rays)),
        ] {
            let want: Vec<_> = rays.iter().map(|r| (cons[0].trace)(r)).collect();
            let hits = want.iter().filter(|h| h.is_some()).count();
            let bits = |h: &Option<(u32, f32)>| h.map(|(_, t)| t.to_bits());
            for con in &cons[1..] {
                let differ = rays
                    .iter()
                    .zip(&want)
                    .filter(|(r, w)| bits(&(con.trace)(r)) != bits(w))
                    .count();
                println!(
                    "{mesh_name}, {kind} rays: {} disagrees with the kd-tree on {differ} of {} rays ({hits} hit)",
                    con.name,
                    rays.len()
                );
                if con.name == "accel MeshBvh" {
                    assert_eq!(differ, 0, "MeshBvh and the kd-tree must agree to the bit");
                }
            }
            let per_second: Vec<f64> = cons
                .iter()
                .map(|con| {
                    let secs = median_seconds(s.reps, || {
                        rays.iter().filter(|r| (con.trace)(r).is_some()).count()
                    });
                    rays.len() as f64 / secs
                })
                .collect();
            table.push((mesh_name.clone(), kind, per_second));
            let mut g = c.benchmark_group(format!("kdtree_rays/{mesh_name}/{kind}"));
            g.throughput(Throughput::Elements(rays.len() as u64));
            g.sample_size(10);
            for con in &cons {
                g.bench_function(con.name, |b| {
                    b.iter(|| rays.iter().filter(|r| (con.trace)(r).is_some()).count())
                });
            }
            g.finish();
        }
    }
    println!("\n## closest-hit rays, million rays per second (one thread)\n");
    println!(
        "| mesh | rays | KdTree | MeshBvh | kdtree-ray | KdTree / MeshBvh | KdTree / kdtree-ray |"
    );
    println!("|---|---|---:|---:|---:|---:|---:|");
    for (mesh, kind, r) in table {
        println!(
            "| {mesh} | {kind} | {:.3} | {:.3} | {:.3} | {:.2}x | {:.2}x |",
            r[0] / 1e6,
            r[1] / 1e6,
            r[2] / 1e6,
            r[0] / r[1],
            r[0] / r[2]
        );
    }
}

fn build_benches(c: &mut Criterion) {
    let m = scene(10_000);
    let mut g = c.benchmark_group("kdtree_build_10k");
    g.sample_size(10);
    for (name, build) in [
        ("event_sweep", KdBuild::EventSweep),
        ("sort_each_level", KdBuild::SortEachLevel),
    ] {
        g.bench_function(name, |b| b.iter(|| build_kd(&m, build)));
    }
    g.finish();
}

fn main() {
    let s = settings();
    let mut c = Criterion::default().configure_from_args();
    builds(&s);
    build_benches(&mut c);
    rays(&mut c, &s);
    c.final_summary();
}
