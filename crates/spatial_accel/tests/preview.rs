//! The preview tracer: tree-traced images against brute force, convergence of the
//! progressive views, shadows, robustness to broken input, determinism across row splits,
//! and a stored reference image.

use accel_testkit::bunny;
use accel_testkit::shapes::cube;
use glam::{Affine3A, Mat4, Quat, Vec2, Vec3, Vec3A};
use spatial_accel::preview::{
    BruteForcePreviewScene, IndexedPreviewScene, InstancedPreviewScene, MeshSurface, PreviewCamera,
    PreviewImage, PreviewInstance, PreviewLight, PreviewMaterial, PreviewMode, PreviewScene,
    PreviewTracer, Texture, TextureFilter,
};
use spatial_accel::query::{AnyIndex, IndexKind};
use std::path::PathBuf;
use std::sync::Arc;

/// The ground: a 20 x 20 quad at y = 0 facing up, with texture coordinates repeating every
/// 4 units.
fn ground() -> MeshSurface {
    let corners = [(-10.0, 10.0), (10.0, 10.0), (10.0, -10.0), (-10.0, -10.0)];
    let mut surface = MeshSurface::new(
        corners.iter().map(|&(x, z)| Vec3::new(x, 0.0, z)).collect(),
        vec![0, 1, 2, 0, 2, 3],
    );
    surface.uvs = Some(
        corners
            .iter()
            .map(|&(x, z)| Vec2::new(x, z) / 4.0)
            .collect(),
    );
    surface
}

fn instance(
    surface: &Arc<MeshSurface>,
    world_from_local: Affine3A,
    material: u32,
) -> PreviewInstance {
    PreviewInstance {
        mesh: Arc::new(surface.build_bvh().unwrap()),
        surface: surface.clone(),
        world_from_local,
        material,
    }
}

/// The known scene: a textured ground, the bunny (smooth normals) standing on it, and three
/// boxes floating a little above it (so no box face lies in the ground's plane), one rotated
/// and one emissive.
fn known_scene() -> Vec<PreviewInstance> {
    let ground = Arc::new(ground());
    let bunny_mesh = bunny().normalized(2.0);
    let bunny_floor = bunny_mesh
        .vertices
        .iter()
        .map(|v| v.y)
        .fold(f32::INFINITY, f32::min);
    let bunny = Arc::new(
        MeshSurface::new(bunny_mesh.positions(), bunny_mesh.flat_indices()).with_smooth_normals(),
    );
    let cube_mesh = cube();
    let cube = Arc::new(MeshSurface::new(
        cube_mesh.positions(),
        cube_mesh.flat_indices(),
    ));
    let placed_box = |half: f32, at: Vec3, turn: f32| {
        Affine3A::from_scale_rotation_translation(
            Vec3::splat(half),
            Quat::from_rotation_y(turn),
            at + Vec3::Y * (half + 0.02),
        )
    };
    vec![
        instance(&ground, Affine3A::IDENTITY, 0),
        instance(
            &bunny,
            Affine3A::from_translation(Vec3::new(0.0, -bunny_floor, 0.0)),
            1,
        ),
        instance(&cube, placed_box(0.5, Vec3::new(-2.5, 0.0, 0.0), 0.0), 2),
        instance(&cube, placed_box(0.75, Vec3::new(2.6, 0.0, -1.0), 0.6), 3),
        instance(&cube, placed_box(0.3, Vec3::new(1.2, 0.0, 2.0), 1.1), 4),
    ]
}

fn checker() -> Arc<Texture> {
    let (dark, light) = ([60, 60, 70, 255], [200, 200, 190, 255]);
    Arc::new(Texture::new(2, 2, vec![dark, light, light, dark], TextureFilter::Nearest).unwrap())
}

fn camera(eye: Vec3, target: Vec3, aspect: f32) -> PreviewCamera {
    let view = Mat4::look_at_rh(eye, target, Vec3::Y);
    let clip_from_view = Mat4::perspective_infinite_reverse_rh(0.9, aspect, 0.1);
    PreviewCamera::new((clip_from_view * view).inverse(), eye)
}

