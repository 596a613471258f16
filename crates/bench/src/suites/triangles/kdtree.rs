//! The kd-tree (`spatial_accel::kdtree`):
//!
//! - builds: the event sweep (O(N log N)) and the sort-each-level build (O(N log^2 N)) on
//!   the benchmarks' triangle scene (bunny copies among large triangles) from 10k to 1M
//!   triangles (10k and 30k at `--quick`), one thread, the median of a few builds (one
//!   build from 300k on); each time also divided by `N log2 N`, which stays roughly flat for
//!   an O(N log N) build. The two builds must give the same tree, and the O(N^2) reference
//!   build too on the first 700 triangles of the bunny (stress rows). Then each tree's size:
//!   nodes, leaves, references, straddling splits, depth, memory;
//! - rays: closest-hit rays, random (origins uniform in the mesh's box grown by a half,
//!   directions uniform) and coherent (a pinhole camera's primary rays in scanline order),
//!   on the bunny and on the largest build's scene, against `MeshBvh::new` (our 16-wide BVH
//!   over pre-split triangles) and the `kdtree-ray` crate 1.2.2 (its `intersect` returns the
//!   candidate triangles of the leaves the ray crosses, unordered; the closest is found with
//!   our watertight test, as its docs intend). Every ray's closest distance must be the same
//!   to the bit on all three (stress rows), then each is timed, the best of a few passes.
//!
//! The plots: build time against ray time and against memory per triangle, one point per
//! contender, per mesh and kind of ray.

use super::TestMesh;
use crate::json::{Report, StressRow};
use crate::progress::Progress;
use crate::suites::point;
use crate::timing::{best_of, median};
use accel_testkit::Rng;
use glam::{Vec3, Vec3A};
use spatial_accel::kdtree::{KdBuild, KdTree, KdTreeConfig, KdTreeStats};
use spatial_accel::mesh::MeshBvh;
use spatial_accel::{Aabb, Backfaces, Ray, WatertightRay};
use std::time::Instant;

/// What this part measures; `--quick` shrinks it.
pub struct Settings {
    build_sizes: Vec<usize>,
    rays: usize,
    reps: usize,
}

impl Settings {
    /// The full run's settings, or the quick run's.
    pub fn new(quick: bool) -> Self {
        if quick {
            Self {
                build_sizes: vec![10_000, 30_000],
                rays: 2_000,
                reps: 1,
            }
        } else {
            Self {
                build_sizes: vec![10_000, 30_000, 100_000, 300_000, 1_000_000],
                rays: 20_000,
                reps: 3,
            }
        }
    }

    /// Progress steps: one per build size, one per ray mesh.
    pub fn steps(&self) -> usize {
        self.build_sizes.len() + 2
    }
}

/// The triangle scene of `n` triangles, unshared corners.
fn scene(n: usize) -> TestMesh {
    let vertices: Vec<Vec3> = accel_testkit::triangle_scene(n, 1)
        .iter()
        .flat_map(|t| t.vertices.map(Vec3::from))
        .collect();
    let indices = (0..vertices.len() as u32).collect();
    TestMesh { vertices, indices }
}

fn build_kd(m: &TestMesh, build: KdBuild) -> KdTree {
    KdTree::with_config(&m.vertices, &m.indices, &KdTreeConfig::with_build(build))
        .expect("a triangle list")
}

/// The median seconds of `reps` builds, and the last tree.
fn timed_build(reps: usize, mut build: impl FnMut() -> KdTree) -> (f64, KdTree) {
    let mut times = Vec::new();
    let mut tree = None;
    for _ in 0..reps.max(1) {
        let t = Instant::now();
        tree = Some(build());
        times.push(t.elapsed().as_secs_f64());
    }
    (median(times), tree.expect("at least one build"))
}

/// Whether two trees are the same: splits, leaves and statistics.
fn same_tree(a: &KdTree, b: &KdTree) -> bool {
    a.nodes() == b.nodes() && a.leaf_references() == b.leaf_references() && a.stats() == b.stats()
}

/// A stress row for one comparison of two builds.
fn same_tree_row(what: &str, same: bool) -> StressRow {
    StressRow {
        structure: "KdTree".into(),
        query: what.to_string(),
        cases: 1,
        misses: u64::from(!same),
        ..StressRow::default()
    }
}

/// The O(N^2) build, small enough to run, against the two fast ones.
fn naive_check(report: &mut Report) {
    let mut part = accel_testkit::bunny();
    part.indices.truncate(700);
    let m = TestMesh {
        vertices: part.positions(),
        indices: part.flat_indices(),
    };
    let sweep = build_kd(&m, KdBuild::EventSweep);
    for (name, build) in [
        ("naive", KdBuild::Naive),
        ("sort each level", KdBuild::SortEachLevel),
    ] {
        report.stress.push(same_tree_row(
            &format!("{name} build = event sweep, bunny's first 700 triangles"),
            same_tree(&sweep, &build_kd(&m, build)),
        ));
    }
}

