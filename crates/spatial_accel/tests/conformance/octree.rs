//! The loose octree and the quadtree: the shared checks at several loosenesses, and the cases
//! a loose tree gets wrong first (objects larger than the world or far outside it, everything
//! in one cell, boxes on cell boundaries, rays along cell planes and through cell corners).
//! Long runs of churn checked against brute force every frame are in [`churn`].

mod churn;

use crate::edits::check_edits;
use crate::scenes;
use crate::spatial::check_queries;
use accel_testkit::Rng;
use core::ops::ControlFlow;
use glam::Vec3A;
use spatial_accel::octree::{LooseTree, OctreeConfig, OctreeConfigError, OctreeHandle};
use spatial_accel::query::{BoundingTree, BruteForceIndex, IndexError};
use spatial_accel::{Aabb, LooseOctree, Quadtree, Ray, SpatialQuery};

const LOOSENESSES: [f32; 3] = [1.25, 1.5, 2.0];

/// A tree of the given settings over `entries`, maintained and validated.
fn build<const AXES: usize>(
    config: OctreeConfig,
    entries: &[(u32, Aabb)],
) -> (LooseTree<AXES>, Vec<OctreeHandle>) {
    let mut tree = LooseTree::<AXES>::with_config(config).expect("valid settings");
    let handles = entries
        .iter()
        .map(|&(id, b)| tree.insert(id, b).expect("valid box"))
        .collect();
    tree.maintain();
    tree.validate().unwrap();
    (tree, handles)
}

/// The default settings, depth from size alone (no limit from the population), spelled out:
/// what the tests of Ulrich's placement rule assume.
fn size_only() -> OctreeConfig {
    OctreeConfig {
        target_occupancy: 0,
        ..OctreeConfig::default()
    }
}

/// Settings with a small world cube, so the suite's scenes make the root grow.
fn small_world(looseness: f32) -> OctreeConfig {
    OctreeConfig {
        world_half_size: 4.0,
        max_depth: 10,
        ..OctreeConfig::default().with_looseness(looseness)
    }
}

#[test]
fn octrees_and_quadtrees_answer_every_query() {
    for (scene, entries, seed) in scenes() {
        for k in LOOSENESSES {
            let shared = OctreeConfig {
                target_occupancy: 4,
                ..OctreeConfig::default().with_looseness(k)
            };
            for (world, config) in [
                ("default world", OctreeConfig::default().with_looseness(k)),
                ("small world", small_world(k)),
                ("default world, 4 a cell", shared),
            ] {
                let (octree, _) = build::<3>(config, &entries);
                check_queries(
                    &format!("LooseOctree k={k}, {world}, {scene}"),
                    &octree,
                    &entries,
                    seed,
                );
                let (quadtree, _) = build::<2>(config, &entries);
                check_queries(
                    &format!("Quadtree k={k}, {world}, {scene}"),
                    &quadtree,
                    &entries,
                    seed,
                );
            }
        }
    }
}

#[test]
fn octrees_and_quadtrees_through_random_edits() {
    for seed in [1, 2, 3] {
        for k in LOOSENESSES {
            let config = OctreeConfig::default().with_looseness(k);
            let octree = LooseOctree::with_config(config).unwrap();
            check_edits(&format!("LooseOctree k={k}"), octree, 48, seed);
            let quadtree = Quadtree::with_config(config).unwrap();
            check_edits(&format!("Quadtree k={k}"), quadtree, 48, seed);
        }
        let grown = LooseOctree::with_config(small_world(2.0)).unwrap();
        check_edits("LooseOctree, small world", grown, 48, seed);
    }
}

