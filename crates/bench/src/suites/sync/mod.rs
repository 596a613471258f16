//! The plugin's upkeep through a real `App::update`: `AccelPlugin` keeping its trees in step
//! with the entities, the figure being what its own systems report
//! (`AccelStats::sync_time` and `maintain_time`), so that transform propagation and the
//! scheduler are not counted. Absorbs the former `benches/sync.rs`.
//!
//! Scenes (`MinimalPlugins` and `TransformPlugin`, unit boxes on a cube grid 3 units apart):
//! every entity dynamic with a different tenth moving a little each frame (a typical game
//! step), for each index choice, and for the BVH with and without the optimiser's per-frame
//! budget (`AccelSettings::upkeep_budget_micros`, a setting rather than refit work); and the
//! idle frames: every entity static, and every entity dynamic with nothing moving (what
//! Bevy's `Changed` scan costs us).
//!
//! The first moving frames carry the motion out of the first fat leaves (and may install a
//! rebuild); the steady state is the median over the frames after a warm-up. Bevy keeps no
//! such trees, so there is no peer in this suite: the whole frame against plain Bevy is the
//! `frame` suite's, and these rows stand against the per-mover target. Points: the
//! upkeep per frame against the BVH's SAH cost over a fresh build's estimate (the quality its
//! budget buys; none for the other indexes).

use super::point;
use crate::json::{Point, Report};
use crate::progress::Progress;
use crate::timing::median;
use bevy::camera::primitives::Aabb;
use bevy::prelude::*;
use bevy_accel::prelude::*;
use std::time::Duration;

/// The sizes of one run.
struct Sizes {
    entities: usize,
    warm_up: usize,
    frames: usize,
}

const FULL: Sizes = Sizes {
    entities: 100_000,
    warm_up: 20,
    frames: 100,
};

const QUICK: Sizes = Sizes {
    entities: 5_000,
    warm_up: 3,
    frames: 8,
};

/// One app: what it runs and its entities in spawn order.
struct SyncApp {
    app: App,
    entities: Vec<Entity>,
}

/// `n` entities on a cube grid; `is_static` marks them all `AccelStatic`.
fn sync_app(n: usize, is_static: bool, settings: AccelSettings) -> SyncApp {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin, AccelPlugin { settings }));
    let side = (n as f32).cbrt().ceil() as usize;
    let entities = (0..n)
        .map(|i| {
            let p = Vec3::new(
                (i % side) as f32,
                (i / side % side) as f32,
                (i / side / side) as f32,
            ) * 3.0;
            let mut e = app.world_mut().spawn((
                Transform::from_translation(p),
                Aabb::from_min_max(Vec3::splat(-0.5), Vec3::splat(0.5)),
            ));
            if is_static {
                e.insert(AccelStatic);
            }
            e.id()
        })
        .collect();
    app.update();
    app.update();
    SyncApp { app, entities }
}

/// Moves a different tenth each frame, each a little up or down.
fn move_tenth(s: &mut SyncApp, frame: u64) {
    for (k, &e) in s
        .entities
        .iter()
        .enumerate()
        .skip((frame % 10) as usize)
        .step_by(10)
    {
        if let Some(mut t) = s.app.world_mut().get_mut::<Transform>(e) {
            t.translation.y += if (frame + k as u64).is_multiple_of(2) {
                0.3
            } else {
                -0.3
            };
        }
    }
}

