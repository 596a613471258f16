//! The conformance suite: every structure of the crate, and a toy one that has no walk of its
//! own, answers every query of the shared interfaces as the brute-force oracle does, on
//! random, clustered and adversarial inputs with fixed seeds.
//!
//! - [`spatial`]: [`SpatialQuery`] over fixed boxes (every static tree, the dynamic trees, the
//!   pair, the run-time choice, the oracle itself).
//! - [`edits`]: [`DynamicIndex`] through runs of inserts, moves, removals and refused edits.
//! - [`triangles`]: [`TriangleQuery`] on meshes.
//! - [`nodes`]: the nodes every structure shows a debug overlay, by depth.

mod edits;
mod grid;
mod grid_views;
mod nodes;
mod octree;
#[path = "../scenes/mod.rs"]
mod scenes;
mod spatial;
mod toy_tree;
mod triangles;

use accel_testkit::{BoxScene, Rng, box_scene};
use edits::check_edits;
use glam::{Vec3, Vec3A};
use spatial::check_queries;
use spatial_accel::bsp::BspTree;
use spatial_accel::bvh::SphereBvh;
use spatial_accel::bvh::validate::validate_tree;
use spatial_accel::bvh::wide::{Bvh4, Bvh8, Bvh16, QBvh8};
use spatial_accel::dynamic::{DynamicBvh, LayeredIndex, StaticDynamicPair};
use spatial_accel::kdtree::{KdBuild, KdTree, KdTreeConfig};
use spatial_accel::mesh::{MeshBvh, SpatialSplits};
use spatial_accel::query::{
    AnyHandle, AnyIndex, BruteForceIndex, DynamicIndex, IndexError, IndexKind, KeyedEntry,
    KeyedList,
};
use spatial_accel::{Aabb, BuildConfig, Bvh, SplitStrategy};
use toy_tree::ToyTree;
use triangles::check_triangles;

/// A scene of the suite: its name, its `(id, box)` entries and the seed of its queries.
type Scene = (String, Vec<(u32, Aabb)>, u64);

/// The box scenes every structure is checked on.
fn scenes() -> Vec<Scene> {
    let mut out = Vec::new();
    for (kind, n) in [
        (BoxScene::Uniform, 400),
        (BoxScene::Clustered, 300),
        (BoxScene::Degenerate, 200),
        (BoxScene::Uniform, 1),
        (BoxScene::Uniform, 0),
    ] {
        let seed = 0x5eed ^ n as u64 ^ ((kind as u64) << 20);
        let boxes = box_scene(kind, n, seed);
        let entries = boxes
            .into_iter()
            .enumerate()
            .map(|(i, b)| (i as u32, b))
            .collect();
        out.push((format!("{kind:?}/{n}"), entries, seed));
    }
    out
}

fn boxes_of(entries: &[(u32, Aabb)]) -> Vec<Aabb> {
    entries.iter().map(|&(_, b)| b).collect()
}

#[test]
fn the_keyed_list_of_movers() {
    for (scene, entries, seed) in scenes() {
        let mut list = KeyedList::new();
        // Keys spread and out of order, as entity indices are; ids are the scene's.
        for (i, &(id, b)) in entries.iter().enumerate().rev() {
            list.insert(i as u32 * 5 + 2, 7, id, b, 0).unwrap();
        }
        list.validate().unwrap();
        check_queries(&format!("KeyedList, {scene}"), &list, &entries, seed);
    }
}

