//! NaN and infinite values in every input of every query and edit of every structure, at
//! random: nothing may panic, no output may be NaN, an untraceable ray hits nothing, and
//! every answer is still the oracle's.

use super::boxes::structures;
use super::oracle::{Volume, check_nearest, check_ray, check_volume, oracle_of};
use super::{Failure, Sizes, Tally};
use accel_testkit::{Rng, uniform_boxes};
use glam::{Affine3A, Mat4, Vec3, Vec3A, Vec4};
use spatial_accel::mesh::{Instance, InstancedScene, MeshBvh};
use spatial_accel::query::{BruteForceMesh, DynamicIndex, IndexKind, TriangleQuery};
use spatial_accel::{Aabb, Backfaces, DynamicBvh, Frustum, Ray, Sphere, UniformGrid};
use spatial_accel::{LooseOctree, Quadtree};
use std::collections::HashMap;
use std::sync::Arc;
use std::time::Duration;

/// The values that break arithmetic: NaN, the infinities, the extremes, signed zeros and
/// the subnormals.
const SPECIALS: [f32; 12] = [
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::MAX,
    f32::MIN,
    f32::MIN_POSITIVE,
    0.0,
    -0.0,
    1e30,
    -1e30,
    1e-40,
    -1e-40,
];

/// A float: a special value three times in ten, else an ordinary one in the scene.
pub fn hostile(rng: &mut Rng) -> f32 {
    if rng.chance(0.3) {
        rng.pick(&SPECIALS)
    } else {
        rng.range(-120.0, 120.0)
    }
}

/// A vector of [`hostile`] components.
pub fn hostile_vec(rng: &mut Rng) -> Vec3A {
    Vec3A::new(hostile(rng), hostile(rng), hostile(rng))
}

/// A box with hostile corners (possibly inverted).
fn hostile_box(rng: &mut Rng) -> Aabb {
    let (a, b) = (hostile_vec(rng), hostile_vec(rng));
    if rng.bool() {
        Aabb::new(a.min(b), a.max(b))
    } else {
        Aabb::new(a, b)
    }
}

/// A ray from hostile values: through `Ray::new`, with a hostile range, or field by field
/// (which `Ray::new` would have made degenerate).
fn hostile_ray(rng: &mut Rng) -> Ray {
    let (o, d) = (hostile_vec(rng), hostile_vec(rng));
    match rng.below(3) {
        0 => Ray::new(o, d),
        1 => Ray::with_range(o, d, hostile(rng), hostile(rng)),
        _ => Ray {
            origin: o,
            direction: d,
            inv_direction: d.recip(),
            t_min: if rng.bool() { 0.0 } else { hostile(rng) },
            t_max: if rng.bool() {
                f32::INFINITY
            } else {
                hostile(rng)
            },
        },
    }
}

fn hostile_frustum(rng: &mut Rng) -> Frustum {
    if rng.bool() {
        let v = |rng: &mut Rng| Vec4::new(hostile(rng), hostile(rng), hostile(rng), hostile(rng));
        Frustum::from_planes([v(rng), v(rng), v(rng), v(rng), v(rng), v(rng)])
    } else {
        let m = Mat4::perspective_rh(hostile(rng), hostile(rng), hostile(rng), hostile(rng));
        Frustum::from_clip_from_world(&(m * Mat4::from_translation(hostile_vec(rng).into())))
    }
}

fn hostile_volume(rng: &mut Rng) -> Volume {
    match rng.below(4) {
        0 => Volume::Box(hostile_box(rng)),
        1 => Volume::Sphere(Sphere::new(hostile_vec(rng), hostile(rng))),
        2 => Volume::Point(hostile_vec(rng)),
        _ => Volume::Frustum(hostile_frustum(rng)),
    }
}

/// Random hostile queries on every structure over a scene with hostile boxes mixed in.
fn queries(tally: &mut Tally, rng: &mut Rng, cases: usize) {
    let mut boxes = uniform_boxes(rng, 160, 100.0, 0.1..8.0);
    for _ in 0..24 {
        boxes.push(hostile_box(rng));
    }
    let entries: Vec<(u32, Aabb)> = boxes
        .iter()
        .enumerate()
        .map(|(i, &b)| (i as u32, b))
        .collect();
    let live: HashMap<u32, Aabb> = entries.iter().copied().collect();
    let oracle = oracle_of(&live);
    let all = structures(tally, &entries);
    let per = cases / all.len().max(1);
    for (name, s) in &all {
        for i in 0..per {
            match i % 3 {
                0 => check_ray(tally, name, &**s, &oracle, &live, &hostile_ray(rng)),
                1 => check_volume(tally, name, &**s, &oracle, &live, &hostile_volume(rng)),
                _ => {
                    let k = rng.pick(&[0usize, 1, 3, 50, usize::MAX]);
                    check_nearest(tally, name, &**s, &oracle, &live, hostile_vec(rng), k);
                }
            }
        }
    }
}

