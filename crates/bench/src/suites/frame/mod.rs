//! The whole frame against plain Bevy, the headline figure: apps with the same scene, updated
//! in turn frame by frame, each `App::update` timed whole. Absorbs the former
//! `benches/frame.rs`.
//!
//! - *floor*: plain Bevy with no camera, what both others pay (transform propagation, the
//!   schedules, the motion system);
//! - *bevy*: plain Bevy (no bevy_accel at all) with one camera, culled by Bevy's own
//!   `check_visibility`;
//! - `accel/<index>`: the same scene with `AccelPlugin`, `AccelCullingPlugin` and
//!   `AccelPickingPlugin`, casting one pointer ray per frame (`AccelRayCast::cast_ray_bounds`),
//!   the moving entities in the chosen index;
//! - `accel/Automatic-no-pointer`: `AccelPlugin` and `AccelCullingPlugin` alone, the pairing
//!   whose frame the plugin promises never slower than Bevy's: its trees step aside in a small
//!   world, or where Bevy's culling is timed cheaper, and leave the busy movers' moves
//!   unwritten while no view reads them (the notes give the share of frames aside, the last
//!   timing of both sides and the share of frames with the moves unwritten);
//! - *bevy again* (1k and 10k entities): a second plain Bevy app, the noise of a ratio.
//!
//! Scenes: a *field* of unit boxes on a square, 4 units apart with a jitter, all of them
//! dynamic (a user who marks nothing `AccelStatic`), a share of them wobbling every frame; and
//! a *city* on the same square (half the entities buildings of mixed sizes marked
//! `AccelStatic`, a quarter parked props, a quarter cars driving every frame, four huge
//! ground tiles), a scene the plugin was not tuned on. Sizes from a thousand entities to a
//! million. Cameras: a *strategy* camera looking down from above (about 2% of the square in
//! view) and a *ground* camera at its edge looking across it (about 40%; Bevy does not cull by
//! the far plane). Run it at several compute-pool sizes with `--compute-threads 1,2`: both
//! apps get the same pools.
//!
//! With `--overlays-off`, each scene also has the BVH app with Bevy's gizmos, and with Bevy's
//! gizmos and `AccelOverlaysPlugin` with every overlay off: the difference of those two is
//! what the overlays cost when they are not used (the same for every index: the overlays'
//! systems do not run while off). With `--panel-closed`, the same for the panel: the BVH app
//! with bevy_egui's `EguiPlugin`, and with it and `AccelPanelPlugin`, the panel closed
//! (headless, so bevy_egui has no window to draw in either way; the difference is what the
//! panel's own systems and run conditions cost while closed).
//!
//! Points: one per scene and contender, the median frame against the visible share's
//! difference from Bevy's in percentage points (ours must equal Bevy's; the floor has no
//! view). The Markdown table is the former bench's; the notes give each accel app's
//! speed-ups (Bevy's frame over ours, whole and over the floor) and where its frame goes (the
//! plugin's own timings of its sync, maintenance and culling).

mod app;

use super::{point, trees_building_off_frame};
use crate::Options;
use crate::json::{Point, Report};
use crate::progress::Progress;
use crate::timing::median;
use app::{CameraKind, Contender, Layout, Scene, build_app, visible_share};
use bevy::prelude::*;
use bevy_accel::culling::CullingStats;
use bevy_accel::prelude::*;
use std::time::{Duration, Instant};

/// One scene size and what runs on it.
#[derive(Clone, Copy)]
struct Size {
    layout: Layout,
    entities: usize,
    indexes: &'static [IndexChoice],
    frames: usize,
}

/// The sizes of one run.
struct Sizes {
    sizes: &'static [Size],
    /// The field's shares of movers (the city's are its cars, a quarter).
    moving: &'static [u32],
    cameras: &'static [CameraKind],
    warm_up: usize,
}

/// Up to this many entities, a scene also runs [`Contender::BevyAgain`].
const SMALL_WORLD: usize = 10_000;

/// Frames measured at 1k and 10k entities: their frames are tenths of a millisecond, and at
/// 100 frames Bevy against itself read anywhere from 0.93x to 1.13x.
const SMALL_WORLD_FRAMES: usize = 1_000;

/// The default choice, on scenes where each index is not compared.
const AUTOMATIC: &[IndexChoice] = &[IndexChoice::Automatic];

