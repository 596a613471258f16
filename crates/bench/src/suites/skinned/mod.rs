//! Skinned picking (issue 73): picking animated characters at their posed vertices, in
//! headless Bevy apps updated in turn frame by frame, each `App::update` timed whole, the
//! cast of the pointer ray timed alone (`Instant` around the call, in the casting system).
//!
//! Scenes: 100 and 1,000 of the test kit's walking characters (about 5k and 20k triangles)
//! on a grid 2.5 m apart, every joint of every character posed every frame
//! by a system in `Update` writing `walk_pose(t + phase)` into the joints' `Transform`s (a
//! phase per character). The characters' `Aabb` is the bind pose's, as for a mesh built in
//! code; one more scene gives them Bevy's `DynamicSkinnedMeshBounds` (what Bevy's glTF loader
//! gives skinned meshes by default), whose `Aabb` follows the pose.
//!
//! Contenders, one app each over the very same crowd:
//! - *frame, no rays*: `AccelPlugin` + `AccelPickingPlugin` against the same app without
//!   `AccelPickingPlugin` (skinned picking off), and plain Bevy without bevy_accel;
//! - *one pointer ray a frame*, cast in `PreUpdate` as the picking backends cast (the joints
//!   of the last frame, propagated), from a camera above the grid's front edge towards a
//!   random character's torso (seeded; the same ray in every app at every frame), nearest
//!   hit, `RayCastVisibility::Any`: `AccelRayCast::cast_ray` with the plugins; Bevy's
//!   `MeshRayCast::cast_ray` in plain Bevy, which tests the bind pose (a reference for time,
//!   not for answers); and the *baking* peer in plain Bevy, Bevy PR 23583's path written
//!   here: Bevy's broad phase on each entity's `Aabb`, then per candidate a new posed `Mesh`
//!   (positions and normals skinned on the CPU, as the PR's `skin_mesh_entity`) and Bevy's
//!   public `ray_mesh_intersection` over it, as `MeshRayCast` runs over any mesh.
//!
//! Figures are medians over the frames; ratios are medians of per-frame ratios (the apps of
//! one frame ran back to back, under the same load). The peers' first hits are compared with
//! ours (which the `skinned_picking` test holds to a brute force over the posed triangles):
//! where Bevy's `Aabb` is the bind pose's, both peers' broad phases may miss a posed limb.
//! After the timed frames, the app of ours runs a few frames casting a ray that reaches no
//! character before the pointer ray, and the pointer ray twice, to see where a pick's time
//! goes: reading every character's joints (at the first ray of a system run), refitting the
//! hit characters' posed trees, and the walk.

mod parts;
mod scene;

use super::point;
use crate::json::{Point, Report};
use crate::progress::Progress;
use crate::timing::median;
use bevy::prelude::App;
use scene::{Breakdown, Contender, Picks, Scene, build_app, character_of};
use std::time::Instant;

/// One scene and its frame counts.
#[derive(Clone, Copy)]
struct Size {
    scene: Scene,
    warm_up: usize,
    frames: usize,
    /// Frames of ours with the breakdown casts, after the timed ones.
    breakdown: usize,
    /// Whether to time the steps of a pick on one character alone (once per character
    /// mesh).
    parts: bool,
}

const fn size(characters: usize, triangles: u32, dynamic_bounds: bool, frames: usize) -> Size {
    Size {
        scene: Scene {
            characters,
            triangles,
            dynamic_bounds,
        },
        warm_up: 30,
        frames,
        breakdown: 30,
        parts: !dynamic_bounds && characters == 100,
    }
}

const FULL: &[Size] = &[
    size(100, 5_000, false, 300),
    size(1_000, 5_000, false, 150),
    size(100, 20_000, false, 300),
    size(1_000, 20_000, false, 150),
    size(100, 5_000, true, 300),
    size(1_000, 5_000, true, 150),
    size(100, 20_000, true, 300),
    size(1_000, 20_000, true, 150),
];

const QUICK: &[Size] = &[Size {
    warm_up: 5,
    breakdown: 5,
    ..size(100, 5_000, false, 30)
}];

/// What one app's measured frames gave.
struct Timed {
    /// Milliseconds per `App::update`, one per frame.
    frames: Vec<f64>,
    /// The casts (empty for the apps that cast none).
    picks: Picks,
}