/// Edits with hostile boxes on one dynamic index: a refused edit changes nothing, an
/// accepted one is what queries then see; entry counts stay those of the accepted edits.
fn edits<I: DynamicIndex>(
    tally: &mut Tally,
    rng: &mut Rng,
    name: &str,
    mut index: I,
    cases: usize,
    validate: impl Fn(&I) -> Result<(), String>,
) {
    let mut handles: Vec<(u32, I::Handle)> = Vec::new();
    let mut live: HashMap<u32, Aabb> = HashMap::new();
    let mut next_id = 0u32;
    for step in 0..cases {
        let b = if rng.chance(0.5) {
            hostile_box(rng)
        } else {
            accel_testkit::random_box(rng, 100.0, 0.1..5.0)
        };
        let op = if handles.is_empty() { 0 } else { rng.below(3) };
        let done = tally.guard(name, "edit", |_| match op {
            0 => index.insert(next_id, b).ok().map(|h| (0, h)),
            1 => {
                let k = rng.below(handles.len());
                index
                    .update(handles[k].1, b)
                    .ok()
                    .map(|_| (1, handles[k].1))
            }
            _ => {
                let k = rng.below(handles.len());
                index.remove(handles[k].1).ok().map(|_| (2, handles[k].1))
            }
        });
        match done.flatten() {
            Some((0, h)) => {
                handles.push((next_id, h));
                live.insert(next_id, b);
                next_id += 1;
            }
            Some((1, h)) => {
                let id = handles
                    .iter()
                    .find(|x| x.1 == h)
                    .map(|x| x.0)
                    .expect("a live handle");
                live.insert(id, b);
            }
            Some((_, h)) => {
                let k = handles
                    .iter()
                    .position(|x| x.1 == h)
                    .expect("a live handle");
                live.remove(&handles.swap_remove(k).0);
            }
            None => {}
        }
        if step % 64 == 63 {
            tally.guard(name, "maintain", |_| index.maintain(Duration::ZERO));
            tally.case(name, "validate");
            if let Err(e) = validate(&index) {
                tally.fail(name, "validate", Failure::Leak, || e);
            }
            tally.case(name, "entry count");
            if index.len() != live.len() {
                tally.fail(name, "entry count", Failure::Leak, || {
                    format!("{} held, {} accepted", index.len(), live.len())
                });
            }
            let oracle = oracle_of(&live);
            for _ in 0..4 {
                check_ray(tally, name, &index, &oracle, &live, &hostile_ray(rng));
                check_volume(tally, name, &index, &oracle, &live, &hostile_volume(rng));
            }
        }
    }
}

/// A mesh's closest and any hits against the oracle's, to the bit.
fn check_mesh(tally: &mut Tally, name: &str, mesh: &MeshBvh, oracle: &BruteForceMesh, ray: &Ray) {
    for bf in [Backfaces::Include, Backfaces::Cull] {
        if let Some((got, any)) = tally.guard(name, "mesh ray", |_| {
            (mesh.cast_ray(ray, bf), mesh.cast_ray_any(ray, bf))
        }) {
            let want = oracle.cast_ray(ray, bf);
            if got.is_some_and(|h| {
                h.t.is_nan()
                    || h.barycentrics.iter().any(|b| b.is_nan())
                    || h.geometric_normal.is_nan()
            }) {
                tally.fail(name, "mesh ray", Failure::Nan, || format!("{ray:?}"));
            }
            // To the bit, but with the zeros one: two triangles tied at the ray's origin may
            // give `-0.0` and `+0.0` (the sign of a zero numerator), and which of the tie the
            // tree and the oracle meet first is their order, not an error.
            let bits = |h: Option<spatial_accel::mesh::MeshHit>| h.map(|h| (h.t + 0.0).to_bits());
            if bits(got) != bits(want) || any != want.is_some() {
                tally.fail(name, "mesh ray", Failure::Miss, || {
                    format!("{ray:?}: got {got:?}, oracle {want:?}")
                });
            }
        }
    }
}