const FULL: Sizes = Sizes {
    sizes: &[
        Size {
            layout: Layout::Field,
            entities: 1_000,
            indexes: AUTOMATIC,
            frames: SMALL_WORLD_FRAMES,
        },
        Size {
            layout: Layout::Field,
            entities: 10_000,
            indexes: AUTOMATIC,
            frames: SMALL_WORLD_FRAMES,
        },
        Size {
            layout: Layout::Field,
            entities: 100_000,
            indexes: &IndexChoice::ALL,
            frames: 40,
        },
        // The octree and the quadtree trail the others at 100k already; 1M of each would
        // double the run.
        Size {
            layout: Layout::Field,
            entities: 1_000_000,
            indexes: &[
                IndexChoice::Bvh,
                IndexChoice::Grid,
                IndexChoice::BruteForce,
                IndexChoice::Automatic,
            ],
            frames: 20,
        },
        Size {
            layout: Layout::City,
            entities: 1_000,
            indexes: AUTOMATIC,
            frames: SMALL_WORLD_FRAMES,
        },
        Size {
            layout: Layout::City,
            entities: 10_000,
            indexes: AUTOMATIC,
            frames: SMALL_WORLD_FRAMES,
        },
        Size {
            layout: Layout::City,
            entities: 100_000,
            indexes: AUTOMATIC,
            frames: 40,
        },
        Size {
            layout: Layout::City,
            entities: 1_000_000,
            indexes: AUTOMATIC,
            frames: 20,
        },
    ],
    moving: &[0, 10, 25],
    cameras: &[CameraKind::Strategy, CameraKind::Ground],
    // First rebuilds, caches, and the ray snapshot's wait (30 frames without an entity
    // entering or leaving the dynamic tree, after the movers have joined the busy list).
    warm_up: 40,
};

const QUICK: Sizes = Sizes {
    sizes: &[
        Size {
            layout: Layout::Field,
            entities: 10_000,
            indexes: &[IndexChoice::Bvh, IndexChoice::Grid],
            frames: 10,
        },
        Size {
            layout: Layout::City,
            entities: 10_000,
            indexes: AUTOMATIC,
            frames: 10,
        },
    ],
    moving: &[0, 10],
    cameras: &[CameraKind::Strategy, CameraKind::Ground],
    warm_up: 10,
};

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

/// What one app's measured frames gave, in milliseconds (medians).
struct Timed {
    frame: f64,
    /// The plugin's sync, maintenance and culling (accel apps only).
    parts: Option<[f64; 3]>,
    visible_pct: Option<f64>,
    /// The structure the movers were in at the end (what the automatic choice chose).
    index: Option<IndexChoice>,
    /// Accel apps: the share of measured frames in which the trees stood aside, and the last
    /// timing of both sides that decided it (`AccelSettings::step_aside_when_slower`).
    aside: Option<(f64, Option<bevy_accel::StepAsideProbe>)>,
    /// Accel apps: the share of measured frames whose busy movers' moves were left unwritten
    /// (`AccelSettings::skip_unread_mover_upkeep`).
    unwritten: Option<f64>,
}

/// Runs every contender of `scene` in turn, frame by frame.
fn measure(scene: Scene, contenders: &[Contender], warm_up: usize, frames: usize) -> Vec<Timed> {
    let mut apps: Vec<App> = contenders.iter().map(|&c| build_app(c, scene)).collect();
    for _ in 0..warm_up {
        for app in &mut apps {
            app.update();
        }
    }
    // The automatic choice: until it runs on the structure it recommends (a switch filled
    // off the frame lands some frames after the choice).
    for app in &mut apps {
        for _ in 0..400 {
            let settled = app.world().get_resource::<AccelStats>().is_none_or(|s| {
                s.automatic.is_none_or(|a| a.recommended == s.index)
                    && !app
                        .world()
                        .resource::<bevy_accel::AccelTrees>()
                        .index_switch_in_flight()
                    && !trees_building_off_frame(app)
            });
            if settled {
                break;
            }
            app.update();
        }
    }
    let mut times = vec![Vec::with_capacity(frames); apps.len()];
    let mut parts = vec![[const { Vec::new() }; 3]; apps.len()];
    let mut aside_frames = vec![0usize; apps.len()];
    let mut unwritten_frames = vec![0usize; apps.len()];
    for _ in 0..frames {
        for ((((app, t), part), aside), unwritten) in apps
            .iter_mut()
            .zip(&mut times)
            .zip(&mut parts)
            .zip(&mut aside_frames)
            .zip(&mut unwritten_frames)
        {
            let start = Instant::now();
            app.update();
            t.push(ms(start.elapsed()));
            if let Some(stats) = app.world().get_resource::<AccelStats>() {
                *aside += app
                    .world()
                    .resource::<bevy_accel::AccelTrees>()
                    .stepped_aside() as usize;
                *unwritten += usize::from(stats.busy_moves_skipped > 0);
                part[0].push(ms(stats.sync_time));
                part[1].push(ms(stats.maintain_time));
                part[2].push(ms(app.world().resource::<CullingStats>().time));
            }
        }
    }
    contenders
        .iter()
        .zip(apps.iter_mut())
        .zip(
            times
                .into_iter()
                .zip(parts)
                .zip(aside_frames.into_iter().zip(unwritten_frames)),
        )
        .map(|((&c, app), ((t, part), (aside, unwritten)))| Timed {
            frame: median(t),
            parts: c.is_accel().then(|| part.map(median)),
            visible_pct: visible_share(app, c, scene.entities),
            index: app.world().get_resource::<AccelStats>().map(|s| s.index),
            aside: c.is_accel().then(|| {
                let trees = app.world().resource::<bevy_accel::AccelTrees>();
                (
                    aside as f64 / frames.max(1) as f64,
                    trees.last_step_aside_probe(),
                )
            }),
            unwritten: c
                .is_accel()
                .then(|| unwritten as f64 / frames.max(1) as f64),
        })
        .collect()
}

