//! Single-threaded builds over the benchmark's 1M-triangle bunny scene (the scene of
//! `benches/bvh_build.rs`), interleaved round by round in one run: our binned SAH (16 and 8
//! bins) and PLOC (fastest preset), obvhs 0.3.3's BVH2 (fastest preset), and, when
//! `TINYBVH_PEER` names the binary that `benches/peers/tinybvh.sh` builds, tinybvh's
//! `BVH::BuildAVX` (binned SAH, 8 bins, its default build) with its threading off, into a new
//! tree each time (as ours) and into one tree whose buffers it reuses.
//! Every time includes making the triangle boxes from the triangles, as obvhs'
//! `build_bvh2_from_tris` and tinybvh's build do.
//!
//! `TINYBVH_PEER=$(crates/accel/benches/peers/tinybvh.sh) cargo run --release -p accel
//! --example tri_build_timing [rounds]`
//!
//! The summary is each contender's median time and its median per-round ratio to the
//! reference (tinybvh when it runs, otherwise obvhs fastest): this machine is shared, and a
//! ratio taken within one round survives its noise.

#[path = "../benches/common/mod.rs"]
mod common;

use accel::{Aabb, BuildConfig, Bvh, SplitStrategy, Triangle};
use obvhs::BvhBuildParams;
use std::time::{Duration, Instant};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Seconds taken by `f`.
fn timed(f: impl FnOnce()) -> f64 {
    let start = Instant::now();
    f();
    start.elapsed().as_secs_f64()
}

fn main() {
    let rounds: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(7);
    let tris = accel_testkit::triangle_scene(1_000_000, 2);
    let ot: Vec<obvhs::triangle::Triangle> = tris.iter().map(common::peers::to_obvhs_tri).collect();
    // The tinybvh rows share one peer; a `RefCell` lends it to each in turn.
    let peer = common::tinybvh::TinyBvh::from_env(&tris).map(std::cell::RefCell::new);

    let ours = |split: SplitStrategy| {
        let config = BuildConfig::with_split(split);
        let tris = &tris;
        move || {
            timed(|| {
                let boxes: Vec<Aabb> = tris.iter().map(Triangle::aabb).collect();
                std::hint::black_box(Bvh::build(&boxes, &config));
            })
        }
    };
    type Build<'a> = Box<dyn FnMut() -> f64 + 'a>;
    let mut contenders: Vec<(String, Build)> = vec![
        (
            "accel binned16".into(),
            Box::new(ours(SplitStrategy::BinnedSah { bins: 16 })),
        ),
        (
            "accel binned8".into(),
            Box::new(ours(SplitStrategy::BinnedSah { bins: 8 })),
        ),
        (
            "accel ploc fastest".into(),
            Box::new(ours(SplitStrategy::PLOC_FASTEST)),
        ),
        (
            "obvhs bvh2 fastest".into(),
            Box::new(|| {
                timed(|| {
                    std::hint::black_box(obvhs::bvh2::builder::build_bvh2_from_tris(
                        &ot,
                        BvhBuildParams::fastest_build(),
                        &mut Duration::default(),
                    ));
                })
            }),
        ),
    ];
    if let Some(peer) = &peer {
        let version = peer.borrow().version.clone();
        println!(
            "{version} BuildAVX: tinybvh's SAH cost {:.2}",
            peer.borrow_mut().build_avx().1
        );
        contenders.push((
            format!("{version} BuildAVX, reusing its buffers"),
            Box::new(|| peer.borrow_mut().rebuild_avx()),
        ));
        contenders.push((
            format!("{version} BuildAVX"),
            Box::new(|| peer.borrow_mut().build_avx().0),
        ));
    }

    let mut samples: Vec<Vec<f64>> = vec![Vec::new(); contenders.len()];
    for _ in 0..rounds {
        for ((_, build), s) in contenders.iter_mut().zip(&mut samples) {
            s.push(build());
        }
    }
    let reference = contenders.len() - 1;
    println!(
        "{} triangles, {rounds} rounds; median time, rate, and median per-round speed ratio to {}:",
        tris.len(),
        contenders[reference].0
    );
    for ((name, _), s) in contenders.iter().zip(&samples) {
        let ratio = median(
            s.iter()
                .zip(&samples[reference])
                .map(|(ours, theirs)| theirs / ours)
                .collect(),
        );
        let seconds = median(s.clone());
        println!(
            "  {name}: {:.1} ms, {:.2} M tris/s ({ratio:.2}x)",
            seconds * 1e3,
            tris.len() as f64 / seconds / 1e6
        );
    }
}