#[test]
fn settings_outside_their_ranges_are_refused() {
    let with = |looseness| OctreeConfig::default().with_looseness(looseness);
    for k in [1.0, 1.25, 4.0] {
        assert!(LooseOctree::with_config(with(k)).is_ok(), "looseness {k}");
    }
    for k in [0.99, 4.01, f32::NAN, f32::INFINITY] {
        assert!(
            matches!(
                LooseOctree::with_config(with(k)),
                Err(OctreeConfigError::LoosenessOutOfRange(_))
            ),
            "looseness {k}"
        );
    }
    for half in [0.0, -1.0, f32::NAN, f32::INFINITY, 1e31] {
        let config = OctreeConfig {
            world_half_size: half,
            ..OctreeConfig::default()
        };
        assert_eq!(
            Quadtree::with_config(config).err(),
            Some(OctreeConfigError::InvalidWorld),
            "half size {half}"
        );
    }
    let world = Aabb::new(Vec3A::new(-5.0, 0.0, 2.0), Vec3A::new(5.0, 0.0, 3.0));
    let config = OctreeConfig::for_world(&world);
    assert_eq!(
        (config.world_center, config.world_half_size),
        (world.center(), 5.0)
    );
    assert_eq!(config.validate(), Ok(()));
    let flat = OctreeConfig::for_world(&Aabb::from_point(Vec3A::ONE));
    assert!(
        LooseOctree::with_config(flat).is_ok(),
        "a point-sized world"
    );
    let too_deep = OctreeConfig {
        world_half_size: 1e-30,
        max_depth: 40,
        ..OctreeConfig::default()
    };
    assert_eq!(
        LooseOctree::with_config(too_deep).err(),
        Some(OctreeConfigError::TooDeep(40))
    );
}

#[test]
fn an_objects_depth_follows_from_its_size() {
    // World half 64, looseness 2: an object of half size r fits the loose cell of every cell
    // of half size r or more that holds its centre, and of none smaller than r / 2.
    let config = OctreeConfig {
        world_half_size: 64.0,
        max_depth: 16,
        ..size_only()
    };
    let mut tree = LooseOctree::with_config(config).unwrap();
    let mut rng = Rng::new(5);
    for _ in 0..300 {
        let r = rng.log_range(0.01, 30.0);
        let b = Aabb::from_center_half_extents(rng.vec3a(-30.0, 30.0), Vec3A::splat(r));
        let h = tree.insert(0, b).unwrap();
        let depth = tree.depth_of(h).unwrap() as i32;
        // Cell half size at depth d: 64 / 2^d.
        let guaranteed = (64.0 / r).log2().floor() as i32;
        assert!(
            depth >= guaranteed.min(16) && depth <= guaranteed + 1,
            "half size {r} kept at depth {depth}"
        );
    }
    tree.maintain();
    tree.validate().unwrap();
}

#[test]
fn a_move_inside_the_loose_cell_is_a_box_write() {
    let mut tree = LooseOctree::with_config(size_only()).unwrap();
    let b = Aabb::from_center_half_extents(Vec3A::new(10.3, 20.7, -5.1), Vec3A::splat(0.4));
    let h = tree.insert(1, b).unwrap();
    tree.insert(2, Aabb::from_point(Vec3A::splat(-300.0)))
        .unwrap();
    tree.maintain();
    let mut moved = 0;
    for step in 1..=200 {
        let offset = Vec3A::new(0.01, -0.005, 0.002) * step as f32;
        let next = Aabb::new(b.min + offset, b.max + offset);
        let (cell, octants) = (tree.loose_cell_of(h).unwrap(), tree.octant_count());
        let changed = tree.update(h, next).unwrap();
        assert_eq!(
            changed,
            tree.loose_cell_of(h).unwrap() != cell,
            "step {step}: Ok(changed) must say whether the entry changed octant"
        );
        if !changed {
            assert_eq!(tree.octant_count(), octants, "a box write made octants");
        }
        moved += usize::from(changed);
        assert_eq!(tree.bounds_of(h), Some(next));
        tree.maintain();
        tree.validate().unwrap();
    }
    // The drift (2 units along x) leaves a loose cell of half size 1 at least once; the
    // hysteresis keeps it from changing octant at every step.
    assert!(
        (1..=4).contains(&moved),
        "a slow drift changed octant {moved} times"
    );
    // A jump far away changes octant.
    let far = Aabb::from_center_half_extents(Vec3A::splat(500.0), Vec3A::splat(0.4));
    assert_eq!(tree.update(h, far), Ok(true));
    tree.maintain();
    tree.validate().unwrap();
}