/// The known scene's view, lights and materials, in `mode`, for a `w` x `h` image.
fn tracer(mode: PreviewMode, (w, h): (u32, u32)) -> PreviewTracer {
    let mut t = PreviewTracer::new(
        camera(
            Vec3::new(1.0, 3.0, 7.5),
            Vec3::new(0.0, 0.6, 0.0),
            w as f32 / h as f32,
        ),
        mode,
    );
    t.materials = vec![
        PreviewMaterial {
            base_color: Vec3::splat(0.9),
            base_color_texture: Some(checker()),
            emissive: Vec3::ZERO,
        },
        PreviewMaterial::diffuse(Vec3::new(0.8, 0.75, 0.7)),
        PreviewMaterial::diffuse(Vec3::new(0.8, 0.2, 0.15)),
        PreviewMaterial::diffuse(Vec3::new(0.2, 0.3, 0.8)),
        PreviewMaterial {
            emissive: Vec3::new(0.2, 1.5, 0.3),
            ..PreviewMaterial::diffuse(Vec3::splat(0.3))
        },
    ];
    t.lights = vec![
        PreviewLight::Directional {
            direction: Vec3::new(-0.4, -1.0, -0.3),
            illuminance: Vec3::new(2.5, 2.4, 2.2),
        },
        PreviewLight::Point {
            position: Vec3::new(0.5, 2.5, 2.0),
            intensity: Vec3::splat(6.0),
            range: 20.0,
        },
        PreviewLight::Spot {
            position: Vec3::new(-3.0, 4.0, 2.5),
            direction: Vec3::new(0.5, -4.0, -2.5),
            intensity: Vec3::new(30.0, 20.0, 10.0),
            range: 30.0,
            inner_angle: 0.25,
            outer_angle: 0.45,
        },
    ];
    t.settings.ambient = Vec3::splat(0.08);
    t.settings.background = Vec3::new(0.05, 0.07, 0.1);
    t
}

/// One sample of every pixel.
fn trace<S: PreviewScene + ?Sized>(
    t: &PreviewTracer,
    scene: &S,
    size: (u32, u32),
    sample: u32,
) -> Vec<Vec3> {
    let mut out = vec![Vec3::ZERO; (size.0 * size.1) as usize];
    t.trace_rows(scene, size, 0..size.1, sample, &mut out);
    out
}

/// `samples` samples of every pixel accumulated, tiles of `rows_per_tile` rows.
fn accumulate<S: PreviewScene + ?Sized>(
    t: &PreviewTracer,
    scene: &S,
    size: (u32, u32),
    samples: u32,
    rows_per_tile: u32,
) -> PreviewImage {
    let mut image = PreviewImage::new(size.0, size.1);
    for _ in 0..samples {
        for mut tile in image.tiles(0..size.1, rows_per_tile) {
            t.trace_tile(scene, &mut tile);
        }
    }
    image
}

fn rmse(a: &PreviewImage, b: &PreviewImage) -> f64 {
    let mut sum = 0.0f64;
    let mut n = 0u32;
    for y in 0..a.height() {
        for x in 0..a.width() {
            let d = a.mean(x, y).unwrap() - b.mean(x, y).unwrap();
            sum += f64::from(d.length_squared());
            n += 3;
        }
    }
    (sum / f64::from(n)).sqrt()
}

#[test]
fn object_ids_match_brute_force_at_every_pixel() {
    let instances = known_scene();
    let (tree, brute) = (
        InstancedPreviewScene::new(&instances),
        BruteForcePreviewScene::new(&instances),
    );
    let size = (96, 54);
    let t = tracer(PreviewMode::ObjectIds, size);
    let mut seen = std::collections::BTreeSet::new();
    let (mut differing, mut misses) = (0, 0);
    for sample in 0..3 {
        for y in 0..size.1 {
            for x in 0..size.0 {
                let pixel = Vec2::new(x as f32, y as f32)
                    + spatial_accel::preview::rng::pixel_jitter(sample);
                let ray = t.camera.pixel_ray(pixel, size.0, size.1);
                let got = tree.closest(&ray);
                let want = brute.closest(&ray);
                differing += usize::from(got.map(|h| h.object) != want.map(|h| h.object));
                assert_eq!(got.map(|h| h.t), want.map(|h| h.t));
                // The counted walk finds the same hit as the fast one.
                assert_eq!(tree.closest_counted(&ray).hit, got);
                if let Some(h) = got {
                    seen.insert(h.object);
                } else {
                    misses += 1;
                }
            }
        }
    }
    assert_eq!(differing, 0);
    // The view holds every object and some sky: the comparison covered all of them.
    assert_eq!(seen.into_iter().collect::<Vec<_>>(), vec![0, 1, 2, 3, 4]);
    assert!(misses > 0);
    // And the id view itself is the same image.
    assert_eq!(trace(&t, &tree, size, 0), trace(&t, &brute, size, 0));
}

