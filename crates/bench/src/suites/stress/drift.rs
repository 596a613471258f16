//! Long runs of edits, checked for drift: each structure's bounds still hold its entries
//! (its validator passes and every query is the oracle's), no entry is lost or repeated,
//! and memory does not grow while the entry count holds.
//!
//! The motion mixes what games do: small steps every frame, a few jumps far away and back,
//! boxes shrinking to points, and a trickle of removals and insertions.

use super::oracle::{Volume, check_ray, check_volume, oracle_of};
use super::{Failure, Sizes, Tally};
use accel_testkit::{Rng, random_box};
use glam::{Affine3A, Quat, Vec3, Vec3A};
use spatial_accel::dynamic::StaticDynamicPair;
use spatial_accel::mesh::{Instance, InstancedScene, MeshBvh};
use spatial_accel::query::{BruteForceMesh, DynamicIndex, TriangleQuery};
use spatial_accel::{
    Aabb, Backfaces, BuildConfig, Bvh, DynamicBvh, DynamicBvhConfig, LooseOctree, Quadtree, Ray,
    UniformGrid,
};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

/// The world's half size.
const EXTENT: f32 = 200.0;

/// The next box of a moving entry.
fn moved(rng: &mut Rng, b: &Aabb) -> Aabb {
    match rng.below(40) {
        0 => Aabb::from_point(b.center()),
        1 => {
            let far = rng.vec3a(-1.0, 1.0) * 1e5;
            Aabb::new(b.min + far, b.max + far)
        }
        2 => random_box(rng, EXTENT, 0.1..4.0),
        _ => {
            let step = rng.vec3a(-1.0, 1.0);
            let c = (b.center() + step).clamp(Vec3A::splat(-1e6), Vec3A::splat(1e6));
            Aabb::from_center_half_extents(c, b.half_extents())
        }
    }
}

/// Runs `frames` frames of motion on `index`, checking every few frames.
fn run_index<I: DynamicIndex>(
    tally: &mut Tally,
    name: &str,
    mut index: I,
    sizes: &Sizes,
    seed: u64,
    validate: impl Fn(&I) -> Result<(), String>,
) {
    let mut rng = Rng::new(seed);
    let mut handles: Vec<(u32, I::Handle)> = Vec::new();
    let mut live: HashMap<u32, Aabb> = HashMap::new();
    let mut next_id = 0u32;
    for _ in 0..sizes.entries {
        let b = random_box(&mut rng, EXTENT, 0.1..4.0);
        if let Ok(h) = index.insert(next_id, b) {
            handles.push((next_id, h));
            live.insert(next_id, b);
        }
        next_id += 1;
    }
    let check_every = (sizes.frames / 12).max(1);
    let mut warm_memory = None;
    for frame in 0..sizes.frames {
        let moving = handles.len() / 10;
        for _ in 0..moving {
            let k = rng.below(handles.len());
            let (id, h) = handles[k];
            let b = moved(&mut rng, &live[&id]);
            if tally
                .guard(name, "update", |_| index.update(h, b))
                .is_some_and(|r| r.is_ok())
            {
                live.insert(id, b);
            }
        }
        // Churn: one in a hundred leaves and as many arrive, so the count holds.
        for _ in 0..(handles.len() / 100).max(1) {
            let k = rng.below(handles.len());
            let (id, h) = handles.swap_remove(k);
            match tally.guard(name, "remove", |_| index.remove(h)) {
                Some(Ok(got)) if got == id => {
                    live.remove(&id);
                }
                other => {
                    tally.fail(name, "remove", Failure::Leak, || {
                        format!("removing {id} gave {other:?}")
                    });
                    live.remove(&id);
                }
            }
            let b = random_box(&mut rng, EXTENT, 0.1..4.0);
            if let Some(Ok(h)) = tally.guard(name, "insert", |_| index.insert(next_id, b)) {
                handles.push((next_id, h));
                live.insert(next_id, b);
            }
            next_id += 1;
        }
        tally.guard(name, "maintain", |_| {
            index.maintain(Duration::from_micros(200))
        });
        if frame % check_every == check_every - 1 {
            check_state(tally, name, &index, &handles, &live, &validate, &mut rng);
            let memory = index.index_stats().memory_bytes;
            if frame >= sizes.frames / 4 && warm_memory.is_none() {
                warm_memory = Some(memory);
            }
            tally.case(name, "memory");
            if let Some(warm) = warm_memory
                && memory > warm * 3 / 2 + 65_536
            {
                tally.fail(name, "memory", Failure::Leak, || {
                    format!("{warm} bytes after warm-up, {memory} at frame {frame}")
                });
            }
        }
    }
}