#[test]
fn stale_handles_and_refused_boxes_change_nothing() {
    let mut tree = Quadtree::new();
    let a = tree.insert(1, Aabb::new(Vec3A::ZERO, Vec3A::ONE)).unwrap();
    assert_eq!(tree.remove(a), Ok(1));
    // The slot is reused with a new generation: the old handle must not name the new entry.
    let b = tree
        .insert(2, Aabb::new(Vec3A::ONE, Vec3A::splat(2.0)))
        .unwrap();
    assert_eq!(OctreeHandle::from_bits(a.to_bits()), a);
    assert_ne!(a, b);
    assert_eq!(tree.id(a), None);
    assert_eq!(tree.bounds_of(a), None);
    assert_eq!(
        tree.update(a, Aabb::from_point(Vec3A::ZERO)),
        Err(IndexError::StaleHandle)
    );
    assert_eq!(tree.remove(a), Err(IndexError::StaleHandle));
    assert_eq!(tree.id(b), Some(2));
    let bad = [
        Aabb::new(Vec3A::splat(f32::NAN), Vec3A::ONE),
        Aabb::new(Vec3A::ONE, Vec3A::ZERO),
        Aabb::new(Vec3A::ZERO, Vec3A::new(1.0, f32::INFINITY, 1.0)),
        Aabb::EVERYTHING,
        Aabb::EMPTY,
    ];
    tree.maintain();
    let octants = tree.octant_count();
    for bad in bad {
        assert_eq!(tree.insert(3, bad).err(), Some(IndexError::InvalidBounds));
        assert_eq!(tree.update(b, bad), Err(IndexError::InvalidBounds));
    }
    assert!(!tree.needs_maintain(), "a refused edit queued work");
    assert_eq!((tree.len(), tree.octant_count()), (1, octants));
    assert_eq!(
        tree.bounds_of(b),
        Some(Aabb::new(Vec3A::ONE, Vec3A::splat(2.0)))
    );
    tree.validate().unwrap();
    tree.clear();
    assert_eq!((tree.id(b), tree.len(), tree.octant_count()), (None, 0, 0));
    tree.validate().unwrap();
}