#[test]
fn shaded_and_path_traced_images_equal_brute_force() {
    let instances = known_scene();
    let (tree, brute) = (
        InstancedPreviewScene::new(&instances),
        BruteForcePreviewScene::new(&instances),
    );
    let size = (64, 36);
    for mode in [
        PreviewMode::Shaded,
        PreviewMode::PathTraced { max_bounces: 1 },
        PreviewMode::Normals,
    ] {
        let t = tracer(mode, size);
        for sample in [0, 5] {
            let (a, b) = (
                trace(&t, &tree, size, sample),
                trace(&t, &brute, size, sample),
            );
            let differing = a.iter().zip(&b).filter(|(p, q)| p != q).count();
            assert_eq!(differing, 0, "{mode:?}, sample {sample}");
            // Not a blank image: lit, shadowed and sky pixels all differ.
            let distinct: std::collections::BTreeSet<[u32; 3]> =
                a.iter().map(|c| c.to_array().map(f32::to_bits)).collect();
            assert!(
                distinct.len() > 50,
                "{mode:?}: {} distinct values",
                distinct.len()
            );
        }
    }
}

/// The scene over each dynamic index as its top level traces the brute-force image, pixel
/// for pixel (shaded: shadow rays through the index too), and finds the same closest hits.
#[test]
fn every_index_choice_traces_the_brute_force_image() {
    let mut instances = known_scene();
    // One that cannot be inverted: every scene leaves it out.
    instances.push(PreviewInstance {
        world_from_local: Affine3A::from_scale(Vec3::new(1.0, 0.0, 1.0)),
        ..instances[1].clone()
    });
    let brute = BruteForcePreviewScene::new(&instances);
    let size = (64, 36);
    let ids = tracer(PreviewMode::ObjectIds, size);
    let shaded = tracer(PreviewMode::Shaded, size);
    let want_ids = trace(&ids, &brute, size, 0);
    let want_shaded = trace(&shaded, &brute, size, 1);
    for kind in IndexKind::ALL {
        let scene = IndexedPreviewScene::new(AnyIndex::new(kind), &instances).unwrap();
        assert_eq!(trace(&ids, &scene, size, 0), want_ids, "{kind:?}");
        assert_eq!(trace(&shaded, &scene, size, 1), want_shaded, "{kind:?}");
        for y in (0..size.1).step_by(3) {
            for x in (0..size.0).step_by(3) {
                let ray = ids
                    .camera
                    .pixel_ray(Vec2::new(x as f32, y as f32), size.0, size.1);
                let got = scene.closest(&ray);
                assert_eq!(
                    got.map(|h| h.t),
                    brute.closest(&ray).map(|h| h.t),
                    "{kind:?}"
                );
                assert_eq!(scene.closest_counted(&ray).hit, got, "{kind:?}");
            }
        }
    }
}

