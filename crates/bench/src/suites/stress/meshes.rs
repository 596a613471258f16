//! Closed meshes (testkit's cube and spheres, and the bunny where it is closed) placed far
//! from the origin, huge and tiny, hit by segments from a point outside to a point inside.
//!
//! Such a segment crosses the surface of a closed mesh, so a watertight test must report a
//! hit (Woop, Benthin and Wald 2013): the families below aim it where tests leak, along the
//! axes, through vertices and the midpoints of shared edges, and grazing a face. Every
//! structure's closest hit must also be the oracle's (`BruteForceMesh`), to the bit.

use super::{Failure, Sizes, Tally};
use accel_testkit::{Mesh, Rng, shapes};
use glam::{Affine3A, DVec3, Vec3};
use spatial_accel::mesh::{Instance, InstancedScene, MeshBvh, SpatialSplits};
use spatial_accel::query::{BruteForceMesh, TriangleQuery};
use spatial_accel::{
    Backfaces, BuildConfig, Bvh, DynamicBvh, Ray, SpatialQuery, Triangle, WatertightRay,
};
use std::sync::Arc;

/// Where a mesh is put: the offset of its centre and its half size. Each keeps the f32
/// spacing at the offset below 1e-4 of the size, so the margins below outlast the rounding.
const PLACEMENTS: [(f64, f64); 8] = [
    (0.0, 1.0),
    (0.0, 1e-4),
    (0.0, 1e4),
    (1e3, 1.0),
    (1e4, 2.0),
    (1e5, 10.0),
    (1e6, 1e2),
    (1e7, 1e4),
];

/// How far inside the surface (in units of the half size) an interior point must lie.
const MARGIN: f64 = 0.02;

/// A test mesh in unit space (|winding number| about 1 inside: testkit's UV sphere winds
/// inwards, and with back faces included the orientation does not matter) (half size 1), whether it is convex, and points inside it.
struct Shape {
    name: &'static str,
    mesh: Mesh,
    convex: bool,
    inside: Vec<DVec3>,
}

fn shapes_under_test(rng: &mut Rng) -> Vec<Shape> {
    let mut out = vec![
        ("cube", shapes::cube(), true),
        ("icosphere", shapes::icosphere(3), true),
        ("uv sphere", shapes::uv_sphere(12, 20, 1.0), true),
    ];
    let bunny = accel_testkit::bunny();
    if bunny.check_closed().is_ok() {
        out.push(("bunny", bunny, false));
    }
    out.into_iter()
        .map(|(name, mesh, convex)| {
            let mesh = mesh.normalized(2.0);
            let mut inside = Vec::new();
            let mut tries = 0;
            while inside.len() < 12 && tries < 4000 {
                tries += 1;
                let p = DVec3::new(
                    rng.range_f64(-0.9, 0.9),
                    rng.range_f64(-0.9, 0.9),
                    rng.range_f64(-0.9, 0.9),
                );
                if mesh.winding_number(p).abs() > 0.5 && mesh.distance_to_surface(p) > MARGIN {
                    inside.push(p);
                }
            }
            Shape {
                name,
                mesh,
                convex,
                inside,
            }
        })
        .collect()
}

/// The segments of one shape, in unit space: (family, outside point, inside point). An
/// outside point lies beyond the shape's box (|p| > sqrt(3) > every corner).
fn segments(rng: &mut Rng, shape: &Shape, n: usize) -> Vec<(&'static str, DVec3, DVec3)> {
    let mut out = Vec::new();
    let mesh = &shape.mesh;
    let edges = mesh.edges();
    for i in 0..n {
        let c = shape.inside[i % shape.inside.len()];
        let dir = rng.unit_vector().as_dvec3();
        out.push(("random", c + dir * 3.0, c));
        let mut o = c;
        o[i % 3] = if rng.bool() { 3.0 } else { -3.0 };
        out.push(("axis-parallel", o, c));
        // Through a vertex, and through the midpoint of a shared edge, on to the inside.
        let v = mesh.vertices[rng.below(mesh.vertices.len())].as_dvec3();
        out.push(("vertex", c + (v - c).normalize() * 3.5, c));
        let [a, b] = edges[rng.below(edges.len())];
        let m = (mesh.vertices[a as usize].as_dvec3() + mesh.vertices[b as usize].as_dvec3()) * 0.5;
        out.push(("shared edge", c + (m - c).normalize() * 3.5, c));
        if shape.convex {
            // Just under a vertex, from far along a tangent: the segment meets the surface
            // at a grazing angle.
            let inner = v * (1.0 - 2.0 * MARGIN);
            let tangent = v.cross(rng.unit_vector().as_dvec3()).normalize();
            out.push(("grazing", inner + tangent * 3.5 + v * (4.0 * MARGIN), inner));
        }
    }
    out.retain(|(_, o, c)| o.length() > 1.75 && shape.mesh.winding_number(*c).abs() > 0.5);
    out
}

/// The structures over one placed mesh, each answering a ray with its closest hit.
type Caster<'a> = (&'static str, Box<dyn Fn(&Ray) -> (Option<f32>, bool) + 'a>);

