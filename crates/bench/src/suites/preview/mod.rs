//! The ray-traced preview: run time against image error for each top-level index the plugin
//! can trace (the two-level `InstancedScene` built for the preview, and the movers' indexes
//! as `IndexedPreviewScene`), the shaded frame on one and on two threads, and the tracer's
//! overhead over casting the same rays directly.
//!
//! - Ambient occlusion, progressive, on one thread: RMSE against a reference of many more
//!   samples (another seed) as samples, and time, add up.
//! - The shaded frame (one primary ray and one shadow ray per light per pixel): time on one
//!   and two threads, and pixels that differ from the two-level scene's frame (must be 0);
//!   each thread's busy time, and the machine's own two-thread speed-up on a loop that
//!   touches no memory (`crate::machine`), which bounds what any tracer can reach here.
//! - Tracer / direct: the frame's time over the time of the very same rays (recorded from a
//!   traced frame) cast straight through `InstancedScene`; what is not traversal.

mod scene;

use super::point;
use crate::json::{Point, Report};
use crate::progress::Progress;
use crate::timing::best_of;
use scene::{instances, rmse, trace_parallel, tracer};
use spatial_accel::mesh::{CountedHit, InstancedScene};
use spatial_accel::preview::{
    IndexedPreviewScene, InstancedPreviewScene, PreviewImage, PreviewMode, PreviewScene, SurfaceHit,
};
use spatial_accel::query::{AnyIndex, IndexKind};
use spatial_accel::{Backfaces, Ray};
use std::hint::black_box;
use std::sync::Mutex;
use std::time::Instant;

/// The sizes of one run.
struct Sizes {
    frame: (u32, u32),
    ao: (u32, u32),
    ao_samples: u32,
    reference_samples: u32,
    runs: usize,
}

/// A scene that records every ray it is asked about (closest hits with `None`, occlusion
/// with its `t_max`).
struct Recording<'a> {
    inner: &'a InstancedPreviewScene,
    rays: Mutex<Vec<(Ray, Option<f32>)>>,
}

impl PreviewScene for Recording<'_> {
    fn closest(&self, ray: &Ray) -> Option<SurfaceHit> {
        self.rays.lock().expect("not poisoned").push((*ray, None));
        self.inner.closest(ray)
    }
    fn occluded(&self, ray: &Ray, t_max: f32) -> bool {
        self.rays
            .lock()
            .expect("not poisoned")
            .push((*ray, Some(t_max)));
        self.inner.occluded(ray, t_max)
    }
    fn closest_counted(&self, ray: &Ray) -> CountedHit<SurfaceHit> {
        self.inner.closest_counted(ray)
    }
}