/// The keyed list's chunk bounds through the life of a list of movers: entries in spatial
/// order (so that chunks cover small regions and queries skip them), then frames of moves
/// (small wobbles, leaps across the scene, through one thread or several), removals and new
/// entries, the bounds tightened in some frames and not in others. Every query must still
/// answer as the oracle over the entries' current boxes: a move out of its chunk that left
/// the chunk current would lose the entry.
#[test]
fn the_keyed_list_through_moves_removals_and_tightening() {
    let mut skipped = 0;
    for (scene, mut entries, seed) in scenes() {
        let mut rng = Rng::new(seed ^ 0xc4c);
        entries.sort_by(|a, b| a.1.center().x.total_cmp(&b.1.center().x));
        let extent = entries.iter().fold(Aabb::EMPTY, |acc, (_, b)| acc.union(b));
        let mut list = KeyedList::new();
        for (key, &(id, b)) in entries.iter().enumerate() {
            list.insert(key as u32, 0, id, b, 0).unwrap();
        }
        let mut next_key = entries.len() as u32;
        for frame in 0..4u32 {
            let moved: Vec<KeyedEntry> = list
                .entries()
                .iter()
                .filter(|_| rng.below(3) == 0)
                .copied()
                .collect();
            let moves: Vec<(u32, Aabb)> = moved
                .iter()
                .map(|e| {
                    let shift = if rng.below(100) == 0 {
                        // A leap across the scene: out of any chunk's margin.
                        rng.vec3a(-1.0, 1.0) * extent.extent().max_element().max(1.0)
                    } else {
                        rng.vec3a(-0.3, 0.3)
                    };
                    (e.key, Aabb::new(e.bounds.min + shift, e.bounds.max + shift))
                })
                .collect();
            if frame % 2 == 0 {
                for &(key, b) in &moves {
                    let at = list.position(key, 0).unwrap();
                    list.set_bounds(at, b, frame);
                }
            } else {
                let concurrent = list.concurrent_moves();
                std::thread::scope(|scope| {
                    for part in moves.chunks(moves.len().div_ceil(3).max(1)) {
                        let concurrent = &concurrent;
                        scope.spawn(move || {
                            for &(key, b) in part {
                                // SAFETY: each key is in one part, once.
                                unsafe { concurrent.set_bounds(key, 0, b, frame) }.unwrap();
                            }
                        });
                    }
                });
            }
            // Some leave (the last entry moves into each one's place), some join.
            for _ in 0..list.len().min(2) {
                let key = list.entries()[rng.below(list.len())].key;
                list.remove(key, 0).unwrap();
            }
            for _ in 0..5 {
                let id = 10_000 + next_key;
                let b = Aabb::from_center_half_extents(rng.vec3a(-20.0, 20.0), Vec3A::splat(0.5));
                list.insert(next_key, 0, id, b, frame).unwrap();
                next_key += 1;
            }
            if frame % 3 != 1 {
                list.tighten_chunk_bounds();
                assert_eq!(list.stale_chunk_count(), 0);
            }
            list.validate().unwrap();
            let now: Vec<(u32, Aabb)> = list.entries().iter().map(|e| (e.id, e.bounds)).collect();
            let name = format!("KeyedList, {scene}, frame {frame}");
            check_queries(&name, &list, &now, seed + u64::from(frame));
            let probe = Aabb::from_center_half_extents(extent.center(), extent.extent() * 0.1);
            skipped += list
                .chunks()
                .filter(|c| c.bounds.is_some_and(|b| !b.intersects_aabb(&probe)))
                .count();
        }
    }
    assert!(skipped > 10, "only {skipped} chunks could be skipped");
}

#[test]
fn the_oracle_agrees_with_itself_and_as_a_tree() {
    for (scene, entries, seed) in scenes() {
        let list = BruteForceIndex::from_boxes(&boxes_of(&entries));
        check_queries(&format!("brute force, {scene}"), &list, &entries, seed);
        // The list seen as a one-leaf tree, through the shared walks.
        let as_tree = spatial_accel::query::walks::nearest_k(&list, Vec3A::ZERO, 5, |id| {
            entries[id as usize]
                .1
                .distance_squared_to_point(Vec3A::ZERO)
        });
        assert_eq!(
            as_tree,
            spatial_accel::SpatialQuery::nearest_k(&list, Vec3A::ZERO, 5, |id| {
                entries[id as usize]
                    .1
                    .distance_squared_to_point(Vec3A::ZERO)
            })
        );
    }
}

#[test]
fn static_trees_of_every_shape() {
    let configs = [
        BuildConfig::default(),
        BuildConfig::with_split(SplitStrategy::Midpoint),
        BuildConfig::with_split(SplitStrategy::Lbvh),
        BuildConfig::with_split(SplitStrategy::PLOC),
        BuildConfig {
            max_leaf_size: 1,
            ..BuildConfig::default()
        },
    ];
    for (scene, entries, seed) in scenes() {
        let boxes = boxes_of(&entries);
        for (c, config) in configs.iter().enumerate() {
            let name = |shape: &str| format!("{shape}, config {c}, {scene}");
            let bvh = Bvh::build(&boxes, config);
            check_queries(&name("Bvh"), &bvh, &entries, seed);
            check_queries(&name("Bvh4"), &Bvh4::from_bvh(&bvh), &entries, seed);
            check_queries(&name("Bvh8"), &Bvh8::from_bvh(&bvh), &entries, seed);
            let mut wide = Bvh16::from_bvh(&bvh);
            check_queries(&name("Bvh16"), &wide, &entries, seed);
            wide.inline_single_leaves();
            check_queries(&name("Bvh16, ids inlined"), &wide, &entries, seed);
            check_queries(&name("QBvh8"), &QBvh8::from_bvh(&bvh), &entries, seed);
            let spheres = SphereBvh::from_bvh(&bvh, &boxes);
            check_queries(&name("SphereBvh"), &spheres, &entries, seed);
        }
    }
}

