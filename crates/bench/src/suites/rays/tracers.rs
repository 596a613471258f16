//! The Rust contenders of the `rays` suite over one triangle scene: our mesh BVHs (three
//! builds), the two-level scene (two builds of its meshes), general box trees with the
//! watertight test in the callback, and the peers obvhs 0.3.3 (CWBVH, BVH2) and bvh 0.13.

use super::sets::RaySet;
use crate::suites::common::peers::{self, BvhShape};
use accel_testkit::InstancedTriangles;
use glam::{Affine3A, Vec3};
use obvhs::BvhBuildParams;
use spatial_accel::bvh::wide::{Bvh4, Bvh8, QBvh8};
use spatial_accel::mesh::{Instance, InstancedScene, MeshBvh, SpatialSplits};
use spatial_accel::{Aabb, Backfaces, BuildConfig, Bvh, SpatialQuery, Triangle, WatertightRay};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// Traces ray `i` of a set: the closest `t`, or for an any-hit set `Some(0.0)` when blocked.
pub type Tracer<'a> = Box<dyn Fn(&RaySet, usize) -> Option<f32> + 'a>;

/// One contender.
pub struct Traced<'a> {
    /// The method (the structure or peer crate).
    pub method: &'static str,
    /// Its setting (the build).
    pub setting: &'static str,
    /// Its triangle test is not our watertight one (Möller-Trumbore), so a ray through a
    /// shared edge may get the other triangle's answer.
    pub other_test: bool,
    /// The tracer.
    pub trace: Tracer<'a>,
}

/// Triangles as an indexed list: three vertices each, in order.
pub fn triangle_list(tris: &[Triangle]) -> (Vec<Vec3>, Vec<u32>) {
    let v: Vec<Vec3> = tris
        .iter()
        .flat_map(|t| t.vertices.map(Vec3::from))
        .collect();
    let i = (0..v.len() as u32).collect();
    (v, i)
}

/// How a mesh BVH is built.
#[derive(Clone, Copy)]
pub enum MeshBuild {
    /// `MeshBvh::with_spatial_splits` with the default splits.
    Sbvh,
    /// `MeshBvh::new`: PLOC over pre-split triangles.
    New,
    /// The default build over whole triangles.
    Whole,
}

/// A mesh BVH over `tris`, built the `how` way.
pub fn build_mesh(tris: &[Triangle], how: MeshBuild) -> MeshBvh {
    let (v, i) = triangle_list(tris);
    match how {
        MeshBuild::Sbvh => {
            MeshBvh::with_spatial_splits(&v, &i, &BuildConfig::default(), &SpatialSplits::default())
        }
        MeshBuild::New => MeshBvh::new(&v, &i),
        MeshBuild::Whole => MeshBvh::with_config(&v, &i, &MeshBvh::default_config(tris.len())),
    }
    .expect("a triangle list")
}

fn mesh_tracer<'a>(m: MeshBvh) -> Tracer<'a> {
    Box::new(move |set, i| {
        if set.any_hit {
            m.cast_ray_any(&set.ours[i], Backfaces::Include)
                .then_some(0.0)
        } else {
            m.cast_ray(&set.ours[i], Backfaces::Include).map(|h| h.t)
        }
    })
}

/// The scene as two levels: one bunny mesh under every copy's transform, the large triangles
/// as one more mesh in place, each mesh built the `how` way.
fn instanced(parts: &InstancedTriangles, how: MeshBuild) -> InstancedScene {
    let bunny = Arc::new(build_mesh(&parts.mesh, how));
    let mut instances: Vec<Instance> = parts
        .placements
        .iter()
        .map(|m| Instance {
            mesh: bunny.clone(),
            world_from_local: Affine3A::from_mat4(*m),
        })
        .collect();
    if !parts.loose.is_empty() {
        instances.push(Instance {
            mesh: Arc::new(build_mesh(&parts.loose, how)),
            world_from_local: Affine3A::IDENTITY,
        });
    }
    InstancedScene::new(instances)
}

fn scene_tracer<'a>(scene: InstancedScene) -> Tracer<'a> {
    Box::new(move |set, i| {
        if set.any_hit {
            scene
                .cast_ray_any(&set.ours[i], Backfaces::Include)
                .then_some(0.0)
        } else {
            scene
                .cast_ray(&set.ours[i], Backfaces::Include)
                .map(|h| h.hit.t)
        }
    })
}

