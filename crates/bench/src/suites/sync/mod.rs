//! The plugin's upkeep through a real `App::update`: `AccelPlugin` keeping its trees in step
//! with the entities, the figure being what its own systems report
//! (`AccelStats::sync_time` and `maintain_time`), so that transform propagation and the
//! scheduler are not counted. Absorbs the former `benches/sync.rs`.
//!
//! Scenes (`MinimalPlugins` and `TransformPlugin`, unit boxes on a cube grid 3 units apart):
//! every entity dynamic with a different tenth moving a little each frame (a typical game
//! step), for each index choice, and for the BVH with and without the optimiser's per-frame
//! budget (`AccelSettings::upkeep_budget_micros`, a setting rather than refit work); the
//! whole-frame scene's size and share, 1M entities with a quarter moving, for the BVH, the
//! grid and the flat list; the busy movers' list beside the BVH in both (every other row has
//! it off, so that it gives the index's own upkeep); and the idle frames: every entity static, and every entity dynamic
//! with nothing moving (what Bevy's `Changed` scan costs us).
//!
//! The peer, in each moving scene: the *floor* (`floor.rs`), an app whose one system does the
//! least any upkeep must (finds the movers, takes their world boxes, stores each one), so the
//! per-mover gap between it and the plugin is what the plugin's records and structures cost.
//!
//! The first moving frames carry the motion out of the first fat leaves (and may install a
//! rebuild); the steady state is the median over the frames after a warm-up. Points: the
//! upkeep per frame against the BVH's SAH cost over a fresh build's estimate (the quality its
//! budget buys; none for the other indexes).

mod floor;

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
    /// The whole-frame scene's size (a quarter moving); none in the quick run.
    large: Option<usize>,
    warm_up: usize,
    frames: usize,
}

const FULL: Sizes = Sizes {
    entities: 100_000,
    large: Some(1_000_000),
    warm_up: 20,
    frames: 100,
};

const QUICK: Sizes = Sizes {
    entities: 5_000,
    large: None,
    warm_up: 3,
    frames: 8,
};

/// One app: what it runs and its entities in spawn order.
struct SyncApp {
    app: App,
    entities: Vec<Entity>,
}