/// Medians over the measured frames, in milliseconds, and the entities the sync moved and
/// those whose move changed a structure (left a fat leaf or a cell) per frame.
#[derive(Default)]
struct Upkeep {
    sync_ms: f64,
    maintain_ms: f64,
    optimise_ms: f64,
    tree_updates: f64,
    moved: f64,
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// Runs `warm_up + frames` frames, moving a tenth each frame when `moving`.
fn measure(s: &mut SyncApp, moving: bool, sizes: &Sizes) -> Upkeep {
    let mut cols: [Vec<f64>; 5] = Default::default();
    for frame in 0..(sizes.warm_up + sizes.frames) as u64 {
        if moving {
            move_tenth(s, frame);
        }
        s.app.update();
        if frame < sizes.warm_up as u64 {
            continue;
        }
        let st = s.app.world().resource::<AccelStats>();
        // The report is the last maintenance's: a frame whose movers all stayed inside their
        // fat leaves ran none, and its optimiser time is 0, not an earlier frame's.
        let optimise = st
            .bvh
            .and_then(|b| b.last_maintain)
            .filter(|_| st.updated > 0)
            .map_or(Duration::ZERO, |m| m.optimize.elapsed);
        let row = [
            ms(st.sync_time),
            ms(st.maintain_time),
            ms(optimise),
            st.updated as f64,
            st.moved as f64,
        ];
        for (col, v) in cols.iter_mut().zip(row) {
            col.push(v);
        }
    }
    let [sync, maintain, optimise, updates, moved] = cols.map(median);
    Upkeep {
        sync_ms: sync,
        maintain_ms: maintain,
        optimise_ms: optimise,
        tree_updates: updates,
        moved,
    }
}

/// The dynamic BVH's SAH cost over a fresh build's estimate, where the BVH holds the movers.
fn bvh_quality(s: &SyncApp) -> Option<f64> {
    let trees = s.app.world().resource::<AccelTrees>();
    trees.dynamic_bvh().map(|b| f64::from(b.quality().ratio))
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let sizes = if quick { QUICK } else { FULL };
    let n = sizes.entities;
    let no_optimiser = AccelSettings {
        upkeep_budget_micros: 0,
        ..default()
    };
    let mut moving: Vec<(String, &str, AccelSettings)> = vec![
        (
            "Bvh".into(),
            "optimiser budget 0.5 ms",
            AccelSettings::default(),
        ),
        ("Bvh".into(), "no optimiser", no_optimiser),
    ];
    for index in [
        IndexChoice::Octree,
        IndexChoice::Grid,
        IndexChoice::BruteForce,
    ] {
        moving.push((
            format!("{index:?}"),
            "",
            AccelSettings { index, ..default() },
        ));
    }
    let mut progress = Progress::new("sync", moving.len() + 3);
    let mut points: Vec<Point> = Vec::new();
    let mut notes = Vec::new();
    let scene = format!("{n} dynamic entities, 10% moving");
    let mut markdown = vec![
        "| scene | index | setting | sync | maintenance | of which the optimiser | sync + \
         maintenance | moved / restructured | per moved entity |"
            .to_string(),
        "|---|---|---|---:|---:|---:|---:|---:|---:|".to_string(),
    ];
    for (label, setting, settings) in moving {
        progress.step(&format!("{label} {setting}"));
        let mut s = sync_app(n, false, settings);
        let u = measure(&mut s, true, &sizes);
        let total = u.sync_ms + u.maintain_ms;
        let per_mover_ns = total * 1e6 / u.moved.max(1.0);
        let quality = bvh_quality(&s).filter(|_| label == "Bvh");
        markdown.push(format!(
            "| {scene} | {label} | {setting} | {:.3} ms | {:.3} ms | {:.3} ms | {total:.3} ms | \
             {:.0} / {:.0} | {per_mover_ns:.0} ns |",
            u.sync_ms, u.maintain_ms, u.optimise_ms, u.moved, u.tree_updates
        ));
        points.push(point(
            &scene,
            &label,
            setting,
            ("ms per frame (sync + maintenance)", total),
            ("BVH SAH cost / fresh build", quality),
        ));
        if let Some(q) = quality {
            notes.push(format!(
                "{label} ({setting}): SAH cost {q:.3}x a fresh build's after {} frames",
                sizes.warm_up + sizes.frames
            ));
        }
    }
    for (is_static, what) in [(true, "static"), (false, "dynamic")] {
        progress.step(&format!("{what} idle"));
        let mut s = sync_app(n, is_static, AccelSettings::default());
        let u = measure(&mut s, false, &sizes);
        let total = u.sync_ms + u.maintain_ms;
        // No optimiser cell: with nothing moved the maintenance does not run, and its last
        // report is an earlier frame's.
        markdown.push(format!(
            "| {n} {what} entities, nothing moving | Bvh | | {:.4} ms | {:.4} ms | | \
             {total:.4} ms | {:.0} / {:.0} | |",
            u.sync_ms, u.maintain_ms, u.moved, u.tree_updates
        ));
        points.push(point(
            &format!("{n} {what} entities, nothing moving"),
            "Bvh",
            "",
            ("ms per frame (sync + maintenance)", total),
            ("BVH SAH cost / fresh build", None),
        ));
    }
    progress.step("done");
    progress.finish();
    Report {
        suite: "sync".into(),
        quick,
        points,
        markdown,
        notes,
        ..Report::default()
    }
}