#[test]
fn dynamic_trees_and_the_pair() {
    for (scene, entries, seed) in scenes() {
        let mut tree = DynamicBvh::new();
        for &(id, b) in &entries {
            tree.insert(id, b).unwrap();
        }
        tree.maintain();
        check_queries(&format!("DynamicBvh, {scene}"), &tree, &entries, seed);

        // The first half static, the rest dynamic, ids kept.
        let half = entries.len() / 2;
        let static_tree = Bvh::build(&boxes_of(&entries[..half]), &BuildConfig::default());
        let mut pair = StaticDynamicPair::new(static_tree, DynamicBvh::new());
        for &(id, b) in &entries[half..] {
            pair.dynamic_mut().insert(id, b).unwrap();
        }
        pair.dynamic_mut().maintain();
        check_queries(&format!("pair, {scene}"), &pair, &entries, seed);
        pair.snapshot_dynamic_for_rays(&BuildConfig::default());
        check_queries(
            &format!("pair with ray snapshot, {scene}"),
            &pair,
            &entries,
            seed,
        );

        for kind in IndexKind::ALL {
            let mut index = AnyIndex::new(kind);
            for &(id, b) in &entries {
                index.insert(id, b).unwrap();
            }
            index.maintain(std::time::Duration::ZERO);
            check_queries(
                &format!("AnyIndex {kind:?}, {scene}"),
                &index,
                &entries,
                seed,
            );

            // The same halves as the pair's, the dynamic one of this kind.
            let static_tree = Bvh::build(&boxes_of(&entries[..half]), &BuildConfig::default());
            let mut layers = LayeredIndex::new(static_tree, AnyIndex::new(kind));
            for &(id, b) in &entries[half..] {
                layers.dynamic_mut().insert(id, b).unwrap();
            }
            layers.dynamic_mut().maintain(std::time::Duration::ZERO);
            check_queries(
                &format!("LayeredIndex over {kind:?}, {scene}"),
                &layers,
                &entries,
                seed,
            );
        }
    }
}

#[test]
fn a_toy_tree_gets_every_query_from_the_shared_walks() {
    for (scene, entries, seed) in scenes() {
        let toy = ToyTree::build(&entries);
        let boxes = boxes_of(&entries);
        validate_tree(&toy, toy.node_count(), entries.len(), |id| {
            boxes.get(id as usize).copied()
        })
        .unwrap();
        check_queries(&format!("toy tree, {scene}"), &toy, &entries, seed);
    }
}

#[test]
fn every_dynamic_index_through_random_edits() {
    for seed in [1, 2, 3] {
        check_edits("DynamicBvh", DynamicBvh::new(), 48, seed);
        check_edits("BruteForceIndex", BruteForceIndex::new(), 48, seed);
        for kind in IndexKind::ALL {
            check_edits(&format!("AnyIndex {kind:?}"), AnyIndex::new(kind), 48, seed);
        }
    }
}

#[test]
fn a_handle_of_another_kind_is_stale() {
    let mut bvh = AnyIndex::new(IndexKind::DynamicBvh);
    let mut list = AnyIndex::new(IndexKind::BruteForce);
    let b = Aabb::new(Vec3A::ZERO, Vec3A::ONE);
    let from_bvh: AnyHandle = bvh.insert(1, b).unwrap();
    let from_list: AnyHandle = list.insert(2, b).unwrap();
    assert_eq!(list.update(from_bvh, b), Err(IndexError::StaleHandle));
    assert_eq!(bvh.remove(from_list), Err(IndexError::StaleHandle));
    assert_eq!((bvh.len(), list.len()), (1, 1));
}

#[test]
fn meshes_against_brute_force() {
    let bunny = accel_testkit::bunny();
    let (vertices, indices) = (bunny.positions(), bunny.flat_indices());
    let mesh = MeshBvh::new(&vertices, &indices).unwrap();
    check_triangles("MeshBvh, bunny", &mesh, &vertices, &indices, 11);

    // A soup of large and small overlapping triangles, which the pre-split and spatial-split
    // builds cut.
    let mut rng = Rng::new(12);
    let mut soup: Vec<Vec3> = Vec::new();
    for i in 0..600 {
        let size = if i % 10 == 0 { 40.0 } else { 2.0 };
        let base = rng.vec3(-30.0, 30.0);
        soup.extend((0..3).map(|_| base + rng.vec3(-size, size)));
    }
    let soup_indices: Vec<u32> = (0..soup.len() as u32).collect();
    let mesh = MeshBvh::new(&soup, &soup_indices).unwrap();
    check_triangles("MeshBvh, soup", &mesh, &soup, &soup_indices, 13);
    let sbvh = MeshBvh::with_spatial_splits(
        &soup,
        &soup_indices,
        &BuildConfig::default(),
        &SpatialSplits::default(),
    )
    .unwrap();
    check_triangles(
        "MeshBvh with spatial splits, soup",
        &sbvh,
        &soup,
        &soup_indices,
        14,
    );
}

