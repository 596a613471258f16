//! The preview tracer on a ~100k-triangle scene (bunny copies, spheres and boxes on a
//! ground quad), a 640 x 360 shaded frame: one primary ray and one shadow ray per light per
//! pixel.
//!
//! Reports (a) the frame time on one thread; (b) the tracer's time over the time of casting
//! the very same rays (recorded from a traced frame) straight through
//! `InstancedScene::cast_ray` and `cast_ray_any`, the cost of everything that is not
//! traversal; (c) the speed-up on two threads (`std::thread::scope`, 4-row tiles dealt
//! round-robin); and (d) ambient occlusion's RMSE against a 256-sample reference (another
//! seed) as samples, and time, add up, at 160 x 90. Each timing is the fastest of a few
//! runs. `ACCEL_PREVIEW_JSON=path` also writes the figures as JSON.
//!
//! Run: `cargo bench -p accel --profile dev --bench preview`

use accel::mesh::{InstancedScene, MeshBvh};
use accel::preview::{
    CountedHit, InstancedPreviewScene, MeshSurface, PreviewCamera, PreviewImage, PreviewInstance,
    PreviewLight, PreviewMaterial, PreviewMode, PreviewScene, PreviewTracer, SurfaceHit,
};
use accel::{Backfaces, Ray};
use accel_testkit::shapes::{cube, icosphere};
use accel_testkit::{Rng, bunny};
use glam::{Affine3A, Mat4, Quat, Vec3};
use std::hint::black_box;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

const SIZE: (u32, u32) = (640, 360);
const AO_SIZE: (u32, u32) = (160, 90);
const RUNS: usize = 5;

/// About 100k triangles: 25 bunnies in a jittered grid, 6 icospheres, 12 boxes, a ground.
fn scene() -> Vec<PreviewInstance> {
    let surface = |m: accel_testkit::Mesh| {
        let s = Arc::new(MeshSurface::new(m.positions(), m.flat_indices()).with_smooth_normals());
        (Arc::new(s.build_bvh().unwrap()), s)
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

fn tracer(mode: PreviewMode, (w, h): (u32, u32)) -> PreviewTracer {
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

/// A scene that records every ray it is asked about (closest hits with `None`, occlusion
/// with its `t_max`).
struct Recording<'a> {
    inner: &'a InstancedPreviewScene,
    rays: Mutex<Vec<(Ray, Option<f32>)>>,
}

impl PreviewScene for Recording<'_> {
    fn closest(&self, ray: &Ray) -> Option<SurfaceHit> {
        self.rays.lock().unwrap().push((*ray, None));
        self.inner.closest(ray)
    }
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.rays.lock().unwrap().push((*ray, Some(t_max)));
        self.inner.occluded(ray, t_max)
    }
    fn closest_counted(&self, ray: &Ray) -> CountedHit<SurfaceHit> {
        self.inner.closest_counted(ray)
    }
}

/// The fastest of `RUNS` runs of each task, the tasks run in turn in every round.
fn fastest_of_each<const N: usize>(tasks: [&mut dyn FnMut(); N]) -> [Duration; N] {
    let mut best = [Duration::MAX; N];
    let mut tasks = tasks;
    for _ in 0..RUNS {
        for (task, best) in tasks.iter_mut().zip(&mut best) {
            let start = Instant::now();
            task();
            *best = (*best).min(start.elapsed());
        }
    }
    best
}

/// One sample of every pixel of `image` on `threads` threads, 4-row tiles dealt round-robin.
/// This thread's CPU time so far, where Linux reports it (`/proc/thread-self/schedstat`,
/// nanoseconds on the CPU).
fn thread_cpu_time() -> Option<Duration> {
    let stat = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    Some(Duration::from_nanos(
        stat.split_whitespace().next()?.parse().ok()?,
    ))
}