/// Runs every contender of `size` in turn, frame by frame; then the breakdown frames of ours.
/// The timed apps, the breakdown of ours, the median first pick of a character, the
/// character's triangles.
fn measure(size: Size, progress: &mut Progress) -> (Vec<Timed>, Vec<[f64; 3]>, f64, usize) {
    let c = character_of(size.scene.triangles);
    let triangles = c.triangle_count();
    // The warm-up's first frames cast at every character in turn (see `scene::pointer_rays`).
    let warm_up = size.scene.characters + size.warm_up;
    let total = 1 + warm_up + size.frames + size.breakdown;
    let mut apps: Vec<App> = Contender::ALL
        .iter()
        .map(|&contender| build_app(contender, size.scene, &c, total))
        .collect();
    progress.step(&format!("{} warm-up", size.scene.name(triangles)));
    for _ in 0..warm_up {
        for app in &mut apps {
            app.update();
        }
    }
    let ours = Contender::ALL
        .iter()
        .position(|&c| c == Contender::Ours)
        .expect("ours is a contender");
    // The casts of the warm-up's turn through the characters (the first frame's excepted:
    // its joints were not propagated yet), each the first to reach its character.
    let first_picks = {
        let us = &apps[ours].world().resource::<Picks>().us;
        median(us[1.min(us.len())..(size.scene.characters + 1).min(us.len())].to_vec())
    };
    for app in &mut apps {
        app.world_mut().resource_mut::<Picks>().clear();
    }
    progress.step(&format!("{} timed", size.scene.name(triangles)));
    let mut frames = vec![Vec::with_capacity(size.frames); apps.len()];
    for _ in 0..size.frames {
        for (app, t) in apps.iter_mut().zip(&mut frames) {
            let start = Instant::now();
            app.update();
            t.push(start.elapsed().as_secs_f64() * 1e3);
        }
    }
    apps[ours].insert_resource(Breakdown(true));
    for _ in 0..size.breakdown {
        apps[ours].update();
    }
    let breakdown = std::mem::take(&mut apps[ours].world_mut().resource_mut::<Picks>().breakdown);
    let timed = apps
        .iter_mut()
        .zip(frames)
        .map(|(app, frames)| Timed {
            frames,
            picks: std::mem::take(&mut *app.world_mut().resource_mut::<Picks>()),
        })
        .collect();
    (timed, breakdown, first_picks, triangles)
}

/// The median of per-frame ratios `a[i] / b[i]`, and their range.
fn ratio(a: &[f64], b: &[f64]) -> (f64, f64, f64) {
    let ratios: Vec<f64> = a.iter().zip(b).map(|(a, b)| a / b.max(1e-9)).collect();
    let (lo, hi) = ratios.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), &r| {
        (lo.min(r), hi.max(r))
    });
    (median(ratios), lo, hi)
}

