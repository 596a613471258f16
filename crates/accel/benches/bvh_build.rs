//! BVH build time, side by side with obvhs 0.3.3 (BVH2 and CWBVH) and the `bvh` crate, on the
//! same primitives, single-threaded:
//!
//! - `build_100k_boxes`: 100k entity boxes (uniform plus clusters).
//! - `build_1m_tris`: the ~1M-triangle bunny scene, reported as triangles per second (the time
//!   includes making the triangle boxes, as obvhs' `build_*_from_tris` does).
//!
//! Before timing, each contender is built once and its shape printed: SAH cost under one cost
//! model (ours, `SahCosts::default()`: traversal 2, intersection 1, computed by
//! `accel::bvh::stats::tree_stats` on every binary tree, the peers' included), node count and
//! memory per primitive.
//!
//! New layouts (wide nodes, the mesh BVH, the parallel build) are one more entry in
//! `contenders`.
//!
//! Run: `cargo bench -p accel --bench bvh_build -- --warm-up-time 1 --measurement-time 3`

mod common;

use accel::bvh::stats::tree_stats;
use accel::query::BoundingTree;
use accel::{Aabb, BuildConfig, Bvh, SahCosts, SplitStrategy, Triangle};
use accel_testkit::{entity_boxes, triangle_scene};
use common::peers::{self, BvhCrateTree, BvhShape, ObvhsBvh2};
use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use obvhs::BvhBuildParams;
use std::cell::RefCell;
use std::hint::black_box;
use std::rc::Rc;
use std::time::Duration;

/// What a built tree reports about itself (outside the timed loop).
struct Report {
    nodes: usize,
    /// SAH cost of a binary tree under our cost model; `None` for wide trees.
    sah: Option<f32>,
    bytes: usize,
}

/// Any built tree.
trait Built {
    fn report(&self) -> Report;
}

fn binary_report<T: BoundingTree<Volume = Aabb>>(tree: &T, nodes: usize, bytes: usize) -> Report {
    Report {
        nodes,
        sah: Some(tree_stats(tree, &SahCosts::default()).sah_cost),
        bytes,
    }
}

impl Built for Bvh {
    fn report(&self) -> Report {
        binary_report(self, self.nodes().len(), self.memory_bytes())
    }
}

impl Built for obvhs::bvh2::Bvh2 {
    fn report(&self) -> Report {
        binary_report(
            &ObvhsBvh2(self),
            self.nodes.len(),
            peers::obvhs_bvh2_bytes(self),
        )
    }
}

impl Built for obvhs::cwbvh::CwBvh {
    fn report(&self) -> Report {
        Report {
            nodes: self.nodes.len(),
            sah: None,
            bytes: peers::obvhs_cwbvh_bytes(self),
        }
    }
}

struct BvhCrateBuilt(bvh::bvh::Bvh<f32, 3>);

impl Built for BvhCrateBuilt {
    fn report(&self) -> Report {
        let tree = BvhCrateTree::new(&self.0);
        binary_report(&tree, self.0.nodes.len(), peers::bvh_crate_bytes(&self.0))
    }
}

/// A named way to build a tree over the scene; the closure is what gets timed.
struct Contender<'a> {
    name: String,
    build: Box<dyn Fn() -> Box<dyn Built + 'a> + 'a>,
}

fn contender<'a, B: Built + 'a>(name: &str, f: impl Fn() -> B + 'a) -> Contender<'a> {
    Contender {
        name: name.to_string(),
        build: Box::new(move || Box::new(f())),
    }
}

/// Our split strategies, each with the default stopping rules (leaves of up to 8 by SAH).
fn our_strategies() -> Vec<(&'static str, SplitStrategy)> {
    vec![
        ("accel lbvh", SplitStrategy::Lbvh),
        ("accel midpoint", SplitStrategy::Midpoint),
        ("accel median", SplitStrategy::Median),
        ("accel binned8", SplitStrategy::BinnedSah { bins: 8 }),
        ("accel binned16", SplitStrategy::BinnedSah { bins: 16 }),
        ("accel sweep", SplitStrategy::SweepSah),
        ("accel ploc fastest", SplitStrategy::PLOC_FASTEST),
        (
            "accel ploc r4",
            SplitStrategy::Ploc {
                search_radius: 4,
                reinsert_per_mille: 0,
            },
        ),
        ("accel ploc", SplitStrategy::PLOC),
    ]
}

fn obvhs_presets() -> Vec<(&'static str, BvhBuildParams)> {
    vec![
        ("fastest", BvhBuildParams::fastest_build()),
        ("fast", BvhBuildParams::fast_build()),
        ("medium", BvhBuildParams::medium_build()),
    ]
}

/// Contenders over boxes (entities): every crate gets the same `Aabb`s.
fn box_contenders(boxes: &[Aabb]) -> Vec<Contender<'_>> {
    let mut c: Vec<Contender<'_>> = our_strategies()
        .into_iter()
        .map(|(name, split)| {
            let cfg = BuildConfig::with_split(split);
            contender(name, move || Bvh::build(boxes, &cfg))
        })
        .collect();
    let ob: Vec<obvhs::aabb::Aabb> = boxes.iter().map(peers::to_obvhs_aabb).collect();
    let ob = Rc::new(ob);
    for (preset, params) in obvhs_presets() {
        let ob2 = ob.clone();
        c.push(contender(&format!("obvhs bvh2 {preset}"), move || {
            obvhs::bvh2::builder::build_bvh2(&ob2, params, &mut Duration::default())
        }));
        let ob2 = ob.clone();
        c.push(contender(&format!("obvhs cwbvh {preset}"), move || {
            obvhs::cwbvh::builder::build_cwbvh(&ob2, params, &mut Duration::default())
        }));
    }
    let shapes: Vec<BvhShape> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| BvhShape::new(i, b))
        .collect();
    let shapes = RefCell::new(shapes);
    c.push(contender("bvh 0.13 (sah)", move || {
        let mut s = shapes.borrow_mut();
        // The crate only writes each shape's node index, so the shapes are reused.
        BvhCrateBuilt(bvh::bvh::Bvh::build(&mut s[..]))
    }));
    c
}