/// One sample of every pixel of `image` on `threads` threads, 4-row tiles dealt
/// round-robin; returns the threads' summed CPU time, where known.
fn trace_parallel(
    t: &PreviewTracer,
    scene: &dyn PreviewScene,
    image: &mut PreviewImage,
    threads: usize,
) -> Option<Duration> {
    let height = image.height();
    let mut shares: Vec<Vec<_>> = (0..threads).map(|_| Vec::new()).collect();
    for (i, tile) in image.tiles(0..height, 4).into_iter().enumerate() {
        shares[i % threads].push(tile);
    }
    std::thread::scope(|s| {
        let handles: Vec<_> = shares
            .into_iter()
            .map(|share| {
                s.spawn(move || {
                    let start = thread_cpu_time();
                    for mut tile in share {
                        t.trace_tile(scene, &mut tile);
                    }
                    Some(thread_cpu_time()? - start?)
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap())
            .sum::<Option<Duration>>()
    })
}

fn rmse(a: &PreviewImage, b: &PreviewImage) -> f64 {
    let mut sum = 0.0f64;
    for y in 0..a.height() {
        for x in 0..a.width() {
            sum += f64::from((a.mean(x, y).unwrap() - b.mean(x, y).unwrap()).length_squared());
        }
    }
    (sum / f64::from(3 * a.width() * a.height())).sqrt()
}

fn main() {
    let instances = scene();
    let triangles: usize = instances.iter().map(|i| i.mesh.triangle_count()).sum();
    let scene = InstancedPreviewScene::new(&instances);
    let t = tracer(PreviewMode::Shaded, SIZE);
    let pixels = (SIZE.0 * SIZE.1) as usize;
    println!(
        "preview bench: {triangles} triangles in {} instances, {}x{} shaded, {} lights",
        instances.len(),
        SIZE.0,
        SIZE.1,
        t.lights.len()
    );

    // (a) and (b): the tracer on one thread, and the same rays (recorded from a traced
    // frame) cast directly, timed in alternation so that a busy machine slows both alike.
    let mut out = vec![Vec3::ZERO; pixels];
    let recording = Recording {
        inner: &scene,
        rays: Mutex::new(Vec::new()),
    };
    t.trace_rows(&recording, SIZE, 0..SIZE.1, 0, &mut out);
    let rays = recording.rays.into_inner().unwrap();
    let primary = rays.iter().filter(|(_, t)| t.is_none()).count();
    let top: &InstancedScene = scene.scene();
    let cast_directly = || {
        for (ray, t_max) in &rays {
            match t_max {
                None => {
                    black_box(top.cast_ray(ray, Backfaces::Include));
                }
                Some(t_max) => {
                    black_box(top.cast_ray_any(&ray.with_t_max(*t_max), Backfaces::Include));
                }
            }
        }
    };
    let [frame, direct] = fastest_of_each([
        &mut || t.trace_rows(&scene, SIZE, 0..SIZE.1, 0, black_box(&mut out)),
        &mut || cast_directly(),
    ]);
    println!(
        "(a) frame on one thread: {:.1} ms",
        frame.as_secs_f64() * 1e3
    );
    let ratio = frame.as_secs_f64() / direct.as_secs_f64();
    println!(
        "(b) {} rays ({primary} closest, {} shadow) cast directly: {:.1} ms; tracer / direct = {ratio:.2}x (target <= 1.3x)",
        rays.len(),
        rays.len() - primary,
        direct.as_secs_f64() * 1e3
    );

    // (c) Two threads.
    let (mut image_one, mut image_two) = (
        PreviewImage::new(SIZE.0, SIZE.1),
        PreviewImage::new(SIZE.0, SIZE.1),
    );
    let (mut cpu_one, mut cpu_two) = (None, None);
    let [one, two] = fastest_of_each([
        &mut || {
            image_one.restart();
            cpu_one = trace_parallel(&t, &scene, &mut image_one, 1);
        },
        &mut || {
            image_two.restart();
            cpu_two = trace_parallel(&t, &scene, &mut image_two, 2);
        },
    ]);
    assert_eq!(image_one, image_two, "threads changed the image");
    let speedup = one.as_secs_f64() / two.as_secs_f64();
    println!(
        "(c) tiles on 1 thread {:.1} ms, on 2 threads {:.1} ms: speed-up {speedup:.2}x (target >= 1.7x; {} CPUs available)",
        one.as_secs_f64() * 1e3,
        two.as_secs_f64() * 1e3,
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    let cpu_ratio = cpu_one
        .zip(cpu_two)
        .map(|(a, b)| b.as_secs_f64() / a.as_secs_f64());
    if let Some(r) = cpu_ratio {
        let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
        let load = load.split_whitespace().next().unwrap_or("?");
        println!("    CPU time on 2 threads / on 1: {r:.2} (load average {load})");
    }

    // (d) Ambient occlusion: error against samples and time.
    let mode = PreviewMode::AmbientOcclusion {
        samples: 1,
        radius: 2.0,
    };
    let mut reference_tracer = tracer(mode, AO_SIZE);
    reference_tracer.settings.seed = 12345;
    let mut reference = PreviewImage::new(AO_SIZE.0, AO_SIZE.1);
    for _ in 0..256 {
        trace_parallel(&reference_tracer, &scene, &mut reference, 2);
    }
    let ao = tracer(mode, AO_SIZE);
    let mut image = PreviewImage::new(AO_SIZE.0, AO_SIZE.1);
    let mut elapsed = Duration::ZERO;
    let mut table = Vec::new();
    println!(
        "(d) ambient occlusion at {}x{}, one thread, against a 256-sample reference:",
        AO_SIZE.0, AO_SIZE.1
    );
    println!("    samples   time (ms)   RMSE");
    for samples in 1..=64u32 {
        let start = Instant::now();
        trace_parallel(&ao, &scene, &mut image, 1);
        elapsed += start.elapsed();
        if samples.is_power_of_two() {
            let e = rmse(&image, &reference);
            println!(
                "    {samples:>7}   {:>9.1}   {e:.4}",
                elapsed.as_secs_f64() * 1e3
            );
            table.push((samples, elapsed.as_secs_f64(), e));
        }
    }

    if let Ok(path) = std::env::var("ACCEL_PREVIEW_JSON") {
        let rows: Vec<String> = table
            .iter()
            .map(|(s, t, e)| format!("{{\"samples\":{s},\"seconds\":{t},\"rmse\":{e}}}"))
            .collect();
        let json = format!(
            "{{\"triangles\":{triangles},\"width\":{},\"height\":{},\"frame_one_thread_s\":{},\"direct_rays_s\":{},\"tracer_over_direct\":{ratio},\"one_thread_s\":{},\"two_threads_s\":{},\"two_thread_speedup\":{speedup},\"two_thread_cpu_ratio\":{},\"ao\":[{}]}}\n",
            SIZE.0,
            SIZE.1,
            frame.as_secs_f64(),
            direct.as_secs_f64(),
            one.as_secs_f64(),
            two.as_secs_f64(),
            cpu_ratio.map_or("null".to_string(), |r| r.to_string()),
            rows.join(",")
        );
        std::fs::write(&path, json).unwrap_or_else(|e| panic!("writing {path}: {e}"));
        println!("figures written to {path}");
    }
}