/// The validator, the entry count, each handle's bounds, and a few queries.
fn check_state<I: DynamicIndex>(
    tally: &mut Tally,
    name: &str,
    index: &I,
    handles: &[(u32, I::Handle)],
    live: &HashMap<u32, Aabb>,
    validate: &impl Fn(&I) -> Result<(), String>,
    rng: &mut Rng,
) {
    tally.case(name, "validate");
    if let Err(e) = validate(index) {
        tally.fail(name, "validate", Failure::Leak, || e);
    }
    tally.case(name, "entries");
    if index.len() != live.len() {
        tally.fail(name, "entries", Failure::Leak, || {
            format!("{} held, {} live", index.len(), live.len())
        });
    }
    for &(id, h) in handles {
        tally.case(name, "entry bounds");
        if index.id(h) != Some(id) || index.bounds_of(h) != live.get(&id).copied() {
            tally.fail(name, "entry bounds", Failure::Leak, || {
                format!("entry {id}: {:?} / {:?}", index.id(h), index.bounds_of(h))
            });
        }
    }
    let oracle = oracle_of(live);
    for _ in 0..8 {
        let ray = Ray::new(rng.vec3a(-EXTENT, EXTENT), rng.unit_vector());
        check_ray(tally, name, index, &oracle, live, &ray);
        let q = Aabb::from_center_half_extents(rng.vec3a(-EXTENT, EXTENT), rng.vec3a(1.0, 40.0));
        check_volume(tally, name, index, &oracle, live, &Volume::Box(q));
    }
}

/// A mesh refit over and over as it turns: still the oracle's hits, still valid.
fn mesh_refits(tally: &mut Tally, sizes: &Sizes) {
    let sphere = accel_testkit::shapes::icosphere(3).normalized(20.0);
    let rest = sphere.positions();
    let indices = sphere.flat_indices();
    let Ok(mut mesh) = MeshBvh::new(&rest, &indices) else {
        return;
    };
    let mut rng = Rng::new(0x3e5);
    let name = "MeshBvh refit";
    for frame in 0..sizes.frames {
        let turn = Quat::from_rotation_y(frame as f32 * 0.05)
            * Quat::from_rotation_x(frame as f32 * 0.013);
        let squash = Vec3::new(1.0 + 0.5 * (frame as f32 * 0.1).sin(), 1.0, 1.0);
        let vertices: Vec<Vec3> = rest
            .iter()
            .map(|&v| turn * (v * squash) + Vec3::splat(frame as f32))
            .collect();
        if tally
            .guard(name, "refit", |_| mesh.refit(&vertices))
            .is_none_or(|r| r.is_err())
        {
            tally.fail(name, "refit", Failure::Leak, || "refit refused".into());
            continue;
        }
        if frame % 8 == 0 {
            tally.case(name, "validate");
            if let Err(e) = mesh.validate() {
                tally.fail(name, "validate", Failure::Leak, || format!("{e:?}"));
            }
            let oracle = BruteForceMesh::new(&vertices, &indices).expect("a triangle list");
            for _ in 0..8 {
                let c = Vec3A::splat(frame as f32);
                let ray = Ray::new(
                    c + rng.unit_vector() * 40.0,
                    rng.unit_vector() * -1.0 + rng.vec3a(-0.2, 0.2),
                );
                tally.case(name, "ray");
                let got = mesh
                    .cast_ray(&ray, Backfaces::Include)
                    .map(|h| h.t.to_bits());
                let want = oracle
                    .cast_ray(&ray, Backfaces::Include)
                    .map(|h| h.t.to_bits());
                if got != want {
                    tally.fail(name, "ray", Failure::Miss, || {
                        format!("frame {frame}: {ray:?}")
                    });
                }
            }
        }
    }
}