#[test]
fn bsp_trees_against_brute_force() {
    let bunny = accel_testkit::bunny();
    let (vertices, indices) = (bunny.positions(), bunny.flat_indices());
    let tree = BspTree::new(&vertices, &indices).unwrap();
    tree.validate().unwrap();
    check_triangles("BspTree, bunny", &tree, &vertices, &indices, 21);

    // Large triangles through each other, cut many times, with degenerate and non-finite
    // ones among them: the rays test the whole source of every piece they reach.
    let mut rng = Rng::new(22);
    let mut soup: Vec<Vec3> = Vec::new();
    for i in 0..300 {
        let size = if i % 3 == 0 { 12.0 } else { 2.0 };
        let base = rng.vec3(-10.0, 10.0);
        soup.extend((0..3).map(|_| base + rng.vec3(-size, size)));
    }
    soup.extend([Vec3::ONE, Vec3::ONE, Vec3::ONE]);
    soup.extend([Vec3::ZERO, Vec3::splat(3.0), Vec3::splat(6.0)]);
    soup.extend([Vec3::ZERO, Vec3::NAN, Vec3::X]);
    let soup_indices: Vec<u32> = (0..soup.len() as u32).collect();
    let tree = BspTree::new(&soup, &soup_indices).unwrap();
    tree.validate().unwrap();
    assert!(tree.stats().splits > 100, "{:?}", tree.stats());
    assert_eq!((tree.stats().degenerate, tree.stats().non_finite), (2, 1));
    check_triangles("BspTree, soup", &tree, &soup, &soup_indices, 23);
}

/// The meshes the kd-tree is checked on: the bunny, a soup of large and small overlapping
/// triangles, a closed icosphere, the test kit's random soup and a small version of the
/// benchmarks' scene (bunny copies among large triangles), each as vertices and indices.
fn kd_meshes() -> Vec<(&'static str, Vec<Vec3>, Vec<u32>)> {
    let mesh = |m: accel_testkit::Mesh| (m.positions(), m.flat_indices());
    let mut out = Vec::new();
    let (v, i) = mesh(accel_testkit::bunny());
    out.push(("bunny", v, i));
    let mut rng = Rng::new(21);
    let mut soup: Vec<Vec3> = Vec::new();
    for k in 0..600 {
        let size = if k % 10 == 0 { 40.0 } else { 2.0 };
        let base = rng.vec3(-30.0, 30.0);
        soup.extend((0..3).map(|_| base + rng.vec3(-size, size)));
    }
    let soup_indices = (0..soup.len() as u32).collect();
    out.push(("large and small soup", soup, soup_indices));
    let (v, i) = mesh(accel_testkit::shapes::icosphere(3));
    out.push(("icosphere", v, i));
    let (v, i) = mesh(accel_testkit::shapes::triangle_soup(&mut rng, 2_000));
    out.push(("test kit soup", v, i));
    let scene: Vec<Vec3> = accel_testkit::triangle_scene(12_000, 22)
        .iter()
        .flat_map(|t| t.vertices.map(Vec3::from))
        .collect();
    let scene_indices = (0..scene.len() as u32).collect();
    out.push(("bunny scene", scene, scene_indices));
    out
}

#[test]
fn kd_trees_against_brute_force() {
    for (k, (name, vertices, indices)) in kd_meshes().into_iter().enumerate() {
        let tree = KdTree::new(&vertices, &indices).unwrap();
        tree.validate(&vertices, &indices).unwrap();
        check_triangles(
            &format!("KdTree, {name}"),
            &tree,
            &vertices,
            &indices,
            31 + k as u64,
        );
    }
    // The sort-each-level build on the bunny (it gives the same tree; see tests/kdtree.rs),
    // and a tree with costs that split far more, deeper and with more straddling.
    let bunny = accel_testkit::bunny();
    let (vertices, indices) = (bunny.positions(), bunny.flat_indices());
    for (name, config) in [
        (
            "sort each level",
            KdTreeConfig::with_build(KdBuild::SortEachLevel),
        ),
        (
            "cheap traversal",
            KdTreeConfig {
                traversal_cost: 1.0,
                intersection_cost: 80.0,
                empty_bonus: 0.5,
                ..KdTreeConfig::default()
            },
        ),
    ] {
        let tree = KdTree::with_config(&vertices, &indices, &config).unwrap();
        tree.validate(&vertices, &indices).unwrap();
        check_triangles(
            &format!("KdTree {name}, bunny"),
            &tree,
            &vertices,
            &indices,
            41,
        );
    }
}