#[test]
fn progressive_ambient_occlusion_converges_and_restarts() {
    let scene = InstancedPreviewScene::new(&known_scene());
    let size = (48, 27);
    let mode = PreviewMode::AmbientOcclusion {
        samples: 1,
        radius: 1.5,
    };
    let mut reference_tracer = tracer(mode, size);
    // Another seed: the reference's noise is independent of the images measured against it.
    reference_tracer.settings.seed = 99;
    let reference = accumulate(&reference_tracer, &scene, size, 256, 9);
    let t = tracer(mode, size);
    let mut image = PreviewImage::new(size.0, size.1);
    let mut errors = Vec::new();
    let mut done = 0;
    for target in [1, 4, 16, 64] {
        while done < target {
            for mut tile in image.tiles(0..size.1, 8) {
                t.trace_tile(&scene, &mut tile);
            }
            done += 1;
        }
        assert_eq!(image.min_samples(), target);
        errors.push(rmse(&image, &reference));
    }
    assert!(errors.windows(2).all(|w| w[1] < w[0] * 0.8), "{errors:?}");
    // Monte Carlo: 16x the samples, about a quarter of the error.
    assert!(errors[3] < errors[1] * 0.45, "{errors:?}");
    let mut first = Vec::new();
    accumulate(&t, &scene, size, 4, 8).resolve_rgba8(
        spatial_accel::preview::Tonemap::Clamp,
        1.0,
        &mut first,
    );
    image.restart();
    assert_eq!(image.min_samples(), 0);
    let mut bytes = Vec::new();
    image.resolve_rgba8(spatial_accel::preview::Tonemap::Clamp, 1.0, &mut bytes);
    assert!(bytes.iter().all(|&b| b == 0));
    // After a restart the sequence starts over: the same four samples, the same image.
    for _ in 0..4 {
        for mut tile in image.tiles(0..size.1, 5) {
            t.trace_tile(&scene, &mut tile);
        }
    }
    image.resolve_rgba8(spatial_accel::preview::Tonemap::Clamp, 1.0, &mut bytes);
    assert_eq!(bytes, first);
}

/// A camera 0.5 above the ground point `at` looking straight down, and the mean value of
/// its 8 x 8 pixels, each checked to be close to the others.
fn ground_patch(t: &mut PreviewTracer, scene: &dyn PreviewScene, at: Vec3) -> Vec3 {
    let eye = at + Vec3::Y * 0.5;
    let view = Mat4::look_at_rh(eye, at, Vec3::Z);
    let clip_from_view = Mat4::perspective_infinite_reverse_rh(0.2, 1.0, 0.05);
    t.camera = PreviewCamera::new((clip_from_view * view).inverse(), eye);
    let size = (8, 8);
    let values = trace(t, scene, size, 0);
    let mean = values.iter().sum::<Vec3>() / values.len() as f32;
    // Every pixel near the mean (a point light's falloff varies a little over the patch): a
    // speck of self-shadowing (acne) would fall to the ambient term.
    assert!(
        values
            .iter()
            .all(|v| (*v - mean).abs().max_element() <= mean.max_element() * 0.02),
        "{values:?}"
    );
    mean
}

#[test]
fn points_under_an_occluder_are_dark_and_points_beside_it_lit() {
    for offset in [Vec3::ZERO, Vec3::new(1.0e4, 0.0, -7.0e3)] {
        let ground = Arc::new(ground());
        let cube_mesh = cube();
        let cube = Arc::new(MeshSurface::new(
            cube_mesh.positions(),
            cube_mesh.flat_indices(),
        ));
        let instances = vec![
            instance(&ground, Affine3A::from_translation(offset), 0),
            // A 2 x 2 slab from y = 2 to 2.4 above the origin.
            instance(
                &cube,
                Affine3A::from_scale_rotation_translation(
                    Vec3::new(1.0, 0.2, 1.0),
                    Quat::IDENTITY,
                    offset + Vec3::Y * 2.2,
                ),
                0,
            ),
        ];
        let scene = InstancedPreviewScene::new(&instances);
        let albedo = 0.6;
        let mut t = PreviewTracer::new(camera(Vec3::ONE, Vec3::ZERO, 1.0), PreviewMode::Shaded);
        t.materials = vec![PreviewMaterial::diffuse(Vec3::splat(albedo))];
        t.settings.ambient = Vec3::splat(0.1);
        let lights = [
            PreviewLight::Directional {
                direction: Vec3::NEG_Y,
                illuminance: Vec3::splat(3.0),
            },
            PreviewLight::Point {
                position: offset + Vec3::Y * 4.0,
                intensity: Vec3::splat(40.0),
                range: 100.0,
            },
        ];
        for light in lights {
            t.lights = vec![light];
            let ambient = albedo * 0.1;
            let under = ground_patch(&mut t, &scene, offset + Vec3::new(0.1, 0.0, -0.2));
            assert!(
                (under - Vec3::splat(ambient)).abs().max_element() < 1e-6,
                "{light:?} {under}"
            );
            // Clear of the slab's shadow from both lights.
            let clear = offset + Vec3::new(3.0, 0.0, 3.5);
            let beside = ground_patch(&mut t, &scene, clear);
            let lit = light.illuminate(clear.into(), Vec3A::Y).unwrap();
            let expected = ambient + albedo * lit.irradiance.x / core::f32::consts::PI;
            // The patch spans a little of the ground: the light's falloff varies over it.
            assert!(
                (beside.x - expected).abs() < expected * 0.02,
                "{light:?}: {beside} vs {expected}"
            );
            assert!(beside.x > under.x * 2.0);
        }
    }
}

