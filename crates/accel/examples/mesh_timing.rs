//! Prints mesh BVH build rate and refit cost per triangle on a ~1M-triangle sphere, with
//! obvhs 0.3.3 doing the same work in the same run for scale: its BVH2 (fastest and medium
//! presets) and CWBVH (medium) builds from triangles, and a BVH2 refit from moved vertices
//! (new triangles, leaf boxes, `refit_all`). Best of 3 builds and 5 refits each.
//!
//! `cargo run --release -p accel --example mesh_timing`

use accel::mesh::MeshBvh;
use accel::{BuildConfig, SplitStrategy};
use glam::{Vec3, Vec3A};
use obvhs::BvhBuildParams;
use std::time::{Duration, Instant};

/// The best of `runs` timings of `f`, in seconds.
fn best_of(runs: usize, mut f: impl FnMut()) -> f64 {
    (0..runs)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .fold(f64::INFINITY, f64::min)
}

fn obvhs_tris(vertices: &[Vec3], indices: &[u32]) -> Vec<obvhs::triangle::Triangle> {
    indices
        .chunks_exact(3)
        .map(|t| obvhs::triangle::Triangle {
            v0: Vec3A::from(vertices[t[0] as usize]),
            v1: Vec3A::from(vertices[t[1] as usize]),
            v2: Vec3A::from(vertices[t[2] as usize]),
        })
        .collect()
}

fn main() {
    let sphere = accel_testkit::shapes::uv_sphere(708, 708, 10.0);
    let (vertices, indices) = (sphere.positions(), sphere.flat_indices());
    let n = indices.len() / 3;
    let rate = |seconds: f64| n as f64 / seconds / 1e6;
    let mut mesh = MeshBvh::new(&vertices, &indices).expect("valid mesh");
    let ours = best_of(3, || {
        mesh = MeshBvh::new(&vertices, &indices).expect("valid mesh")
    });
    println!("build, {n} triangles (M tris/s, including making the triangle boxes):");
    println!(
        "  accel MeshBvh::new (16-wide, packets; PLOC at this size): {:.2}",
        rate(ours)
    );
    for (name, split) in [
        ("PLOC_FASTEST", SplitStrategy::PLOC_FASTEST),
        ("binned SAH 16", SplitStrategy::BinnedSah { bins: 16 }),
    ] {
        let config = BuildConfig::with_split(split);
        let t = best_of(3, || {
            std::hint::black_box(
                MeshBvh::with_config(&vertices, &indices, &config).expect("valid mesh"),
            );
        });
        println!("  accel MeshBvh::with_config({name}): {:.2}", rate(t));
    }
    let tris = obvhs_tris(&vertices, &indices);
    for (name, params) in [
        ("fastest", BvhBuildParams::fastest_build()),
        ("medium", BvhBuildParams::medium_build()),
    ] {
        let t = best_of(3, || {
            std::hint::black_box(obvhs::bvh2::builder::build_bvh2_from_tris(
                &tris,
                params,
                &mut Duration::default(),
            ));
        });
        println!("  obvhs bvh2 {name}: {:.2}", rate(t));
    }
    let t = best_of(3, || {
        std::hint::black_box(obvhs::cwbvh::builder::build_cwbvh_from_tris(
            &tris,
            BvhBuildParams::medium_build(),
            &mut Duration::default(),
        ));
    });
    println!("  obvhs cwbvh medium: {:.2}", rate(t));

    // A skinned-like pose: every vertex displaced a little.
    let moved: Vec<Vec3> = vertices
        .iter()
        .enumerate()
        .map(|(i, v)| *v * (1.0 + 0.01 * (i % 7) as f32))
        .collect();
    let ours = best_of(5, || mesh.refit(&moved).expect("same vertex count"));
    let mut bvh2 = obvhs::bvh2::builder::build_bvh2_from_tris(
        &tris,
        BvhBuildParams::medium_build(),
        &mut Duration::default(),
    );
    let mut tris = tris;
    let theirs = best_of(5, || {
        for (tri, t) in tris.iter_mut().zip(indices.chunks_exact(3)) {
            *tri = obvhs::triangle::Triangle {
                v0: Vec3A::from(moved[t[0] as usize]),
                v1: Vec3A::from(moved[t[1] as usize]),
                v2: Vec3A::from(moved[t[2] as usize]),
            };
        }
        for node in bvh2.nodes.iter_mut().filter(|n| n.is_leaf()) {
            let (first, count) = (node.first_index as usize, node.prim_count as usize);
            let b = bvh2.primitive_indices[first..first + count]
                .iter()
                .fold(obvhs::aabb::Aabb::INVALID, |acc, &p| {
                    acc.union(&tris[p as usize].aabb())
                });
            node.set_aabb(b);
        }
        bvh2.refit_all();
    });
    println!("refit after every vertex moved (ns per triangle):");
    println!("  accel MeshBvh::refit: {:.1}", ours * 1e9 / n as f64);
    println!(
        "  obvhs bvh2 (new triangles, leaf boxes, refit_all): {:.1}",
        theirs * 1e9 / n as f64
    );
}