#[test]
fn objects_larger_than_the_world_and_far_outside_it() {
    let config = OctreeConfig {
        world_half_size: 10.0,
        max_depth: 6,
        ..OctreeConfig::default()
    };
    let world = Aabb::from_center_half_extents(Vec3A::ZERO, Vec3A::splat(10.0));
    let mut rng = Rng::new(8);
    let mut entries: Vec<(u32, Aabb)> = (0..200)
        .map(|i| {
            let b = Aabb::from_center_half_extents(rng.vec3a(-9.0, 9.0), rng.vec3a(0.05, 1.0));
            (i, b)
        })
        .collect();
    let outsiders = [
        // Larger than the world, centred in it.
        Aabb::from_center_half_extents(Vec3A::ZERO, Vec3A::splat(1e4)),
        // Overhanging both sides of the world, centred off it.
        Aabb::new(Vec3A::new(-5e3, -1.0, -1.0), Vec3A::new(3e4, 1.0, 1.0)),
        // Far away in every octant of space.
        Aabb::from_center_half_extents(Vec3A::splat(1e7), Vec3A::ONE),
        Aabb::from_center_half_extents(Vec3A::new(-1e20, 3e19, -2e5), Vec3A::splat(1e3)),
        // A flat slab reaching far along one axis only.
        Aabb::new(Vec3A::new(-1e6, 0.0, 0.0), Vec3A::new(1e6, 0.0, 0.0)),
    ];
    let ids = 1000..1000 + outsiders.len() as u32;
    entries.extend(ids.clone().zip(outsiders));
    for (name, octree) in [("octree", true), ("quadtree", false)] {
        let (handles, outsider_handles) = if octree {
            let (mut tree, handles) = build::<3>(config, &entries);
            check_queries(&format!("{name}, outsiders"), &tree, &entries, 81);
            let root = tree.root_cell().unwrap();
            // It grew to reach the box near -1e20 (the cell's faces, rounded at that size, need
            // not contain the world cube exactly; the loose cells do).
            assert!(
                root.half_extents().x > 1e19,
                "{name}: the root grew: {root:?}"
            );
            for &h in &handles[200..] {
                tree.remove(h).unwrap();
            }
            tree.maintain();
            tree.validate().unwrap();
            assert_eq!(
                tree.root_cell(),
                Some(world),
                "{name}: the root shrank back"
            );
            check_queries(
                &format!("{name}, outsiders gone"),
                &tree,
                &entries[..200],
                82,
            );
            (handles.len(), tree.len())
        } else {
            let (mut tree, handles) = build::<2>(config, &entries);
            check_queries(&format!("{name}, outsiders"), &tree, &entries, 81);
            for &h in &handles[200..] {
                tree.remove(h).unwrap();
            }
            tree.maintain();
            tree.validate().unwrap();
            let root = tree.root_cell().unwrap();
            assert_eq!(
                (root.min.x, root.max.y),
                (-10.0, 10.0),
                "{name}: the root shrank back"
            );
            check_queries(
                &format!("{name}, outsiders gone"),
                &tree,
                &entries[..200],
                82,
            );
            (handles.len(), tree.len())
        };
        assert_eq!((handles, outsider_handles), (205, 200));
    }
}

#[test]
fn a_first_object_far_outside_the_world() {
    let config = OctreeConfig {
        world_half_size: 10.0,
        max_depth: 8,
        ..OctreeConfig::default()
    };
    let mut rng = Rng::new(14);
    for far in [Vec3A::splat(1e6), Vec3A::new(-3e4, 2e4, 5.0)] {
        let mut tree = LooseOctree::with_config(config).unwrap();
        let far_box = Aabb::from_center_half_extents(far, Vec3A::splat(0.5));
        let h = tree.insert(1000, far_box).unwrap();
        tree.maintain();
        tree.validate().unwrap();
        // The root grew to reach the box, then moved down to the world-sized cell around it.
        let root = tree.root_cell().unwrap();
        assert!(root.contains_point(far), "{root:?}");
        assert_eq!(root.half_extents().x, 10.0);
        // Objects in the world make it grow back over both.
        let mut entries: Vec<(u32, Aabb)> = (0..60)
            .map(|i| {
                let b = Aabb::from_center_half_extents(rng.vec3a(-9.0, 9.0), rng.vec3a(0.1, 1.0));
                (i, b)
            })
            .collect();
        for &(id, b) in &entries {
            tree.insert(id, b).unwrap();
        }
        tree.maintain();
        tree.validate().unwrap();
        entries.push((1000, far_box));
        check_queries("far first", &tree, &entries, 15);
        assert_eq!(tree.remove(h), Ok(1000));
        entries.pop();
        tree.maintain();
        tree.validate().unwrap();
        let root = tree.root_cell().unwrap();
        assert_eq!(
            root.half_extents().x,
            10.0,
            "the root shrank back: {root:?}"
        );
        check_queries("far first, gone", &tree, &entries, 16);
    }
}