/// Meshes with hostile vertices, built and refit; instanced scenes with hostile transforms.
fn meshes(tally: &mut Tally, rng: &mut Rng, cases: usize) {
    let sphere = accel_testkit::shapes::icosphere(2).normalized(100.0);
    let indices = sphere.flat_indices();
    let clean = sphere.positions();
    let rounds = (cases / 40).max(1);
    for round in 0..rounds {
        let mut vertices = clean.clone();
        for v in vertices.iter_mut() {
            if rng.chance(0.05) {
                *v = Vec3::from(hostile_vec(rng));
            }
        }
        let Some(Ok(mut mesh)) =
            tally.guard("MeshBvh", "build", |_| MeshBvh::new(&vertices, &indices))
        else {
            continue;
        };
        let Ok(mut oracle) = BruteForceMesh::new(&vertices, &indices) else {
            continue;
        };
        if round % 2 == 1 {
            // Refit to other hostile vertices; the oracle follows.
            for v in vertices.iter_mut() {
                if rng.chance(0.05) {
                    *v = Vec3::from(hostile_vec(rng));
                }
            }
            if tally
                .guard("MeshBvh", "refit", |_| mesh.refit(&vertices))
                .is_none()
            {
                continue;
            }
            oracle = BruteForceMesh::new(&vertices, &indices).expect("the same indices");
        }
        tally.case("MeshBvh", "validate");
        if let Err(e) = mesh.validate() {
            tally.fail("MeshBvh", "validate", Failure::Leak, || format!("{e:?}"));
        }
        if mesh.bounds().min.is_nan() || mesh.bounds().max.is_nan() {
            tally.fail("MeshBvh", "bounds", Failure::Nan, || "NaN bounds".into());
        }
        for _ in 0..20 {
            let ray = if rng.bool() {
                hostile_ray(rng)
            } else {
                Ray::new(rng.vec3a(-150.0, 150.0), rng.unit_vector())
            };
            check_mesh(tally, "MeshBvh", &mesh, &oracle, &ray);
        }
        // Instances under hostile transforms: the rejected ones are left out, the rest
        // answer as their mesh does in its own space.
        let mesh = Arc::new(mesh);
        let transforms: Vec<Affine3A> = (0..6)
            .map(|_| {
                if rng.chance(0.5) {
                    Affine3A::from_cols_array(&std::array::from_fn(|_| hostile(rng)))
                } else {
                    Affine3A::from_translation(Vec3::from(rng.vec3a(-300.0, 300.0)))
                }
            })
            .collect();
        let instances = transforms
            .iter()
            .map(|&m| Instance {
                mesh: mesh.clone(),
                world_from_local: m,
            })
            .collect();
        let Some(scene) = tally.guard("InstancedScene", "build", |_| {
            InstancedScene::new(instances)
        }) else {
            continue;
        };
        for _ in 0..20 {
            let ray = if rng.bool() {
                hostile_ray(rng)
            } else {
                Ray::new(rng.vec3a(-400.0, 400.0), rng.unit_vector())
            };
            let Some(got) = tally.guard("InstancedScene", "ray", |_| {
                scene.cast_ray(&ray, Backfaces::Include)
            }) else {
                continue;
            };
            // An untraceable world ray hits nothing (every walk asks `Ray::is_traceable`
            // first); `Ray::transformed` judges the local ray afresh, and a world direction
            // past `Ray::MAX_DIRECTION` can come out traceable in an instance's space.
            let want = transforms
                .iter()
                .enumerate()
                .filter(|(i, _)| {
                    ray.is_traceable() && !scene.rejected_instances().contains(&(*i as u32))
                })
                .filter_map(|(_, m)| {
                    mesh.cast_ray(&ray.transformed(&m.inverse()), Backfaces::Include)
                })
                .map(|h| h.t)
                .fold(None, |best: Option<f32>, t| {
                    Some(best.map_or(t, |b| b.min(t)))
                });
            if got.is_some_and(|h| h.hit.t.is_nan() || h.hit.geometric_normal.is_nan()) {
                tally.fail("InstancedScene", "ray", Failure::Nan, || format!("{ray:?}"));
            }
            if got.map(|h| h.hit.t) != want {
                tally.fail("InstancedScene", "ray", Failure::Miss, || {
                    format!(
                        "{ray:?}: got {got:?}, per instance {want:?}; transforms {transforms:?}"
                    )
                });
            }
        }
    }
}

/// Every hostile case: `sizes.nonfinite_cases` in all, most of them queries.
pub fn run(tally: &mut Tally, sizes: &Sizes) {
    let mut rng = Rng::new(0x4a4);
    let n = sizes.nonfinite_cases;
    queries(tally, &mut rng, n * 7 / 10);
    let per_index = n / 10 / 5;
    edits(
        tally,
        &mut rng,
        "DynamicBvh",
        DynamicBvh::new(),
        per_index,
        |t| t.validate().map_err(|e| format!("{e:?}")),
    );
    edits(
        tally,
        &mut rng,
        "LooseOctree",
        LooseOctree::new(),
        per_index,
        |t| t.validate().map_err(|e| format!("{e:?}")),
    );
    edits(
        tally,
        &mut rng,
        "Quadtree",
        Quadtree::new(),
        per_index,
        |t| t.validate().map_err(|e| format!("{e:?}")),
    );
    edits(
        tally,
        &mut rng,
        "UniformGrid",
        UniformGrid::new(),
        per_index,
        |t| t.validate().map_err(|e| format!("{e:?}")),
    );
    edits(
        tally,
        &mut rng,
        "AnyIndex BruteForce",
        spatial_accel::query::AnyIndex::new(IndexKind::BruteForce),
        per_index,
        |_| Ok(()),
    );
    meshes(tally, &mut rng, n * 2 / 10);
}
