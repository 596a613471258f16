//! Dynamic BVH benchmarks at 100k handles, with obvhs 0.3.3's dynamic operations on the same
//! workload. Before the criterion groups, a 1,000-frame quality run prints the SAH ratio to a
//! fresh build and the optimiser's time per frame (skip it with ACCEL_SKIP_QUALITY=1).

use accel::{Aabb, BuildConfig, Bvh};
use criterion::{BatchSize, Criterion};
use glam::Vec3A;
use std::hint::black_box;
use std::time::{Duration, Instant};

const N: usize = 100_000;

#[path = "common/dynamic_workload.rs"]
mod dynamic_workload;
use accel_testkit::Rng;
use dynamic_workload::{built_tree as tree, scene};

fn to_obvhs(b: &Aabb) -> obvhs::aabb::Aabb {
    obvhs::aabb::Aabb::new(b.min, b.max)
}

fn quality_run() {
    let boxes = scene(N, 1);
    let mut boxes_now = boxes.clone();
    let (mut t, hs) = tree(&boxes);
    let mut r = Rng::new(2);
    let (mut opt_total, mut opt_max, mut maintain_total) =
        (Duration::ZERO, Duration::ZERO, Duration::ZERO);
    let mut rebuilds = 0;
    for _ in 0..1000 {
        for _ in 0..N / 10 {
            let i = r.below(N);
            let d = r.vec3a(-1.0, 1.0);
            boxes_now[i] = Aabb::new(boxes_now[i].min + d, boxes_now[i].max + d);
            t.update(hs[i], boxes_now[i]).unwrap();
        }
        let s = Instant::now();
        let rep = t.maintain();
        maintain_total += s.elapsed();
        opt_total += rep.optimize.elapsed;
        opt_max = opt_max.max(rep.optimize.elapsed);
        rebuilds += usize::from(rep.rebuilt);
    }
    let fresh_fat = t.measure_fresh_build_cost();
    let fresh_tight = Bvh::build(
        &boxes_now,
        &BuildConfig {
            max_leaf_size: 1,
            sah_termination: false,
            ..BuildConfig::default()
        },
    )
    .stats(&t.config().sah)
    .sah_cost;
    let cost = t.stats(&t.config().sah).sah_cost;
    println!(
        "quality run (100k, 1000 frames, 10% random walk of up to 1 unit/axis per frame): SAH {cost:.2}, \
         fresh build over fat boxes {fresh_fat:.2} (ratio {:.3}), over tight boxes {fresh_tight:.2} (ratio {:.3}); \
         estimate {:?}; optimiser mean {:?}/frame max {:?}; maintain mean {:?}/frame; rebuilds {rebuilds}",
        cost / fresh_fat,
        cost / fresh_tight,
        t.quality(),
        opt_total / 1000,
        opt_max,
        maintain_total / 1000
    );
}

fn benches(c: &mut Criterion) {
    let boxes = scene(N, 1);
    let mut g = c.benchmark_group("dynamic_100k");
    // Refit: every leaf moves out of its fat box (1 unit, past the 0.1 margin), then one refit.
    {
        let (mut t, hs) = tree(&boxes);
        let mut flip = 1.0f32;
        g.bench_function("update_and_refit_all_100k_moved", |b| {
            b.iter(|| {
                flip = -flip;
                for (h, bx) in hs.iter().zip(&boxes) {
                    let d = Vec3A::splat(0.5 + 0.5 * flip);
                    t.update(*h, Aabb::new(bx.min + d, bx.max + d)).unwrap();
                }
                black_box(t.refit())
            })
        });
        g.bench_function("empty_frame_maintain", |b| {
            b.iter(|| black_box(t.maintain()))
        });
    }
    {
        let (t, _) = tree(&boxes);
        let extra = scene(1000, 9);
        g.bench_function("insert_1000_at_100k", |b| {
            b.iter_batched_ref(
                || t.clone(),
                |t| {
                    for (i, bx) in extra.iter().enumerate() {
                        black_box(t.insert(N as u32 + i as u32, *bx).unwrap());
                    }
                },
                BatchSize::LargeInput,
            )
        });
        g.bench_function("remove_1000_at_100k", |b| {
            b.iter_batched_ref(
                || {
                    let mut t = t.clone();
                    let hs: Vec<_> = extra
                        .iter()
                        .enumerate()
                        .map(|(i, bx)| t.insert(N as u32 + i as u32, *bx).unwrap())
                        .collect();
                    (t, hs)
                },
                |(t, hs)| {
                    for h in hs.iter() {
                        black_box(t.remove(*h).unwrap());
                    }
                },
                BatchSize::LargeInput,
            )
        });
    }
    // obvhs 0.3.3 on the same boxes: insertion-built Bvh2 (its dynamic path).
    {
        let mut ob = obvhs::bvh2::Bvh2::default();
        let mut stack = obvhs::faststack::HeapStack::new_with_capacity(1000);
        for (i, b) in boxes.iter().enumerate() {
            ob.insert_primitive(to_obvhs(b), i as u32, &mut stack);
        }
        let extra = scene(1000, 9);
        g.bench_function("obvhs_insert_1000_at_100k", |b| {
            b.iter_batched_ref(
                || {
                    (
                        ob.clone(),
                        obvhs::faststack::HeapStack::new_with_capacity(1000),
                    )
                },
                |(o, st)| {
                    for (i, bx) in extra.iter().enumerate() {
                        black_box(o.insert_primitive(to_obvhs(bx), (N + i) as u32, st));
                    }
                },
                BatchSize::LargeInput,
            )
        });
        g.bench_function("obvhs_remove_1000_at_100k", |b| {
            b.iter_batched_ref(
                || ob.clone(),
                |o| {
                    for i in 0..1000u32 {
                        o.remove_primitive(i * 97);
                    }
                },
                BatchSize::LargeInput,
            )
        });
        let mut flip = 1.0f32;
        g.bench_function("obvhs_resize_node_all_100k_moved", |b| {
            b.iter(|| {
                flip = -flip;
                for (i, bx) in boxes.iter().enumerate() {
                    let d = Vec3A::splat(0.5 + 0.5 * flip);
                    let node = ob.primitives_to_nodes[i] as usize;
                    ob.resize_node(node, to_obvhs(&Aabb::new(bx.min + d, bx.max + d)));
                }
            })
        });
        g.bench_function("obvhs_set_all_then_refit_all_100k", |b| {
            b.iter(|| {
                flip = -flip;
                for (i, bx) in boxes.iter().enumerate() {
                    let d = Vec3A::splat(0.5 + 0.5 * flip);
                    let node = ob.primitives_to_nodes[i] as usize;
                    ob.nodes[node].set_aabb(to_obvhs(&Aabb::new(bx.min + d, bx.max + d)));
                }
                ob.refit_all();
            })
        });
    }
    g.finish();
}

fn main() {
    if std::env::var("ACCEL_SKIP_QUALITY").is_err() {
        quality_run();
    }
    let mut c = Criterion::default().configure_from_args();
    benches(&mut c);
    c.final_summary();
}