/// One scene of `--scene N/PCT/CAMERA[/INDEX]` (the field) or `city/N/CAMERA[/INDEX]`, and
/// the index asked for with it (its place in [`IndexChoice::ALL`]). The argument parser calls
/// it to refuse a bad scene early.
pub fn parse_scene(text: &str) -> Result<(Scene, Option<usize>), String> {
    let bad =
        || format!("--scene wants N/PCT/CAMERA[/INDEX] or city/N/CAMERA[/INDEX], not {text:?}");
    let mut parts: Vec<&str> = text.split('/').collect();
    let layout = if parts
        .first()
        .is_some_and(|p| p.eq_ignore_ascii_case("city"))
    {
        parts.remove(0);
        // The city's movers are its cars, a quarter.
        parts.insert(1, "25");
        Layout::City
    } else {
        Layout::Field
    };
    if !(3..=4).contains(&parts.len()) {
        return Err(bad());
    }
    let entities = parts[0].parse().map_err(|_| bad())?;
    let moving_pct = parts[1]
        .parse()
        .ok()
        .filter(|&p| p <= 100)
        .ok_or_else(bad)?;
    let camera = match parts[2].to_ascii_lowercase().as_str() {
        "strategy" => CameraKind::Strategy,
        "ground" => CameraKind::Ground,
        _ => return Err(bad()),
    };
    let index = match parts.get(3) {
        None => None,
        Some(name) => Some(
            IndexChoice::ALL
                .iter()
                .position(|i| format!("{i:?}").eq_ignore_ascii_case(name))
                .ok_or_else(bad)?,
        ),
    };
    let scene = Scene {
        layout,
        entities,
        moving_pct,
        camera,
    };
    Ok((scene, index))
}