/// The builds' table and the size table; returns the largest scene and its sweep tree with
/// the tree's build time.
fn builds(s: &Settings, report: &mut Report, progress: &mut Progress) -> (TestMesh, KdTree, f64) {
    let mut build_rows = vec![
        "| triangles | event sweep ms | ns / (N log2 N) | sort each level ms | ns / (N log2 N) | \
         sort / sweep |"
            .to_string(),
        "|---:|---:|---:|---:|---:|---:|".into(),
    ];
    let mut size_rows = vec![
        "| triangles | nodes | leaves | empty leaves | references | refs / tri | straddled | \
         clipped away | depth | bytes / tri |"
            .to_string(),
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|".into(),
    ];
    let mut last = None;
    for &n in &s.build_sizes {
        progress.step(&format!("kd-tree builds at {n}"));
        let m = scene(n);
        let reps = if n >= 300_000 { 1 } else { s.reps };
        let (sweep_s, sweep) = timed_build(reps, || build_kd(&m, KdBuild::EventSweep));
        let (sorted_s, sorted) = timed_build(reps, || build_kd(&m, KdBuild::SortEachLevel));
        report.stress.push(same_tree_row(
            &format!("sort each level build = event sweep, {n} triangles"),
            same_tree(&sweep, &sorted),
        ));
        drop(sorted);
        let nlogn = n as f64 * (n as f64).log2();
        build_rows.push(format!(
            "| {n} | {:.1} | {:.0} | {:.1} | {:.0} | {:.2}x |",
            sweep_s * 1e3,
            sweep_s * 1e9 / nlogn,
            sorted_s * 1e3,
            sorted_s * 1e9 / nlogn,
            sorted_s / sweep_s
        ));
        let st: KdTreeStats = sweep.stats();
        size_rows.push(format!(
            "| {n} | {} | {} | {} | {} | {:.3} | {} | {} | {} | {:.1} |",
            st.nodes,
            st.leaves,
            st.empty_leaves,
            st.references,
            st.references as f64 / n as f64,
            st.straddled,
            st.clipped_away,
            st.depth,
            sweep.memory_bytes() as f64 / n as f64
        ));
        last = Some((m, sweep, sweep_s));
    }
    report.markdown.extend([
        "kd-tree builds (triangle scene, one thread):".into(),
        String::new(),
    ]);
    report.markdown.extend(build_rows);
    report.markdown.extend([
        String::new(),
        "kd-tree sizes (event sweep):".into(),
        String::new(),
    ]);
    report.markdown.extend(size_rows);
    report.markdown.push(String::new());
    last.expect("at least one build size")
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
    let center = bounds.center();
    let radius = bounds.extent().length() * 0.5;
    let eye = center + Vec3A::new(0.6, 0.35, 1.0).normalize() * radius * 2.2;
    (crate::suites::camera_rays(n, eye - center).into_iter())
        .map(|r| Ray::new(r.origin + center, r.direction))
        .collect()
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

/// One contender on one mesh.
struct Contender<'a> {
    name: &'static str,
    build_seconds: f64,
    bytes: Option<usize>,
    trace: Trace<'a>,
}