/// Contenders over triangles: the time includes making the boxes from the triangles.
fn tri_contenders(tris: &[Triangle]) -> Vec<Contender<'_>> {
    let mut c: Vec<Contender<'_>> = our_strategies()
        .into_iter()
        .map(|(name, split)| {
            let cfg = BuildConfig::with_split(split);
            contender(name, move || {
                let boxes: Vec<Aabb> = tris.iter().map(Triangle::aabb).collect();
                Bvh::build(&boxes, &cfg)
            })
        })
        .collect();
    let ot: Vec<obvhs::triangle::Triangle> = tris.iter().map(peers::to_obvhs_tri).collect();
    let ot = Rc::new(ot);
    for (preset, params) in obvhs_presets() {
        let ot2 = ot.clone();
        c.push(contender(&format!("obvhs bvh2 {preset}"), move || {
            obvhs::bvh2::builder::build_bvh2_from_tris(&ot2, params, &mut Duration::default())
        }));
        let ot2 = ot.clone();
        c.push(contender(&format!("obvhs cwbvh {preset}"), move || {
            obvhs::cwbvh::builder::build_cwbvh_from_tris(&ot2, params, &mut Duration::default())
        }));
    }
    c.push(contender("bvh 0.13 (sah)", move || {
        let mut shapes: Vec<BvhShape> = tris
            .iter()
            .enumerate()
            .map(|(i, t)| BvhShape::new(i, &t.aabb()))
            .collect();
        BvhCrateBuilt(bvh::bvh::Bvh::build(&mut shapes))
    }));
    c
}

/// Builds each contender once and prints its shape, with its SAH cost relative to the first
/// row that has one (ours, binned 16 is the reference when present).
fn print_reports(title: &str, prims: usize, contenders: &[Contender<'_>]) {
    println!("\n## {title}: {prims} primitives");
    println!("| contender | one build (ms) | nodes | SAH cost (Ct=2, Ci=1) | bytes/prim |");
    println!("|---|---:|---:|---:|---:|");
    for c in contenders {
        let t = std::time::Instant::now();
        let built = (c.build)();
        let ms = t.elapsed().as_secs_f64() * 1e3;
        let r = built.report();
        let sah = r
            .sah
            .map_or("n/a (wide)".to_string(), |s| format!("{s:.2}"));
        println!(
            "| {} | {ms:.1} | {} | {sah} | {:.1} |",
            c.name,
            r.nodes,
            r.bytes as f64 / prims as f64
        );
    }
}

fn bench_group(c: &mut Criterion, group: &str, prims: usize, contenders: &[Contender<'_>]) {
    let mut g = c.benchmark_group(group);
    g.throughput(Throughput::Elements(prims as u64));
    if prims > 200_000 {
        g.sample_size(10);
    }
    for con in contenders {
        g.bench_function(&con.name, |b| {
            b.iter_batched(
                || (),
                |()| black_box((con.build)()),
                BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

fn builds(c: &mut Criterion) {
    let boxes = entity_boxes(100_000, 1);
    let box_c = box_contenders(&boxes);
    print_reports("build_100k_boxes", boxes.len(), &box_c);

    let tris = triangle_scene(1_000_000, 2);
    let tri_c = tri_contenders(&tris);
    print_reports("build_1m_tris", tris.len(), &tri_c);

    bench_group(c, "build_100k_boxes", boxes.len(), &box_c);
    bench_group(c, "build_1m_tris", tris.len(), &tri_c);
}

criterion_group!(benches, builds);
criterion_main!(benches);