/// Instances moved frame after frame through `update_instances`: still what a new scene
/// over the same instances answers.
fn scene_updates(tally: &mut Tally, sizes: &Sizes) {
    let sphere = accel_testkit::shapes::icosphere(2);
    let mesh = Arc::new(MeshBvh::new(&sphere.positions(), &sphere.flat_indices()).expect("a mesh"));
    let mut rng = Rng::new(0x5ce);
    let mut places: Vec<Affine3A> = (0..200)
        .map(|_| Affine3A::from_translation(rng.vec3(-EXTENT, EXTENT)))
        .collect();
    let make = |m: &Affine3A| Instance {
        mesh: mesh.clone(),
        world_from_local: *m,
    };
    let mut scene = InstancedScene::new(places.iter().map(make).collect());
    let name = "InstancedScene update";
    for frame in 0..sizes.frames {
        let mut updates = Vec::new();
        for _ in 0..20 {
            let i = rng.below(places.len());
            places[i] = Affine3A::from_translation(places[i].translation.into())
                * Affine3A::from_translation(rng.vec3(-3.0, 3.0));
            updates.push((i as u32, make(&places[i])));
        }
        if tally
            .guard(name, "update", |_| scene.update_instances(updates))
            .is_none_or(|r| r.is_err())
        {
            tally.fail(name, "update", Failure::Leak, || "update refused".into());
        }
        if frame % 10 == 0 {
            let fresh = InstancedScene::new(places.iter().map(make).collect());
            for _ in 0..16 {
                let ray = Ray::new(rng.vec3a(-EXTENT, EXTENT), rng.unit_vector());
                tally.case(name, "ray");
                let got = scene
                    .cast_ray(&ray, Backfaces::Include)
                    .map(|h| (h.instance, h.hit.t));
                let want = fresh
                    .cast_ray(&ray, Backfaces::Include)
                    .map(|h| (h.instance, h.hit.t));
                if got.map(|g| g.1) != want.map(|w| w.1) {
                    tally.fail(name, "ray", Failure::Miss, || {
                        format!("frame {frame}: got {got:?}, fresh {want:?}")
                    });
                }
            }
        }
    }
}

/// Every drift run.
pub fn run(tally: &mut Tally, sizes: &Sizes) {
    let v = |r: Result<(), spatial_accel::dynamic::DynamicValidationError>| {
        r.map_err(|e| format!("{e:?}"))
    };
    run_index(tally, "DynamicBvh", DynamicBvh::new(), sizes, 1, |t| {
        v(t.validate())
    });
    let no_rotations = DynamicBvhConfig {
        rotations: false,
        ..DynamicBvhConfig::default()
    };
    run_index(
        tally,
        "DynamicBvh no rotations",
        DynamicBvh::with_config(no_rotations),
        sizes,
        2,
        |t| v(t.validate()),
    );
    run_index(tally, "LooseOctree", LooseOctree::new(), sizes, 3, |t| {
        t.validate().map_err(|e| format!("{e:?}"))
    });
    run_index(tally, "Quadtree", Quadtree::new(), sizes, 4, |t| {
        t.validate().map_err(|e| format!("{e:?}"))
    });
    run_index(tally, "UniformGrid", UniformGrid::new(), sizes, 5, |t| {
        t.validate().map_err(|e| format!("{e:?}"))
    });
    // The pair's dynamic half, with its ray snapshot refreshed as the plugin does.
    let mut pair =
        StaticDynamicPair::new(Bvh::build(&[], &BuildConfig::default()), DynamicBvh::new());
    let mut rng = Rng::new(6);
    let mut live = HashMap::new();
    let mut handles = Vec::new();
    for id in 0..sizes.entries as u32 {
        let b = random_box(&mut rng, EXTENT, 0.1..4.0);
        handles.push(pair.dynamic_mut().insert(id, b).expect("a valid box"));
        live.insert(id, b);
    }
    for frame in 0..sizes.frames {
        for _ in 0..handles.len() / 10 {
            let id = rng.below(handles.len());
            let b = moved(&mut rng, &live[&(id as u32)]);
            if pair.update_dynamic(handles[id], b).is_ok() {
                live.insert(id as u32, b);
            }
        }
        pair.maintain_dynamic();
        if frame % 5 == 0 {
            pair.snapshot_dynamic_for_rays(&BuildConfig::default());
        }
        if frame % 25 == 0 {
            let oracle = oracle_of(&live);
            for _ in 0..8 {
                let ray = Ray::new(rng.vec3a(-EXTENT, EXTENT), rng.unit_vector());
                check_ray(tally, "StaticDynamicPair", &pair, &oracle, &live, &ray);
            }
        }
    }
    mesh_refits(tally, sizes);
    scene_updates(tally, sizes);
}