#[test]
fn non_finite_cameras_scenes_lights_and_materials_do_not_panic() {
    let size = (16, 9);
    let mut instances = known_scene();
    // A mesh with NaN corners, and instances under broken transforms.
    let broken = Arc::new(MeshSurface::new(
        vec![Vec3::NAN, Vec3::X, Vec3::INFINITY],
        vec![0, 1, 2],
    ));
    instances.push(instance(&broken, Affine3A::IDENTITY, 7));
    instances.push(instance(
        &instances[1].surface.clone(),
        Affine3A::from_scale(Vec3::ZERO),
        1,
    ));
    instances.push(instance(
        &instances[1].surface.clone(),
        Affine3A::from_translation(Vec3::NAN),
        1,
    ));
    // A surface whose indices name missing vertices and whose normals are too short.
    let mut short = MeshSurface::new(vec![Vec3::ZERO, Vec3::X, Vec3::Z], vec![0, 1, 2]);
    short.normals = Some(vec![Vec3::Y]);
    let bvh = Arc::new(short.build_bvh().unwrap());
    short.indices = vec![0, 1, 9];
    instances.push(PreviewInstance {
        mesh: bvh,
        surface: Arc::new(short),
        world_from_local: Affine3A::from_translation(Vec3::Y),
        material: 3,
    });
    let tree = InstancedPreviewScene::new(&instances);
    let brute = BruteForcePreviewScene::new(&instances);
    let scenes: [&dyn PreviewScene; 2] = [&tree, &brute];
    let modes = [
        PreviewMode::Shaded,
        PreviewMode::AmbientOcclusion {
            samples: 2,
            radius: f32::NAN,
        },
        PreviewMode::PathTraced { max_bounces: 2 },
        PreviewMode::Normals,
        PreviewMode::Depth,
        PreviewMode::TraversalCost,
        PreviewMode::ObjectIds,
        PreviewMode::LeafDepth,
    ];
    let bad = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY];
    for mode in modes {
        for scene in scenes {
            let mut t = tracer(mode, size);
            t.lights.push(PreviewLight::Point {
                position: Vec3::NAN,
                intensity: Vec3::ONE,
                range: 5.0,
            });
            t.lights.push(PreviewLight::Spot {
                position: Vec3::Y,
                direction: Vec3::ZERO,
                intensity: Vec3::INFINITY,
                range: f32::NAN,
                inner_angle: 1.0,
                outer_angle: 0.5,
            });
            t.materials[1].base_color = Vec3::NAN;
            t.materials[2].emissive = Vec3::INFINITY;
            t.settings.depth_scale = 0.0;
            t.settings.cost_scale = f32::NAN;
            let image = accumulate(&t, scene, size, 2, 4);
            let mut bytes = Vec::new();
            t.resolve_rgba8(&image, &mut bytes);
            assert_eq!(bytes.len(), 16 * 9 * 4);
            for y in 0..size.1 {
                for x in 0..size.0 {
                    assert!(image.mean(x, y).unwrap().is_finite());
                }
            }
            for v in bad {
                // A broken camera draws the background.
                t.camera = PreviewCamera::new(Mat4::from_cols_array(&[v; 16]), Vec3::splat(v));
                let values = trace(&t, scene, size, 1);
                let background = if mode == PreviewMode::TraversalCost {
                    values[0]
                } else {
                    t.settings.background
                };
                assert!(values.iter().all(|&c| c == background), "{mode:?}");
            }
        }
    }
    // Empty and zero-sized images, singular cameras.
    let mut t = tracer(PreviewMode::Shaded, size);
    t.camera = PreviewCamera::new(Mat4::ZERO, Vec3::ZERO);
    let mut empty = PreviewImage::new(0, 0);
    assert!(empty.tiles(0..10, 3).is_empty());
    let mut bytes = vec![1, 2, 3];
    t.resolve_rgba8(&empty, &mut bytes);
    assert!(bytes.is_empty());
    assert!(trace(&t, &tree, (0, 5), 0).is_empty());
    assert!(
        trace(&t, &tree, size, 0)
            .iter()
            .all(|&c| c == t.settings.background)
    );
}