#[test]
fn a_box_reaching_near_f32_max_stays_at_the_root() {
    let mut tree = LooseOctree::new();
    let huge = Aabb::new(Vec3A::splat(-3e38), Vec3A::splat(3e38));
    let small = Aabb::from_center_half_extents(Vec3A::splat(5.0), Vec3A::splat(0.5));
    let h = tree.insert(1, huge).unwrap();
    tree.insert(2, small).unwrap();
    tree.maintain();
    tree.validate().unwrap();
    assert_eq!(tree.depth_of(h), Some(0));
    let mut found = Vec::new();
    let q = Aabb::from_center_half_extents(Vec3A::splat(-1e30), Vec3A::ONE);
    tree.for_each_overlapping_aabb(&q, |id| {
        found.push(id);
        ControlFlow::Continue(())
    });
    assert!(found.contains(&1));
    // It can move, still too large for any root, and leave.
    let huger = Aabb::new(Vec3A::splat(-3.3e38), Vec3A::splat(3.1e38));
    assert_eq!(tree.update(h, huger), Ok(false));
    tree.maintain();
    tree.validate().unwrap();
    assert_eq!(tree.remove(h), Ok(1));
    tree.maintain();
    tree.validate().unwrap();
    assert_eq!(tree.len(), 1);
}

#[test]
fn everything_in_one_cell() {
    // Off every dividing plane (multiples of 0.5 down to the deepest cells of the default
    // settings), so the tiny boxes' centres fall on the points' side of each.
    let spot = Vec3A::splat(3.1);
    let point = Aabb::from_point(spot);
    let small = Aabb::from_center_half_extents(spot, Vec3A::splat(1e-4));
    let mut entries: Vec<(u32, Aabb)> = (0..1500).map(|i| (i, point)).collect();
    entries.extend((1500..2000).map(|i| (i, small)));
    for k in LOOSENESSES {
        let config = size_only().with_looseness(k);
        let (mut tree, handles) = build::<3>(config, &entries);
        check_queries(&format!("one cell, k={k}"), &tree, &entries, 9);
        // Every entry sits at the deepest level, in one octant right below the root: the
        // cells between would hold nothing but one child, so they are not made.
        assert_eq!(tree.depth(), usize::from(config.max_depth), "k={k}");
        assert_eq!(tree.octant_count(), 2, "k={k}");
        for &h in handles.iter().step_by(2) {
            tree.remove(h).unwrap();
        }
        tree.maintain();
        tree.validate().unwrap();
        let left: Vec<(u32, Aabb)> = entries.iter().copied().skip(1).step_by(2).collect();
        check_queries(&format!("one cell halved, k={k}"), &tree, &left, 10);
        let (quadtree, _) = build::<2>(config, &entries);
        check_queries(
            &format!("quadtree one cell, k={k}"),
            &quadtree,
            &entries,
            11,
        );
    }
}

/// Boxes placed on the dividing planes of a world of half size 16: centred on planes and
/// corners of cells at several depths, faces flush with cell faces, points on corners.
fn boundary_boxes() -> Vec<(u32, Aabb)> {
    let mut out = Vec::new();
    let mut id = 0;
    let mut push = |b: Aabb| {
        out.push((id, b));
        id += 1;
    };
    for depth in 0..5 {
        let cell = 16.0 / (1 << depth) as f32;
        for i in -2i32..=2 {
            for j in -2i32..=2 {
                let corner = Vec3A::new(i as f32 * cell, j as f32 * cell, (i - j) as f32 * cell);
                let half = cell * 0.25;
                push(Aabb::from_point(corner));
                push(Aabb::from_center_half_extents(corner, Vec3A::splat(half)));
                // Faces flush with the cell's faces.
                push(Aabb::new(corner, corner + Vec3A::splat(cell)));
                push(Aabb::new(corner - Vec3A::splat(cell), corner));
                // Flat on a dividing plane.
                push(Aabb::new(
                    Vec3A::new(corner.x, corner.y - half, corner.z - half),
                    Vec3A::new(corner.x, corner.y + half, corner.z + half),
                ));
            }
        }
    }
    out
}

#[test]
fn boxes_exactly_on_cell_boundaries() {
    let entries = boundary_boxes();
    for k in [1.0, 1.25, 1.5, 2.0, 4.0] {
        let config = OctreeConfig {
            world_half_size: 16.0,
            max_depth: 8,
            ..OctreeConfig::default().with_looseness(k)
        };
        let (octree, _) = build::<3>(config, &entries);
        check_queries(&format!("boundaries, k={k}"), &octree, &entries, 12);
        check_planar_rays(&format!("boundaries, k={k}"), &octree, &entries);
        let (quadtree, _) = build::<2>(config, &entries);
        check_queries(
            &format!("quadtree boundaries, k={k}"),
            &quadtree,
            &entries,
            13,
        );
        check_planar_rays(&format!("quadtree boundaries, k={k}"), &quadtree, &entries);
    }
}