/// A general box tree over the triangle boxes, with the single watertight test in the
/// callback.
fn box_tracer<'a, T: SpatialQuery + 'a>(tree: T, tris: &'a [Triangle]) -> Tracer<'a> {
    Box::new(move |set, i| {
        let ray = &set.ours[i];
        let wt = WatertightRay::new(ray);
        if set.any_hit {
            tree.cast_ray_any(ray, |p, _| {
                wt.intersect(&tris[p as usize], Backfaces::Include)
                    .is_some()
            })
            .map(|_| 0.0)
        } else {
            tree.cast_ray(ray, |p, _| {
                wt.intersect(&tris[p as usize], Backfaces::Include)
                    .map(|h| h.t)
            })
            .map(|h| h.t)
        }
    })
}

/// obvhs' CWBVH (medium preset, its Möller-Trumbore test, triangles in leaf order: its
/// recommended use).
fn cwbvh<'a>(ot: &[obvhs::triangle::Triangle]) -> Tracer<'a> {
    let cw = obvhs::cwbvh::builder::build_cwbvh_from_tris(
        ot,
        BvhBuildParams::medium_build(),
        &mut Duration::default(),
    );
    let leaf: Vec<_> = cw
        .primitive_indices
        .iter()
        .map(|&p| ot[p as usize])
        .collect();
    Box::new(move |set, i| {
        let ray = set.obvhs[i];
        let test = |ray: &obvhs::ray::Ray, id: usize| leaf[id].intersect(ray);
        if set.any_hit {
            (!cw.ray_traverse_miss(ray, test)).then_some(0.0)
        } else {
            let mut hit = obvhs::ray::RayHit::none();
            cw.ray_traverse(ray, &mut hit, test).then_some(hit.t)
        }
    })
}

/// obvhs' BVH2 (fast preset; closest hit only: an any-hit ray asks for the closest).
fn bvh2<'a>(ot: &[obvhs::triangle::Triangle]) -> Tracer<'a> {
    let b2 = obvhs::bvh2::builder::build_bvh2_from_tris(
        ot,
        BvhBuildParams::fast_build(),
        &mut Duration::default(),
    );
    let leaf: Vec<_> = b2
        .primitive_indices
        .iter()
        .map(|&p| ot[p as usize])
        .collect();
    Box::new(move |set, i| {
        let mut hit = obvhs::ray::RayHit::none();
        b2.ray_traverse(set.obvhs[i], &mut hit, |ray, id| leaf[id].intersect(ray))
            .then_some(hit.t)
    })
}

/// bvh 0.13's `nearest_traverse_iterator` (leaves in order of box entry, stopped once a box
/// starts beyond the best hit) with our watertight test: it has no two-sided triangle test.
fn bvh_crate<'a>(tris: &'a [Triangle], boxes: &'a [Aabb]) -> Tracer<'a> {
    let mut shapes: Vec<BvhShape> = boxes
        .iter()
        .enumerate()
        .map(|(i, b)| BvhShape::new(i, b))
        .collect();
    let tree = bvh::bvh::Bvh::build(&mut shapes);
    Box::new(move |set, i| {
        let r = &set.ours[i];
        let wt = WatertightRay::new(r);
        let mut best: Option<f32> = None;
        for s in tree.nearest_traverse_iterator(&set.bvh[i], &shapes) {
            let t_best = best.unwrap_or(r.t_max);
            match r.with_t_max(t_best).intersect_aabb(&boxes[s.id as usize]) {
                None => continue,
                Some(entry) if entry > t_best => break,
                Some(_) => {}
            }
            if let Some(h) = wt.intersect(&tris[s.id as usize], Backfaces::Include)
                && h.t < t_best
            {
                best = Some(h.t);
                if set.any_hit {
                    break;
                }
            }
        }
        best
    })
}

/// What a mesh build cost: its time and memory per triangle, for the notes.
pub struct BuildNote {
    /// The contender.
    pub name: String,
    /// Seconds of the build.
    pub seconds: f64,
    /// Bytes per triangle of the built tree.
    pub bytes_per_triangle: f64,
}

/// Every contender over `tris` (whose two-level form is `parts`, and whose boxes are
/// `boxes`), obvhs' CWBVH last (the reference of every ratio); and each mesh build's cost.
/// `new` is the `MeshBvh::new` tree, already built (the ray sets start from its hits).
pub fn contenders<'a>(
    tris: &'a [Triangle],
    boxes: &'a [Aabb],
    parts: &InstancedTriangles,
    new: BuildNote,
    new_mesh: MeshBvh,
) -> (Vec<Traced<'a>>, Vec<BuildNote>) {
    let ours = |method: &'static str, setting: &'static str, trace: Tracer<'a>| Traced {
        method,
        setting,
        other_test: false,
        trace,
    };
    let mut out = Vec::new();
    let mut notes = Vec::new();
    let mut timed_mesh = |setting: &'static str, how| {
        let started = Instant::now();
        let mesh = build_mesh(tris, how);
        notes.push(BuildNote {
            name: format!("MeshBvh {setting}"),
            seconds: started.elapsed().as_secs_f64(),
            bytes_per_triangle: mesh.memory_bytes() as f64 / tris.len() as f64,
        });
        ours("MeshBvh", setting, mesh_tracer(mesh))
    };
    out.push(timed_mesh("sbvh", MeshBuild::Sbvh));
    out.push(timed_mesh("whole", MeshBuild::Whole));
    out.insert(1, ours("MeshBvh", "new", mesh_tracer(new_mesh)));
    notes.insert(1, new);
    for (setting, how) in [
        ("sbvh meshes", MeshBuild::Sbvh),
        ("new meshes", MeshBuild::New),
    ] {
        out.push(ours(
            "InstancedScene",
            setting,
            scene_tracer(instanced(parts, how)),
        ));
    }
    let bvh = Bvh::build(boxes, &BuildConfig::default());
    out.push(ours(
        "Bvh8 + watertight",
        "binned16",
        box_tracer(Bvh8::from_bvh(&bvh), tris),
    ));
    out.push(ours(
        "QBvh8 + watertight",
        "binned16",
        box_tracer(QBvh8::from_bvh(&bvh), tris),
    ));
    out.push(ours(
        "Bvh4 + watertight",
        "binned16",
        box_tracer(Bvh4::from_bvh(&bvh), tris),
    ));
    out.push(ours("Bvh + watertight", "binned16", box_tracer(bvh, tris)));
    out.push(ours(
        "bvh 0.13 + watertight",
        "default",
        bvh_crate(tris, boxes),
    ));
    let ot: Vec<obvhs::triangle::Triangle> = tris.iter().map(peers::to_obvhs_tri).collect();
    for (method, setting, trace) in [
        ("obvhs bvh2", "fast", bvh2(&ot)),
        ("obvhs cwbvh", "medium", cwbvh(&ot)),
    ] {
        out.push(Traced {
            method,
            setting,
            other_test: true,
            trace,
        });
    }
    (out, notes)
}