#[test]
fn row_splits_and_threads_give_the_same_image() {
    let scene = InstancedPreviewScene::new(&known_scene());
    let size = (40, 23);
    let t = tracer(PreviewMode::PathTraced { max_bounces: 2 }, size);
    let whole = accumulate(&t, &scene, size, 3, size.1);
    let mut want = Vec::new();
    t.resolve_rgba8(&whole, &mut want);
    for (rows_per_tile, threads) in [(1, 1), (5, 2), (7, 3)] {
        let mut image = PreviewImage::new(size.0, size.1);
        for _ in 0..3 {
            let tiles = image.tiles(0..size.1, rows_per_tile);
            let mut shares: Vec<Vec<_>> = (0..threads).map(|_| Vec::new()).collect();
            for (i, tile) in tiles.into_iter().enumerate() {
                shares[i % threads].push(tile);
            }
            std::thread::scope(|s| {
                for share in shares {
                    let (t, scene) = (&t, &scene);
                    s.spawn(move || {
                        for mut tile in share {
                            t.trace_tile(scene, &mut tile);
                        }
                    });
                }
            });
        }
        assert_eq!(
            image, whole,
            "{rows_per_tile} rows a tile on {threads} threads"
        );
    }
    // Rows traced in two passes of a budget's sweep land where one pass would put them.
    let mut swept = PreviewImage::new(size.0, size.1);
    for _ in 0..3 {
        loop {
            let rows = swept.next_rows(6);
            for mut tile in swept.tiles(rows.clone(), 4) {
                t.trace_tile(&scene, &mut tile);
            }
            if rows.end == size.1 {
                break;
            }
        }
    }
    let mut got = Vec::new();
    t.resolve_rgba8(&swept, &mut got);
    assert_eq!(got, want);
}

fn reference_path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/preview_reference.rgba")
}

/// The shaded known scene at 64 x 36, four samples a pixel, against the stored image: mean
/// absolute difference at most 1/255 a channel, none over 8/255 (room for another CPU's
/// `sin` or `powf`, not for a change in the tracer). `ACCEL_BLESS=1` rewrites the file.
#[test]
fn shaded_image_matches_the_stored_reference() {
    let size = (64, 36);
    let t = tracer(PreviewMode::Shaded, size);
    let image = accumulate(&t, &InstancedPreviewScene::new(&known_scene()), size, 4, 12);
    let mut got = Vec::new();
    t.resolve_rgba8(&image, &mut got);
    let path = reference_path();
    if std::env::var("ACCEL_BLESS").is_ok_and(|v| v == "1") {
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(&path, &got).unwrap();
    }
    let want = std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "{} ({e}); run with ACCEL_BLESS=1 to write it",
            path.display()
        )
    });
    assert_eq!(want.len(), got.len());
    let diffs: Vec<u32> = got
        .iter()
        .zip(&want)
        .map(|(&a, &b)| u32::from(a.abs_diff(b)))
        .collect();
    let mean = f64::from(diffs.iter().sum::<u32>()) / diffs.len() as f64;
    let max = diffs.iter().copied().max().unwrap();
    assert!(mean <= 1.0 && max <= 8, "mean {mean}, max {max} (in 1/255)");
    // The image is a picture, not a flat fill.
    let distinct: std::collections::BTreeSet<&[u8]> = got.chunks(4).collect();
    assert!(distinct.len() > 300, "{} distinct colours", distinct.len());
}