#[test]
fn rays_along_cell_planes_and_through_cell_corners() {
    // A lattice of unit boxes, one per cell of depth 3 in a world of half size 16.
    let mut entries = Vec::new();
    for i in 0..8 {
        for j in 0..8 {
            for l in 0..8 {
                let c = Vec3A::new(i as f32, j as f32, l as f32) * 4.0 - Vec3A::splat(14.0);
                entries.push((
                    entries.len() as u32,
                    Aabb::from_center_half_extents(c, Vec3A::ONE),
                ));
            }
        }
    }
    for k in LOOSENESSES {
        let config = OctreeConfig {
            world_half_size: 16.0,
            ..OctreeConfig::default().with_looseness(k)
        };
        let (octree, _) = build::<3>(config, &entries);
        check_planar_rays(&format!("lattice, k={k}"), &octree, &entries);
        let (quadtree, _) = build::<2>(config, &entries);
        check_planar_rays(&format!("quadtree lattice, k={k}"), &quadtree, &entries);
    }
}

/// Rays that lie in the dividing planes of cells of half size 16, 8, 4 and 2 (along them and
/// across them), and rays through the corners where those planes meet, compared with brute
/// force: closest hit, any hit and every hit.
fn check_planar_rays<S: SpatialQuery>(name: &str, tree: &S, entries: &[(u32, Aabb)]) {
    let oracle = BruteForceIndex::from_boxes(&entries.iter().map(|e| e.1).collect::<Vec<_>>());
    let boxes: Vec<Aabb> = entries.iter().map(|e| e.1).collect();
    let hit = |id: u32, r: &Ray| r.intersect_aabb(&boxes[id as usize]);
    let mut rays = Vec::new();
    for plane in [0.0, 16.0, 8.0, -8.0, 4.0, 2.0, -2.0] {
        for axis in 0..3 {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut origin = Vec3A::splat(-40.0);
            origin[axis] = plane;
            for direction in [
                Vec3A::X + Vec3A::Y + Vec3A::Z,
                Vec3A::X,
                Vec3A::Y,
                Vec3A::Z,
                Vec3A::new(1.0, 2.0, 0.5),
            ] {
                // Keep the ray in the plane: no motion on the plane's axis.
                let mut d = direction;
                d[axis] = 0.0;
                if d != Vec3A::ZERO {
                    rays.push(Ray::new(origin, d));
                    rays.push(Ray::new(-origin, -d));
                }
            }
            // Along the line where two dividing planes meet.
            let mut along = Vec3A::splat(plane);
            along[u] = -40.0;
            let mut d = Vec3A::ZERO;
            d[u] = 1.0;
            rays.push(Ray::new(along, d));
            along[v] = 40.0;
            d[v] = -1.0;
            rays.push(Ray::new(along, d));
        }
        // Through corners, on the diagonals.
        for sign in [
            Vec3A::ONE,
            Vec3A::new(1.0, -1.0, 1.0),
            Vec3A::new(-1.0, 1.0, 1.0),
        ] {
            let corner = Vec3A::splat(plane) * sign;
            rays.push(Ray::new(corner - sign * 50.0, sign));
            let across = Vec3A::new(50.0, 30.0, 0.0);
            rays.push(Ray::new(corner + across, -across));
        }
    }
    for ray in rays {
        let want = oracle.cast_ray(&ray, hit).map(|h| h.t);
        let got = tree.cast_ray(&ray, hit).map(|h| h.t);
        assert_eq!(got, want, "{name}: closest hit of {ray:?}");
        let any = tree.cast_ray_any(&ray, |id, r| hit(id, r).is_some());
        assert_eq!(any.is_some(), want.is_some(), "{name}: any hit of {ray:?}");
        let (mut want_all, mut got_all) = (Vec::new(), Vec::new());
        oracle.cast_ray_all(&ray, hit, &mut want_all);
        tree.cast_ray_all(&ray, hit, &mut got_all);
        assert_eq!(got_all, want_all, "{name}: all hits of {ray:?}");
    }
}