fn casters<'a>(
    vertices: &'a [Vec3],
    indices: &'a [u32],
    tris: &'a [Triangle],
    local: Arc<MeshBvh>,
    place: Affine3A,
) -> Vec<Caster<'a>> {
    let bf = Backfaces::Include;
    let mut out: Vec<Caster<'a>> = Vec::new();
    if let Ok(m) = MeshBvh::new(vertices, indices) {
        out.push((
            "MeshBvh",
            Box::new(move |r| (m.cast_ray(r, bf).map(|h| h.t), m.cast_ray_any(r, bf))),
        ));
    }
    if let Ok(m) = MeshBvh::with_config(vertices, indices, &BuildConfig::default()) {
        out.push((
            "MeshBvh whole",
            Box::new(move |r| (m.cast_ray(r, bf).map(|h| h.t), m.cast_ray_any(r, bf))),
        ));
    }
    if let Ok(m) = MeshBvh::with_spatial_splits(
        vertices,
        indices,
        &BuildConfig::default(),
        &SpatialSplits::default(),
    ) {
        out.push((
            "MeshBvh sbvh",
            Box::new(move |r| (m.cast_ray(r, bf).map(|h| h.t), m.cast_ray_any(r, bf))),
        ));
    }
    let boxes: Vec<_> = tris.iter().map(Triangle::aabb).collect();
    let bvh = Bvh::build(&boxes, &BuildConfig::default());
    out.push((
        "Bvh + watertight",
        Box::new(move |r| {
            let wt = WatertightRay::new(r);
            let t = bvh
                .cast_ray(r, |p, _| wt.intersect(&tris[p as usize], bf).map(|h| h.t))
                .map(|h| h.t);
            let any = bvh
                .cast_ray_any(r, |p, _| wt.intersect(&tris[p as usize], bf).is_some())
                .is_some();
            (t, any)
        }),
    ));
    let mut dynamic = DynamicBvh::new();
    for (i, b) in boxes.iter().enumerate() {
        let _ = dynamic.insert(i as u32, *b);
    }
    out.push((
        "DynamicBvh + watertight",
        Box::new(move |r| {
            let wt = WatertightRay::new(r);
            let t = dynamic
                .cast_ray(r, |p, _| wt.intersect(&tris[p as usize], bf).map(|h| h.t))
                .map(|h| h.t);
            (t, t.is_some())
        }),
    ));
    let scene = InstancedScene::new(vec![Instance {
        mesh: local,
        world_from_local: place,
    }]);
    out.push((
        "InstancedScene",
        Box::new(move |r| {
            (
                scene.cast_ray(r, bf).map(|h| h.hit.t),
                scene.cast_ray_any(r, bf),
            )
        }),
    ));
    out
}

/// Every shape at every placement, every ray family.
pub fn run(tally: &mut Tally, sizes: &Sizes) {
    let mut rng = Rng::new(0xc105ed);
    for shape in shapes_under_test(&mut rng) {
        let segs = segments(&mut rng, &shape, sizes.mesh_rays);
        let indices = shape.mesh.flat_indices();
        for (offset, half) in PLACEMENTS {
            let centre = DVec3::new(offset, -0.6 * offset, 0.8 * offset);
            let world = |p: DVec3| (centre + p * half).as_vec3a();
            let vertices: Vec<Vec3> = shape
                .mesh
                .vertices
                .iter()
                .map(|v| world(v.as_dvec3()).into())
                .collect();
            let tris: Vec<Triangle> = shape
                .mesh
                .indices
                .iter()
                .map(|t| {
                    Triangle::new(
                        vertices[t[0] as usize],
                        vertices[t[1] as usize],
                        vertices[t[2] as usize],
                    )
                })
                .collect();
            // The instance: the mesh scaled in its own space, moved by the transform.
            let local: Vec<Vec3> = shape
                .mesh
                .vertices
                .iter()
                .map(|v| (v.as_dvec3() * half).as_vec3())
                .collect();
            let Ok(local) = MeshBvh::new(&local, &indices) else {
                continue;
            };
            let place = Affine3A::from_translation(centre.as_vec3());
            let oracle = BruteForceMesh::new(&vertices, &indices).expect("a triangle list");
            let name = |s: &str| format!("{s} ({}, {offset:e}, x{half:e})", shape.name);
            let all_casters = casters(&vertices, &indices, &tris, Arc::new(local), place);
            for &(family, o, c) in &segs {
                let ray = Ray::segment(world(o), world(c));
                let want = oracle.cast_ray(&ray, Backfaces::Include);
                let structure = "BruteForceMesh".to_string();
                tally.case(&structure, family);
                if want.is_none() {
                    tally.fail(&structure, family, Failure::Miss, || {
                        format!("{} {offset:e} {half:e}: {ray:?}", shape.name)
                    });
                }
                for (cname, cast) in &all_casters {
                    let structure = cname.to_string();
                    let Some((t, any)) = tally.guard(&structure, family, |_| cast(&ray)) else {
                        continue;
                    };
                    // The instance's ray is another float ray (moved into its space): it
                    // must hit, but need not match the world-space oracle to the bit.
                    let exact = *cname != "InstancedScene";
                    let wrong = t.is_none()
                        || !any
                        || (exact && t.map(f32::to_bits) != want.map(|h| h.t.to_bits()));
                    if t.is_some_and(f32::is_nan) {
                        tally.fail(&structure, family, Failure::Nan, || name("NaN t"));
                    }
                    if wrong {
                        tally.fail(&structure, family, Failure::Miss, || {
                            format!(
                                "{}: {ray:?} got {t:?}/{any}, oracle {:?}",
                                name(cname),
                                want.map(|h| h.t)
                            )
                        });
                    }
                }
            }
        }
    }
}