/// The three contenders on `m`: the kd-tree `kd` (built in `kd_seconds`), the mesh BVH and
/// the peer, the last two built here.
fn contenders(m: &TestMesh, kd: KdTree, kd_seconds: f64) -> Vec<Contender<'_>> {
    let (bvh_build, bvh) = best_of(1, || {
        MeshBvh::new(&m.vertices, &m.indices).expect("a triangle list")
    });
    let corners: Vec<[Vec3A; 3]> = (m.indices.chunks_exact(3))
        .map(|t| [0, 1, 2].map(|k| Vec3A::from(m.vertices[t[k] as usize])))
        .collect();
    let shapes: Vec<PeerTriangle> = (corners.iter())
        .map(|c| PeerTriangle(Aabb::from_points(*c)))
        .collect();
    let (peer_build, peer) = best_of(1, || kdtree_ray::KDTree::build(&shapes));
    vec![
        Contender {
            name: "KdTree",
            build_seconds: kd_seconds,
            bytes: Some(kd.memory_bytes()),
            trace: Box::new(move |r| {
                (kd.cast_ray(r, Backfaces::Include)).map(|h| (h.triangle, h.t))
            }),
        },
        Contender {
            name: "MeshBvh",
            build_seconds: bvh_build,
            bytes: Some(bvh.memory_bytes()),
            trace: Box::new(move |r| {
                (bvh.cast_ray(r, Backfaces::Include)).map(|h| (h.triangle, h.t))
            }),
        },
        Contender {
            name: "kdtree-ray 1.2.2",
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

/// Rays per second of each contender on both kinds of ray through `m`, after checking they
/// agree; adds the build table's rows, the stress rows and the points.
fn rays_on(
    (mesh_name, m): (&str, &TestMesh),
    cons: &[Contender<'_>],
    s: &Settings,
    report: &mut Report,
    build_rows: &mut Vec<String>,
) -> Vec<(String, &'static str, Vec<f64>)> {
    let triangles = m.indices.len() / 3;
    for con in cons {
        build_rows.push(format!(
            "| {mesh_name} | {} | {:.1} | {} |",
            con.name,
            con.build_seconds * 1e3,
            con.bytes.map_or("n/a".into(), |b| format!(
                "{:.1}",
                b as f64 / triangles as f64
            ))
        ));
    }
    let bounds = Aabb::from_points(m.vertices.iter().copied());
    let mut out = Vec::new();
    for (kind, rays) in [
        ("random", random_rays(&bounds, s.rays, 3)),
        ("coherent", coherent_rays(&bounds, s.rays)),
    ] {
        let bits = |h: Option<(u32, f32)>| h.map(|(_, t)| t.to_bits());
        let want: Vec<_> = rays.iter().map(|r| bits((cons[0].trace)(r))).collect();
        for con in &cons[1..] {
            let differ = (rays.iter().zip(&want))
                .filter(|(r, w)| bits((con.trace)(r)) != **w)
                .count();
            report.stress.push(StressRow {
                structure: con.name.into(),
                query: format!("closest t = KdTree's, {mesh_name}, {kind} rays"),
                cases: rays.len() as u64,
                misses: differ as u64,
                ..StressRow::default()
            });
        }
        let scene = format!("{mesh_name}, {kind} rays");
        let per_second: Vec<f64> = cons
            .iter()
            .map(|con| {
                let (secs, _) = best_of(s.reps.max(2), || {
                    rays.iter().filter(|r| (con.trace)(r).is_some()).count()
                });
                let time = ("build ms", con.build_seconds * 1e3);
                report.points.push(point(
                    &scene,
                    con.name,
                    "",
                    time,
                    ("ns per ray", Some(secs * 1e9 / rays.len() as f64)),
                ));
                let bytes = con.bytes.map(|b| b as f64 / triangles as f64);
                report.points.push(point(
                    &scene,
                    con.name,
                    "",
                    time,
                    ("bytes per triangle", bytes),
                ));
                rays.len() as f64 / secs
            })
            .collect();
        out.push((mesh_name.to_string(), kind, per_second));
    }
    out
}

/// Runs this part of the suite into `report`.
pub fn run(s: &Settings, report: &mut Report, progress: &mut Progress) {
    naive_check(report);
    let (big, big_tree, big_seconds) = builds(s, report, progress);
    let bunny = super::bunny();
    let mut build_rows = vec![
        "| mesh | contender | build ms | bytes / tri |".to_string(),
        "|---|---|---:|---:|".into(),
    ];
    let mut table = Vec::new();
    progress.step("kd-tree rays on the bunny");
    let (t, kd) = timed_build(s.reps, || build_kd(&bunny, KdBuild::EventSweep));
    let cons = contenders(&bunny, kd, t);
    table.extend(rays_on(
        ("bunny", &bunny),
        &cons,
        s,
        report,
        &mut build_rows,
    ));
    drop(cons);
    progress.step("kd-tree rays on the scene");
    let name = format!("scene {}", big.indices.len() / 3);
    let cons = contenders(&big, big_tree, big_seconds);
    table.extend(rays_on((&name, &big), &cons, s, report, &mut build_rows));
    drop(cons);
    report.markdown.extend(build_rows);
    report.markdown.extend([
        String::new(),
        "Closest-hit rays, million rays per second (one thread):".into(),
        String::new(),
        "| mesh | rays | KdTree | MeshBvh | kdtree-ray | KdTree / MeshBvh | KdTree / kdtree-ray |"
            .into(),
        "|---|---|---:|---:|---:|---:|---:|".into(),
    ]);
    for (mesh, kind, r) in table {
        report.markdown.push(format!(
            "| {mesh} | {kind} | {:.3} | {:.3} | {:.3} | {:.2}x | {:.2}x |",
            r[0] / 1e6,
            r[1] / 1e6,
            r[2] / 1e6,
            r[0] / r[1],
            r[0] / r[2]
        ));
    }
    report.markdown.push(String::new());
}