/// Runs the suite; `--overlays-off` adds the overlays' contenders, `--panel-closed` the
/// panel's, `--scene` keeps one scene (and perhaps one index).
pub fn run(opts: &Options) -> Report {
    let (quick, overlays_off, panel_closed) = (opts.quick, opts.overlays_off, opts.panel_closed);
    let sizes = if quick { QUICK } else { FULL };
    let mut scenes: Vec<(Scene, Size)> = Vec::new();
    if let Some(text) = &opts.frame_scene {
        let (scene, index) = parse_scene(text).expect("checked when the arguments were parsed");
        let nearest = sizes
            .sizes
            .iter()
            .min_by_key(|s| {
                (
                    s.layout != scene.layout,
                    s.entities.abs_diff(scene.entities),
                )
            })
            .expect("every run has a size");
        let indexes: &'static [IndexChoice] = match index {
            Some(p) => &IndexChoice::ALL[p..=p],
            None => nearest.indexes,
        };
        let size = Size {
            layout: scene.layout,
            entities: scene.entities,
            indexes,
            frames: opts.frames.unwrap_or(nearest.frames),
        };
        scenes.push((scene, size));
    } else {
        for size in sizes.sizes {
            let moving: &[u32] = match size.layout {
                Layout::Field => sizes.moving,
                Layout::City => &[25],
            };
            for &moving_pct in moving {
                for &camera in sizes.cameras {
                    let scene = Scene {
                        layout: size.layout,
                        entities: size.entities,
                        moving_pct,
                        camera,
                    };
                    scenes.push((scene, *size));
                }
            }
        }
    }
    let mut progress = Progress::new("frame", scenes.len() + 1);
    let mut points: Vec<Point> = Vec::new();
    let mut notes = Vec::new();
    let mut markdown = vec![
        "| scene | entities | moving | camera | visible (bevy / ours) | floor | bevy | index | \
         accel | whole frame bevy/accel | over the floor bevy/accel |"
            .to_string(),
        "|---|---:|---:|---|---|---:|---:|---|---:|---:|---:|".to_string(),
    ];
    for (scene, size) in scenes {
        let Scene {
            layout,
            entities: n,
            moving_pct: pct,
            camera,
        } = scene;
        let name = format!("{layout:?}, {n} entities, {pct}% moving, {camera:?} camera");
        progress.step(&name);
        let mut contenders = vec![Contender::Floor, Contender::Bevy];
        // Where a frame is a few tenths of a millisecond: Bevy against itself (the noise of
        // a ratio).
        if n <= SMALL_WORLD {
            contenders.push(Contender::BevyAgain);
        }
        // The trees serving culling alone, at every size: the pairing whose frame the plugin
        // promises never slower than Bevy's (where they may step aside).
        contenders.push(Contender::AccelNoPointer(IndexChoice::Automatic));
        contenders.extend(size.indexes.iter().map(|&i| Contender::Accel(i)));
        // The default choice as it was before the busy movers' list: what the list changes.
        contenders.push(Contender::AccelBusyOff(IndexChoice::Automatic));
        if overlays_off {
            contenders.extend([
                Contender::AccelGizmos(IndexChoice::Bvh),
                Contender::AccelOverlaysOff(IndexChoice::Bvh),
            ]);
        }
        if panel_closed {
            contenders.extend([
                Contender::AccelEgui(IndexChoice::Bvh),
                Contender::AccelPanelClosed(IndexChoice::Bvh),
            ]);
        }
        let timed = measure(scene, &contenders, sizes.warm_up, size.frames);
        let (floor, bevy) = (timed[0].frame, timed[1].frame);
        let bevy_share = timed[1].visible_pct.unwrap_or(0.0);
        // What each pays over the floor; a microsecond at least, so that a contender level
        // with the floor gives a large ratio rather than a division by zero.
        let over = |t: f64| (t - floor).max(1e-3);
        for (&c, t) in contenders.iter().zip(&timed) {
            let share_error = t.visible_pct.map(|share| (share - bevy_share).abs());
            points.push(point(
                &name,
                &c.label(),
                "",
                ("ms per frame", t.frame),
                ("visible share off Bevy's, points", share_error),
            ));
            // A row for every accel app, and for Bevy against itself (the ratios' noise).
            if !(c.is_accel() || c == Contender::BevyAgain) {
                continue;
            }
            let (whole, over_floor) = (bevy / t.frame, over(bevy) / over(t.frame));
            markdown.push(format!(
                "| {layout:?} | {n} | {pct}% | {camera:?} | {bevy_share:.1}% / {:.1}% | {:.2} ms | \
                 {:.2} ms | {} | {:.2} ms | {whole:.2}x | {over_floor:.2}x |",
                t.visible_pct.unwrap_or(0.0),
                floor,
                bevy,
                c.label(),
                t.frame,
            ));
            let Some([sync, maintain, culling]) = t.parts else {
                continue;
            };
            let aside = match t.aside {
                Some((share, probe)) if share > 0.0 || probe.is_some() => format!(
                    "; aside {:.0}% of frames{}",
                    share * 100.0,
                    probe.map_or(String::new(), |p| format!(
                        " (last probe: trees {:.3} ms, Bevy {:.3} ms)",
                        ms(p.trees),
                        ms(p.bevy)
                    ))
                ),
                _ => String::new(),
            };
            let unwritten = match t.unwritten {
                Some(share) if share > 0.0 => {
                    format!("; busy movers unwritten {:.0}% of frames", share * 100.0)
                }
                _ => String::new(),
            };
            notes.push(format!(
                "{name}, {} (on {:?}): bevy/accel {whole:.2}x whole frame, {over_floor:.2}x \
                 over the floor; sync {:.2} ms, maintenance {:.2} ms, culling {:.2} ms \
                 (medians){aside}{unwritten}",
                c.label(),
                t.index.unwrap_or_default(),
                sync,
                maintain,
                culling
            ));
        }
    }
    progress.step("done");
    progress.finish();
    // Every app of the process shares Bevy's pools, made by the first one.
    if let Some(pool) = bevy::tasks::ComputeTaskPool::try_get() {
        notes.insert(
            0,
            format!("compute threads (every app): {}", pool.thread_num()),
        );
    }
    Report {
        suite: "frame".into(),
        quick,
        points,
        markdown,
        notes,
        ..Report::default()
    }
}
