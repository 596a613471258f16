//! `AccelSelection` against the projection brute force while the scene changes under it: a
//! third of the entities moving every frame (so that they become busy movers, outside the
//! dynamic index), and every few frames some leaving and new ones taking their slots, so that
//! slots no longer follow the order of entities.

use accel_testkit::Rng;
use bevy::math::DAffine3;
use bevy::prelude::*;
use bevy_accel::prelude::*;

mod common;
mod selection_oracle;
use selection_oracle::scene::{
    MODES, Rule, app, expected, populate, random_rect, rect_screens, select_in_rect, spawn_camera,
};

#[test]
fn rectangles_stay_exact_while_entities_move_leave_and_come() {
    let mut rng = Rng::from_state(31);
    let mut app = app();
    let mut scene = populate(&mut app, &mut rng, 400);
    let (camera, clip_from_world) = spawn_camera(&mut app, &mut rng, false);
    app.update();
    let (mut compared, mut selected, mut busy_seen, mut replaced) = (0usize, 0usize, 0usize, 0);
    for frame in 0..24 {
        for e in scene.iter_mut().step_by(3) {
            let mut transform = *app.world().get::<Transform>(e.entity).unwrap();
            transform.translation += rng.vec3(-1.5, 1.5);
            app.world_mut().entity_mut(e.entity).insert(transform);
            let affine = transform.compute_affine();
            e.affine = DAffine3 {
                matrix3: affine.matrix3.as_dmat3(),
                translation: affine.translation.as_dvec3(),
            };
        }
        if frame % 4 == 3 {
            for _ in 0..20 {
                let gone = scene.swap_remove(rng.below(scene.len()));
                app.world_mut().despawn(gone.entity);
            }
            scene.extend(populate(&mut app, &mut rng, 20));
            replaced += 20;
        }
        app.update();
        busy_seen = busy_seen.max(app.world().resource::<AccelStats>().busy_movers);
        let cam = app.world().get::<Camera>(camera).unwrap().clone();
        let viewport = cam.logical_viewport_rect().unwrap();
        for round in 0..6 {
            let rect = random_rect(&mut rng, viewport);
            let mode = MODES[round % 3];
            let found = select_in_rect(&mut app, camera, rect, mode);
            assert!(found.is_sorted(), "frame {frame}: not sorted by entity");
            let Some(screens) = rect_screens(&cam, clip_from_world, rect) else {
                assert!(
                    found.is_empty(),
                    "frame {frame}: off the viewport {found:?}"
                );
                continue;
            };
            for e in &scene {
                let got = found.binary_search(&e.entity).is_ok();
                let want = if e.rule == Rule::Allowed {
                    expected(e, mode, &screens)
                } else {
                    Some(false)
                };
                if let Some(want) = want {
                    compared += 1;
                    selected += usize::from(want);
                    assert_eq!(
                        got, want,
                        "frame {frame} round {round} {mode:?}: {} ({:?})",
                        e.entity, e.rule
                    );
                }
            }
            // Nothing that left is found.
            assert_eq!(
                found
                    .iter()
                    .filter(|f| !scene.iter().any(|e| e.entity == **f))
                    .count(),
                0,
                "frame {frame}: a despawned entity selected"
            );
        }
    }
    // The scene went through what the test is about: busy movers, reused slots, and
    // verdicts with weight both ways.
    assert!(busy_seen > 50, "{busy_seen} busy movers");
    assert_eq!(replaced, 120);
    assert!(compared > 30_000, "{compared} compared");
    assert!(
        selected > compared / 20,
        "{selected} of {compared} selected"
    );
}