#[test]
fn node_bounds_shrink_to_what_is_left() {
    let mut tree = LooseOctree::with_config(size_only()).unwrap();
    let inner = Aabb::from_center_half_extents(Vec3A::splat(1.0), Vec3A::splat(0.5));
    let outer = Aabb::from_center_half_extents(Vec3A::splat(300.0), Vec3A::splat(0.5));
    tree.insert(1, inner).unwrap();
    let h = tree.insert(2, outer).unwrap();
    tree.maintain();
    let root = tree.root().unwrap();
    // Node bounds hold their content with a margin of half an octant's cell at most
    // (`OWN_MARGIN`; the entries here sit in cells of half size 1 or less).
    let holds = |bounds: Aabb, content: Aabb| {
        bounds.contains_aabb(&content) && content.expanded(Vec3A::splat(0.5)).contains_aabb(&bounds)
    };
    assert!(holds(tree.node_bounds(root), inner.union(&outer)));
    let moved = Aabb::from_center_half_extents(Vec3A::splat(1.5), Vec3A::splat(0.25));
    assert_eq!(tree.update(h, moved), Ok(true));
    tree.maintain();
    let root = tree.root().unwrap();
    assert!(holds(tree.node_bounds(root), inner.union(&moved)));
    tree.validate().unwrap();
}

#[test]
fn small_objects_share_the_deepest_octants_the_population_allows() {
    // Tiny boxes spread over the world: by size alone each would sit 12 levels down in an
    // octant of its own. With 4 entries per cell as the aim, the depth limit rises with the
    // population (4 * 4^d cells' worth), and entries at the old limit go down with it.
    let config = OctreeConfig {
        world_half_size: 1000.0,
        target_occupancy: 4,
        ..OctreeConfig::default()
    };
    let mut tree = Quadtree::with_config(config).unwrap();
    let mut rng = Rng::new(31);
    let mut entries = Vec::new();
    for i in 0..10_000u32 {
        let b = Aabb::from_center_half_extents(
            rng.vec3a(-990.0, 990.0) * Vec3A::new(1.0, 1.0, 0.0),
            Vec3A::new(0.5, 0.5, 0.0),
        );
        tree.insert(i, b).unwrap();
        entries.push((i, b));
        if i == 99 || i == 999 || i == 9_999 {
            tree.maintain();
            tree.validate().unwrap();
            // The first depth whose 4^d cells hold the entries four at a time.
            let n = i as usize + 1;
            let limit = (0..).find(|d| 4 * 4usize.pow(*d) >= n).unwrap();
            assert!(
                tree.depth() <= limit as usize,
                "{n} entries at depth {}",
                tree.depth()
            );
            assert!(
                tree.depth() + 1 >= limit as usize,
                "{n} entries at depth {}",
                tree.depth()
            );
        }
    }
    // They share octants: by size alone there would be one or more per entry.
    assert!(
        tree.octant_count() * 5 < entries.len() * 3,
        "{} octants",
        tree.octant_count()
    );
    check_queries("population limit", &tree, &entries, 41);
    // Removing most keeps the limit (it only rises) and every invariant.
    let mut tree2 = Quadtree::with_config(config).unwrap();
    let handles: Vec<_> = entries
        .iter()
        .map(|&(i, b)| tree2.insert(i, b).unwrap())
        .collect();
    for h in handles.iter().skip(100) {
        tree2.remove(*h).unwrap();
    }
    tree2.maintain();
    tree2.validate().unwrap();
    check_queries(
        "population limit, most removed",
        &tree2,
        &entries[..100],
        42,
    );
}