/// Percent of the frames where `theirs` hit the same character first as `ours` (or both
/// nothing), and where it also hit it at the same distance (within a millimetre: the same
/// point of the posed surface).
fn agreement(theirs: &[Option<(u32, f32)>], ours: &[Option<(u32, f32)>]) -> (f64, f64) {
    let (mut character, mut point) = (0, 0);
    for (a, b) in theirs.iter().zip(ours) {
        match (a, b) {
            (None, None) => (character, point) = (character + 1, point + 1),
            (Some((a, da)), Some((b, db))) if a == b => {
                character += 1;
                point += usize::from((da - db).abs() <= 1e-3);
            }
            _ => {}
        }
    }
    let pct = |k: usize| 100.0 * k as f64 / ours.len().max(1) as f64;
    (pct(character), pct(point))
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let sizes = if quick { QUICK } else { FULL };
    let mut progress = Progress::new("skinned", 2 * sizes.len() + 1);
    let mut points: Vec<Point> = Vec::new();
    let mut notes = Vec::new();
    let mut markdown = vec![
        "| characters | triangles | Bevy's `Aabb` | frame, no rays: picking on / off (on/off) | \
         plain Bevy | per pick: ours | MeshRayCast | baking | MeshRayCast/ours | baking/ours | \
         frame with the ray: ours / MeshRayCast / baking | first hit as ours (character; point): \
         MeshRayCast / baking |"
            .to_string(),
        "|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---|---|".to_string(),
    ];
    let index = |c: Contender| {
        Contender::ALL
            .iter()
            .position(|&x| x == c)
            .expect("every contender has an app")
    };
    for &size in sizes {
        let (timed, breakdown, first_picks, triangles) = measure(size, &mut progress);
        let scene = size.scene;
        let name = scene.name(triangles);
        let of = |c: Contender| &timed[index(c)];
        let frame = |c: Contender| median(of(c).frames.clone());
        let pick = |c: Contender| median(of(c).picks.us.clone());
        let ours_hits = &of(Contender::Ours).picks.hits;
        for &c in &Contender::ALL {
            points.push(point(
                &name,
                c.label(),
                if c.casts() {
                    "one ray a frame"
                } else {
                    "no ray"
                },
                ("ms per frame", frame(c)),
                ("", None),
            ));
            if c.casts() {
                let off = 100.0 - agreement(&of(c).picks.hits, ours_hits).0;
                points.push(point(
                    &name,
                    c.label(),
                    "",
                    ("us per pick", pick(c)),
                    ("first hit off ours, % of rays", Some(off)),
                ));
            }
        }
        let (on_off, on_off_lo, on_off_hi) = ratio(
            &of(Contender::Picking).frames,
            &of(Contender::PickingOff).frames,
        );
        let ours_us = &of(Contender::Ours).picks.us;
        let (bevy_ours, bevy_lo, bevy_hi) = ratio(&of(Contender::Bevy).picks.us, ours_us);
        let (bake_ours, bake_lo, bake_hi) = ratio(&of(Contender::Baking).picks.us, ours_us);
        let (bevy_agree, bevy_point) = agreement(&of(Contender::Bevy).picks.hits, ours_hits);
        let (bake_agree, bake_point) = agreement(&of(Contender::Baking).picks.hits, ours_hits);
        markdown.push(format!(
            "| {} | {triangles} | {} | {:.2} / {:.2} ms ({on_off:.2}x) | {:.2} ms | {:.0} us | \
             {:.0} us | {:.0} us | {bevy_ours:.2}x | {bake_ours:.1}x | {:.2} / {:.2} / {:.2} ms | \
             {bevy_agree:.0}% / {bake_agree:.0}%; {bevy_point:.0}% / {bake_point:.0}% |",
            scene.characters,
            if scene.dynamic_bounds {
                "posed"
            } else {
                "bind pose"
            },
            frame(Contender::Picking),
            frame(Contender::PickingOff),
            frame(Contender::Plain),
            pick(Contender::Ours),
            pick(Contender::Bevy),
            pick(Contender::Baking),
            frame(Contender::Ours),
            frame(Contender::Bevy),
            frame(Contender::Baking),
        ));
        notes.push(format!(
            "{name}: frame with skinned picking on / off, no rays: {on_off:.3}x (per frame \
             {on_off_lo:.2}x-{on_off_hi:.2}x, {} frames)",
            of(Contender::Picking).frames.len()
        ));
        notes.push(format!(
            "{name}: per pick MeshRayCast/ours {bevy_ours:.2}x (per frame \
             {bevy_lo:.2}x-{bevy_hi:.2}x), baking/ours {bake_ours:.1}x (per frame \
             {bake_lo:.1}x-{bake_hi:.1}x)"
        ));
        let hit_share = 100.0 * ours_hits.iter().filter(|h| h.is_some()).count() as f64
            / ours_hits.len().max(1) as f64;
        let refits = &of(Contender::Ours).picks.refits;
        notes.push(format!(
            "{name}: ours hit a character on {hit_share:.0}% of the rays, refitting {:.2} \
             posed trees a pick (mean); first hit on the same character as ours: MeshRayCast \
             {bevy_agree:.0}%, baking {bake_agree:.0}%; at the same point (within 1 mm): \
             MeshRayCast {bevy_point:.0}%, baking {bake_point:.0}%; the first pick of a character (building its posed \
             tree, in the warm-up) {first_picks:.0} us",
            refits.iter().sum::<usize>() as f64 / refits.len().max(1) as f64
        ));
        if size.parts {
            notes.push(parts::note(&name, &character_of(scene.triangles), 200));
        }
        if !breakdown.is_empty() {
            let part = |k: usize| median(breakdown.iter().map(|b| b[k]).collect());
            notes.push(format!(
                "{name}: where a pick of ours goes (medians over {} frames): a first ray that \
                 reaches no character (reading every character's joints) {:.0} us, then the \
                 pointer ray (refit of the characters it reaches and the walk) {:.0} us, then \
                 the same ray again (the walk alone) {:.0} us",
                breakdown.len(),
                part(0),
                part(1),
                part(2)
            ));
        }
    }
    progress.step("done");
    progress.finish();
    if let Some(pool) = bevy::tasks::ComputeTaskPool::try_get() {
        notes.insert(
            0,
            format!("compute threads (every app): {}", pool.thread_num()),
        );
    }
    Report {
        suite: "skinned".into(),
        quick,
        points,
        markdown,
        notes,
        ..Report::default()
    }
}
