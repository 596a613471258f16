//! The preview suite's scene (about 100k triangles: bunny copies, spheres and boxes on a
//! ground quad, two lights), its tracers, and the threaded tile loop the suite times.

use accel_testkit::shapes::{cube, icosphere};
use accel_testkit::{Rng, bunny};
use glam::{Affine3A, Mat4, Quat, Vec3};
use spatial_accel::mesh::MeshBvh;
use spatial_accel::preview::{
    MeshSurface, PreviewCamera, PreviewImage, PreviewInstance, PreviewLight, PreviewMaterial,
    PreviewMode, PreviewScene, PreviewTracer,
};
use std::sync::Arc;
use std::time::Instant;

/// 25 bunnies in a jittered grid, 6 icospheres, 12 boxes and a ground.
pub fn instances() -> Vec<PreviewInstance> {
    let surface = |m: accel_testkit::Mesh| {
        let s = Arc::new(MeshSurface::new(m.positions(), m.flat_indices()).with_smooth_normals());
        (
            Arc::new(s.build_bvh().expect("the test meshes are valid")),
            s,
        )
    };
    let b = bunny().normalized(2.0);
    let floor = b.vertices.iter().map(|v| v.y).fold(f32::INFINITY, f32::min);
    let (bunny, sphere, cube) = (surface(b), surface(icosphere(3)), surface(cube()));
    let quad = accel_testkit::Mesh {
        vertices: [(-40.0, 40.0), (40.0, 40.0), (40.0, -40.0), (-40.0, -40.0)]
            .map(|(x, z)| glam::Vec3A::new(x, 0.0, z))
            .to_vec(),
        indices: vec![[0, 1, 2], [0, 2, 3]],
    };
    let ground = surface(quad);
    let mut rng = Rng::new(5);
    let place = |(mesh, surface): &(Arc<MeshBvh>, Arc<MeshSurface>), m: Affine3A, material: u32| {
        PreviewInstance {
            mesh: mesh.clone(),
            surface: surface.clone(),
            world_from_local: m,
            material,
        }
    };
    let mut out = vec![place(&ground, Affine3A::IDENTITY, 0)];
    for i in 0..25 {
        let (gx, gz) = ((i % 5) as f32 - 2.0, (i / 5) as f32 - 2.0);
        let s = rng.range(0.8, 1.6);
        let at = Vec3::new(
            gx * 4.0 + rng.range(-0.8, 0.8),
            -floor * s,
            gz * 4.0 + rng.range(-0.8, 0.8),
        );
        let turn = Quat::from_rotation_y(rng.range(0.0, core::f32::consts::TAU));
        out.push(place(
            &bunny,
            Affine3A::from_scale_rotation_translation(Vec3::splat(s), turn, at),
            1,
        ));
    }
    for i in 0..6 {
        let r = rng.range(0.4, 0.9);
        let at = Vec3::new(rng.range(-10.0, 10.0), r + 0.01, rng.range(-10.0, 10.0));
        out.push(place(
            &sphere,
            Affine3A::from_scale_rotation_translation(Vec3::splat(r), Quat::IDENTITY, at),
            2 + i % 2,
        ));
    }
    for _ in 0..12 {
        let h = rng.range(0.3, 0.8);
        let at = Vec3::new(rng.range(-11.0, 11.0), h + 0.01, rng.range(-11.0, 11.0));
        let turn = Quat::from_rotation_y(rng.range(0.0, 3.0));
        out.push(place(
            &cube,
            Affine3A::from_scale_rotation_translation(Vec3::splat(h), turn, at),
            3,
        ));
    }
    out
}

/// The view over the scene, its materials and its two lights (a sun and a point light).
pub fn tracer(mode: PreviewMode, (w, h): (u32, u32)) -> PreviewTracer {
    let eye = Vec3::new(3.0, 7.0, 16.0);
    let view = Mat4::look_at_rh(eye, Vec3::new(0.0, 0.5, 0.0), Vec3::Y);
    let proj = Mat4::perspective_infinite_reverse_rh(0.9, w as f32 / h as f32, 0.1);
    let mut t = PreviewTracer::new(PreviewCamera::new((proj * view).inverse(), eye), mode);
    t.materials = vec![
        PreviewMaterial::diffuse(Vec3::splat(0.7)),
        PreviewMaterial::diffuse(Vec3::new(0.8, 0.75, 0.7)),
        PreviewMaterial::diffuse(Vec3::new(0.8, 0.2, 0.15)),
        PreviewMaterial::diffuse(Vec3::new(0.2, 0.3, 0.8)),
    ];
    t.lights = vec![
        PreviewLight::Directional {
            direction: Vec3::new(-0.4, -1.0, -0.3),
            illuminance: Vec3::splat(2.5),
        },
        PreviewLight::Point {
            position: Vec3::new(0.0, 4.0, 3.0),
            intensity: Vec3::splat(30.0),
            range: 40.0,
        },
    ];
    t.settings.ambient = Vec3::splat(0.08);
    t
}

/// One sample of every pixel of `image` on `threads` threads, 4-row tiles dealt round-robin
/// (the plugin deals its tiles to Bevy's compute pool the same way). Returns each thread's
/// busy seconds: threads that end far apart mean an uneven deal, threads each slower than
/// one alone mean the machine (shared caches, shared cores).
pub fn trace_parallel(
    t: &PreviewTracer,
    scene: &dyn PreviewScene,
    image: &mut PreviewImage,
    threads: usize,
) -> Vec<f64> {
    let height = image.height();
    let mut shares: Vec<Vec<_>> = (0..threads.max(1)).map(|_| Vec::new()).collect();
    let count = shares.len();
    for (i, tile) in image.tiles(0..height, 4).into_iter().enumerate() {
        shares[i % count].push(tile);
    }
    std::thread::scope(|s| {
        let workers: Vec<_> = shares
            .into_iter()
            .map(|share| {
                s.spawn(move || {
                    let start = Instant::now();
                    for mut tile in share {
                        t.trace_tile(scene, &mut tile);
                    }
                    start.elapsed().as_secs_f64()
                })
            })
            .collect();
        workers
            .into_iter()
            .map(|w| w.join().expect("a tracing thread panicked"))
            .collect()
    })
}

/// Root mean square difference of two images' accumulated means, over every channel.
pub fn rmse(a: &PreviewImage, b: &PreviewImage) -> f64 {
    let mut sum = 0.0f64;
    for y in 0..a.height() {
        for x in 0..a.width() {
            let (p, q) = (a.mean(x, y), b.mean(x, y));
            let d = p
                .zip(q)
                .map_or(f32::INFINITY, |(p, q)| (p - q).length_squared());
            sum += f64::from(d);
        }
    }
    (sum / f64::from(3 * a.width() * a.height())).sqrt()
}