/// Runs the suite.
pub fn run(quick: bool) -> Report {
    let sizes = if quick {
        Sizes {
            frame: (320, 180),
            ao: (80, 45),
            ao_samples: 16,
            reference_samples: 64,
            runs: 2,
        }
    } else {
        Sizes {
            frame: (640, 360),
            ao: (160, 90),
            ao_samples: 64,
            reference_samples: 256,
            runs: 5,
        }
    };
    let instances = instances();
    let triangles: usize = instances.iter().map(|i| i.mesh.triangle_count()).sum();
    let two_level = InstancedPreviewScene::new(&instances);
    let kinds = [
        IndexKind::DynamicBvh,
        IndexKind::Octree,
        IndexKind::Grid,
        IndexKind::BruteForce,
    ];
    let indexed: Vec<(String, IndexedPreviewScene<AnyIndex>)> = kinds
        .iter()
        .map(|&k| {
            let scene = IndexedPreviewScene::new(AnyIndex::new(k), &instances)
                .expect("finite instance boxes");
            (format!("{k:?}"), scene)
        })
        .collect();
    let mut methods: Vec<(&str, &dyn PreviewScene)> = vec![("InstancedScene", &two_level)];
    methods.extend(
        indexed
            .iter()
            .map(|(n, s)| (n.as_str(), s as &dyn PreviewScene)),
    );

    let mut progress = Progress::new("preview", 2 + methods.len() * 2);
    let mut points: Vec<Point> = Vec::new();
    let mut notes = vec![format!(
        "{triangles} triangles in {} instances; {} threads available",
        instances.len(),
        std::thread::available_parallelism().map_or(1, |n| n.get())
    )];

    // The shaded frame: every method on one and two threads, alternated round by round so
    // that a busy machine slows all alike.
    let (w, h) = sizes.frame;
    let shaded = tracer(PreviewMode::Shaded, sizes.frame);
    let frame_name = format!("shaded frame {w}x{h}");
    let mut want = PreviewImage::new(w, h);
    trace_parallel(&shaded, &two_level, &mut want, 2);
    let mut best = vec![[f64::INFINITY; 2]; methods.len()];
    // The busy seconds of each thread in the best two-thread run.
    let mut busy = vec![Vec::new(); methods.len()];
    let mut images: Vec<PreviewImage> = methods.iter().map(|_| PreviewImage::new(w, h)).collect();
    for _ in 0..sizes.runs {
        for (m, (_, scene)) in methods.iter().enumerate() {
            for (slot, threads) in [1usize, 2].into_iter().enumerate() {
                images[m].restart();
                let start = Instant::now();
                let per_thread = trace_parallel(&shaded, *scene, &mut images[m], threads);
                let t = start.elapsed().as_secs_f64();
                if t < best[m][slot] {
                    best[m][slot] = t;
                    if threads == 2 {
                        busy[m] = per_thread;
                    }
                }
            }
        }
    }
    // The machine's own two-thread speed-up, measured between the frames and after them, so
    // that the frames' ratio reads against what this machine gave at the time.
    let machine = crate::machine::alu_speedup(2, sizes.runs.min(3));
    for (m, (name, _)) in methods.iter().enumerate() {
        let differing = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| images[m].mean(x, y) != want.mean(x, y))
            .count();
        for (slot, setting) in ["1 thread", "2 threads"].into_iter().enumerate() {
            points.push(point(
                &frame_name,
                name,
                setting,
                ("ms", best[m][slot] * 1e3),
                (
                    "pixels unlike the two-level scene's",
                    Some(differing as f64),
                ),
            ));
        }
        let busy_ms: Vec<String> = busy[m].iter().map(|b| format!("{:.1}", b * 1e3)).collect();
        let speedup = best[m][0] / best[m][1];
        notes.push(format!(
            "{name}: shaded frame {:.1} ms on 1 thread, {:.1} ms on 2: speed-up {speedup:.2}x \
             ({:.2} of the machine's {machine:.2}x); the two threads busy {} ms",
            best[m][0] * 1e3,
            best[m][1] * 1e3,
            speedup / machine,
            busy_ms.join(" / ")
        ));
        progress.step(name);
    }

    // The tracer's overhead: its frame against the same rays cast straight through the
    // two-level scene, on one thread, alternated.
    let recording = Recording {
        inner: &two_level,
        rays: Mutex::new(Vec::new()),
    };
    let mut out = vec![glam::Vec3::ZERO; (w * h) as usize];
    shaded.trace_rows(&recording, sizes.frame, 0..h, 0, &mut out);
    let rays = recording.rays.into_inner().expect("not poisoned");
    let top: &InstancedScene = two_level.scene();
    let (mut frame, mut direct) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..sizes.runs {
        let (t, _) = best_of(1, || {
            shaded.trace_rows(&two_level, sizes.frame, 0..h, 0, &mut out)
        });
        frame = frame.min(t);
        let (t, _) = best_of(1, || {
            for (ray, t_max) in &rays {
                match t_max {
                    None => drop(black_box(top.cast_ray(ray, Backfaces::Include))),
                    Some(t_max) => drop(black_box(
                        top.cast_ray_any(&ray.with_t_max(*t_max), Backfaces::Include),
                    )),
                }
            }
        });
        direct = direct.min(t);
    }
    let primary = rays.iter().filter(|(_, t)| t.is_none()).count();
    notes.push(format!(
        "tracer / direct: {:.2}x ({:.1} ms against {:.1} ms for {} rays, {primary} closest, {} shadow)",
        frame / direct,
        frame * 1e3,
        direct * 1e3,
        rays.len(),
        rays.len() - primary
    ));
    progress.step("ambient occlusion reference");

    // Ambient occlusion: error against samples and time, for every method.
    let mode = PreviewMode::AmbientOcclusion {
        samples: 1,
        radius: 2.0,
    };
    let (aw, ah) = sizes.ao;
    let mut reference_tracer = tracer(mode, sizes.ao);
    reference_tracer.settings.seed = 12345;
    let mut reference = PreviewImage::new(aw, ah);
    for _ in 0..sizes.reference_samples {
        trace_parallel(&reference_tracer, &two_level, &mut reference, 2);
    }
    progress.step("ambient occlusion");
    let ao = tracer(mode, sizes.ao);
    let ao_name = format!(
        "ambient occlusion {aw}x{ah}, 1 thread, against {} samples",
        sizes.reference_samples
    );
    for (name, scene) in &methods {
        let mut image = PreviewImage::new(aw, ah);
        let mut elapsed = 0.0;
        for samples in 1..=sizes.ao_samples {
            let start = Instant::now();
            trace_parallel(&ao, *scene, &mut image, 1);
            elapsed += start.elapsed().as_secs_f64();
            if samples.is_power_of_two() {
                points.push(point(
                    &ao_name,
                    name,
                    &format!("{samples} samples"),
                    ("ms", elapsed * 1e3),
                    ("RMSE", Some(rmse(&image, &reference))),
                ));
            }
        }
        progress.step(name);
    }
    progress.finish();
    Report {
        suite: "preview".into(),
        quick,
        points,
        notes,
        ..Report::default()
    }
}