/// `n` entities on a cube grid; `is_static` marks them all `AccelStatic`. With no settings,
/// the floor's app instead of the plugin.
fn sync_app(n: usize, is_static: bool, settings: Option<AccelSettings>) -> SyncApp {
    let mut app = App::new();
    app.add_plugins((MinimalPlugins, TransformPlugin));
    match settings {
        Some(settings) => {
            app.add_plugins(AccelPlugin { settings });
        }
        None => floor::add_floor(&mut app),
    }
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

/// Moves a different share each frame (every `stride`-th entity from an offset that turns
/// with the frame), each a little up or down.
fn move_share(s: &mut SyncApp, frame: u64, stride: usize) {
    for (k, &e) in s
        .entities
        .iter()
        .enumerate()
        .skip((frame % stride as u64) as usize)
        .step_by(stride)
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

/// Runs `warm_up + frames` frames, moving every `stride`-th entity each frame when given.
fn measure(s: &mut SyncApp, stride: Option<usize>, sizes: &Sizes) -> Upkeep {
    let mut cols: [Vec<f64>; 5] = Default::default();
    for frame in 0..(sizes.warm_up + sizes.frames) as u64 {
        if let Some(stride) = stride {
            move_share(s, frame, stride);
        }
        s.app.update();
        if frame < sizes.warm_up as u64 {
            continue;
        }
        if let Some(floor) = s.app.world().get_resource::<floor::FloorBoxes>() {
            let row = [ms(floor.elapsed), 0.0, 0.0, 0.0, floor.moved as f64];
            for (col, v) in cols.iter_mut().zip(row) {
                col.push(v);
            }
            continue;
        }
        let st = s.app.world().resource::<AccelStats>();
        // The report is the last maintenance's: a frame whose movers all stayed inside their
        // fat leaves ran none, and its optimiser time is 0, not an earlier frame's.
        let optimise = st
            .bvh
            .and_then(|b| b.last_maintain)
            .filter(|_| st.updated > st.busy_moved)
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
    let trees = s.app.world().get_resource::<AccelTrees>()?;
    trees.dynamic_bvh().map(|b| f64::from(b.quality().ratio))
}

/// One contender of a moving scene: its label, setting and app (no settings: the floor).
type Contender = (String, &'static str, Option<AccelSettings>);

/// Every mover in `index`: the busy movers' list off, so that each row is the index's own
/// upkeep.
fn in_index(index: IndexChoice) -> AccelSettings {
    AccelSettings {
        index,
        busy_movers: BusyMoverSettings {
            mode: BusyMovers::Off,
            ..default()
        },
        ..default()
    }
}

/// The movers in the busy movers' list, the rest in the BVH.
fn busy_movers() -> Contender {
    let settings = AccelSettings {
        index: IndexChoice::Bvh,
        busy_movers: BusyMoverSettings {
            mode: BusyMovers::On,
            ..default()
        },
        ..default()
    };
    ("busy movers".into(), "beside the BVH", Some(settings))
}

/// The contenders of the 100k scene: every index, the BVH with and without its optimiser,
/// and the busy movers.
fn every_index() -> Vec<Contender> {
    let no_optimiser = AccelSettings {
        upkeep_budget_micros: 0,
        ..in_index(IndexChoice::Bvh)
    };
    let mut contenders: Vec<Contender> = vec![
        (
            "Bvh".into(),
            "optimiser budget 0.5 ms",
            Some(in_index(IndexChoice::Bvh)),
        ),
        ("Bvh".into(), "no optimiser", Some(no_optimiser)),
    ];
    for index in [
        IndexChoice::Octree,
        IndexChoice::Grid,
        IndexChoice::BruteForce,
    ] {
        contenders.push((format!("{index:?}"), "", Some(in_index(index))));
    }
    contenders.push(busy_movers());
    contenders
}

/// The contenders of the 1M scene: the indexes the whole-frame suite runs at that size, and
/// the busy movers.
fn large_indexes() -> Vec<Contender> {
    [IndexChoice::Bvh, IndexChoice::Grid, IndexChoice::BruteForce]
        .into_iter()
        .map(|index| (format!("{index:?}"), "", Some(in_index(index))))
        .chain([busy_movers()])
        .collect()
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let sizes = if quick { QUICK } else { FULL };
    let n = sizes.entities;
    let floor: Contender = ("floor".into(), "bare read and store", None);
    // (entities, every how many moves, percent moving, contenders)
    let mut scenes = vec![(n, 10, 10, every_index())];
    if let Some(large) = sizes.large {
        scenes.push((large, 4, 25, large_indexes()));
    }
    for scene in &mut scenes {
        scene.3.push(floor.clone());
    }
    let steps: usize = scenes.iter().map(|s| s.3.len()).sum();
    let mut progress = Progress::new("sync", steps + 3);
    let mut points: Vec<Point> = Vec::new();
    let mut notes = Vec::new();
    let mut markdown = vec![
        "| scene | index | setting | sync | maintenance | of which the optimiser | sync + \
         maintenance | moved / restructured | per moved entity | over the floor's |"
            .to_string(),
        "|---|---|---|---:|---:|---:|---:|---:|---:|---:|".to_string(),
    ];
    for (entities, stride, pct, contenders) in scenes {
        let scene = format!("{entities} dynamic entities, {pct}% moving");
        let mut rows = Vec::new();
        for (label, setting, settings) in contenders {
            progress.step(&format!("{entities} {label} {setting}"));
            let mut s = sync_app(entities, false, settings);
            let u = measure(&mut s, Some(stride), &sizes);
            let quality = bvh_quality(&s).filter(|_| label == "Bvh");
            rows.push((label, setting, u, quality));
        }
        let per_mover = |u: &Upkeep| (u.sync_ms + u.maintain_ms) * 1e6 / u.moved.max(1.0);
        let floor_ns = rows
            .iter()
            .find(|r| r.0 == "floor")
            .map_or(f64::NAN, |r| per_mover(&r.2));
        for (label, setting, u, quality) in rows {
            let total = u.sync_ms + u.maintain_ms;
            let per_mover_ns = per_mover(&u);
            markdown.push(format!(
                "| {scene} | {label} | {setting} | {:.3} ms | {:.3} ms | {:.3} ms | {total:.3} ms \
                 | {:.0} / {:.0} | {per_mover_ns:.0} ns | {:.1}x |",
                u.sync_ms,
                u.maintain_ms,
                u.optimise_ms,
                u.moved,
                u.tree_updates,
                per_mover_ns / floor_ns
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
                    "{scene}, {label} ({setting}): SAH cost {q:.3}x a fresh build's after {} \
                     frames",
                    sizes.warm_up + sizes.frames
                ));
            }
        }
        notes.push(format!(
            "{scene}: the floor (movers found, read, boxed and stored, nothing else) costs \
             {floor_ns:.0} ns a mover"
        ));
    }
    for (is_static, what) in [(true, "static"), (false, "dynamic")] {
        progress.step(&format!("{what} idle"));
        let mut s = sync_app(n, is_static, Some(AccelSettings::default()));
        let u = measure(&mut s, None, &sizes);
        let total = u.sync_ms + u.maintain_ms;
        // No optimiser cell: with nothing moved the maintenance does not run, and its last
        // report is an earlier frame's.
        markdown.push(format!(
            "| {n} {what} entities, nothing moving | Bvh | | {:.4} ms | {:.4} ms | | \
             {total:.4} ms | {:.0} / {:.0} | | |",
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
