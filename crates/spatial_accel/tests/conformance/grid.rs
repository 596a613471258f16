//! The uniform grid: the shared checks at the heuristic cell size and at tiny and huge ones,
//! the cases a grid gets wrong first (objects larger than the world, everything in one cell,
//! boxes on cell boundaries, rays along grid lines and through cell corners, rays that walk
//! the cell list instead of the cells), a long run of churn checked against brute force
//! every frame, memory after removing everything, and rays cast from several threads.

use crate::edits::check_edits;
use crate::scenes;
use crate::scenes::random_frustum;
use crate::spatial::check_queries;
use accel_testkit::Rng;
use core::ops::ControlFlow;
use glam::Vec3A;
use spatial_accel::grid::{GridConfig, GridHandle, UniformGrid};
use spatial_accel::query::{BruteForceIndex, DynamicIndex, IndexError};
use spatial_accel::{Aabb, Containment, Ray, RayHit, SpatialQuery, Sphere};
use std::collections::HashMap;
use std::time::Duration;

/// The settings every shared check runs with: the heuristic, cells much smaller than the
/// boxes (most go to the oversize list), cells of the boxes' size, a huge cell (everything
/// in a few cells), and no oversize list at all.
fn configs() -> Vec<(String, GridConfig)> {
    let mut out = vec![("auto".to_string(), GridConfig::default())];
    for size in [0.05, 0.7, 1e4] {
        out.push((format!("cell {size}"), GridConfig::fixed(size)));
    }
    out.push((
        "cell 0.7, no oversize list".to_string(),
        GridConfig {
            max_cells_per_entry: u32::MAX,
            ..GridConfig::fixed(0.7)
        },
    ));
    out
}

/// A grid of `config` over `entries`, maintained and validated.
fn build(config: GridConfig, entries: &[(u32, Aabb)]) -> (UniformGrid, Vec<GridHandle>) {
    let mut grid = UniformGrid::with_config(config);
    let handles = entries
        .iter()
        .map(|&(id, b)| grid.insert(id, b).expect("valid box"))
        .collect();
    grid.maintain(Duration::ZERO);
    grid.validate().unwrap();
    (grid, handles)
}

#[test]
fn the_grid_answers_every_query_at_every_cell_size() {
    for (scene, entries, seed) in scenes() {
        for (name, config) in configs() {
            if name.contains("no oversize") && scene.starts_with("Clustered") {
                // A 2000-unit world of 0.7 cells and the boxes' copies: fine, but slow in
                // debug builds for no case the others do not cover.
                continue;
            }
            let (grid, _) = build(config, &entries);
            check_queries(&format!("grid {name}, {scene}"), &grid, &entries, seed);
        }
        let boxes: Vec<Aabb> = entries.iter().map(|&(_, b)| b).collect();
        let grid = UniformGrid::from_boxes(&boxes, GridConfig::default());
        grid.validate().unwrap();
        check_queries(&format!("grid from_boxes, {scene}"), &grid, &entries, seed);
    }
}

#[test]
fn the_grid_through_random_edits() {
    for seed in [1, 2, 3] {
        check_edits("UniformGrid auto", UniformGrid::new(), 48, seed);
        check_edits(
            "UniformGrid cell 0.5",
            UniformGrid::with_config(GridConfig::fixed(0.5)),
            48,
            seed,
        );
        check_edits(
            "UniformGrid cell 40",
            UniformGrid::with_config(GridConfig::fixed(40.0)),
            48,
            seed,
        );
    }
}

#[test]
fn objects_larger_than_the_world() {
    let mut rng = Rng::new(21);
    let mut entries: Vec<(u32, Aabb)> = (0..200)
        .map(|i| (i, accel_testkit::random_box(&mut rng, 20.0, 0.1..1.0)))
        .collect();
    entries.push((1000, Aabb::new(Vec3A::splat(-1e6), Vec3A::splat(1e6))));
    entries.push((
        1001,
        Aabb::new(Vec3A::new(-1e5, -0.5, -1e5), Vec3A::new(1e5, 0.5, 1e5)),
    ));
    // Spans about 40^3 cells: in the cells when the limit allows it.
    entries.push((1002, Aabb::new(Vec3A::splat(-20.0), Vec3A::splat(20.0))));
    for (name, config) in [
        ("auto", GridConfig::default()),
        (
            "limit 100k",
            GridConfig {
                max_cells_per_entry: 100_000,
                ..GridConfig::fixed(1.0)
            },
        ),
    ] {
        let (grid, _) = build(config, &entries);
        assert!(
            grid.oversize_count() >= 2,
            "{name}: the huge boxes are oversize"
        );
        assert!(
            grid.cell_count() < 100_000,
            "{name}: no huge box filled the cells"
        );
        check_queries(
            &format!("larger than the world, {name}"),
            &grid,
            &entries,
            22,
        );
    }
}

#[test]
fn everything_in_one_cell() {
    let mut rng = Rng::new(31);
    let entries: Vec<(u32, Aabb)> = (0..300)
        .map(|i| (i, accel_testkit::random_box(&mut rng, 1.0, 0.01..0.5)))
        .collect();
    let (mut grid, handles) = build(GridConfig::fixed(1000.0), &entries);
    assert!(grid.cell_count() <= 8, "{} cells", grid.cell_count());
    check_queries("one cell", &grid, &entries, 32);
    // Edits inside the one crowded cell: every move stays in its cells.
    for (i, &h) in handles.iter().enumerate().step_by(3) {
        let b = entries[i].1;
        let moved = Aabb::new(b.min * 0.5, b.max * 0.5);
        assert_eq!(grid.update(h, moved), Ok(false));
    }
    for &h in handles.iter().skip(1).step_by(3) {
        grid.remove(h).unwrap();
    }
    grid.maintain(Duration::ZERO);
    grid.validate().unwrap();
    check_edits(
        "one cell",
        UniformGrid::with_config(GridConfig::fixed(1000.0)),
        24,
        33,
    );
}

/// Boxes whose faces lie on the planes of a unit lattice: whole cells, flat squares on cell
/// faces, sticks along cell edges and points at cell corners.
fn lattice_boxes() -> Vec<(u32, Aabb)> {
    let mut out = Vec::new();
    let mut id = 0;
    let mut push = |b: Aabb| {
        out.push((id, b));
        id += 1;
    };
    for x in -3i32..3 {
        for y in -3..3 {
            for z in -3..3 {
                let p = Vec3A::new(x as f32, y as f32, z as f32);
                match (x + 2 * y + 3 * z).rem_euclid(5) {
                    0 => push(Aabb::new(p, p + Vec3A::ONE)),
                    1 => push(Aabb::new(p, p + Vec3A::new(1.0, 1.0, 0.0))),
                    2 => push(Aabb::new(p, p + Vec3A::new(0.0, 0.0, 1.0))),
                    3 => push(Aabb::from_point(p)),
                    _ => {}
                }
            }
        }
    }
    out
}

#[test]
fn objects_exactly_on_cell_boundaries() {
    let entries = lattice_boxes();
    for size in [1.0, 0.5, 2.0] {
        let (grid, _) = build(GridConfig::fixed(size), &entries);
        check_queries(&format!("on boundaries, cell {size}"), &grid, &entries, 41);
        // Queries that touch the boxes only on a face, an edge or a corner.
        let model: HashMap<u32, Aabb> = entries.iter().copied().collect();
        for p in [
            Vec3A::ZERO,
            Vec3A::new(1.0, 0.0, 0.0),
            Vec3A::new(-2.0, 1.0, 2.0),
        ] {
            compare_region(&grid, &model, &Aabb::from_point(p));
            compare_region(&grid, &model, &Aabb::new(p, p + Vec3A::ONE));
            compare_region(&grid, &model, &Aabb::new(p - Vec3A::ONE, p));
        }
    }
}

/// The rays the lattice tests cast: along grid lines and cell faces, through cell corners
/// and along their diagonals, with zero and negative-zero components, from inside and from
/// far outside.
fn lattice_rays() -> Vec<Ray> {
    let mut rays = Vec::new();
    let axes = [Vec3A::X, Vec3A::Y, Vec3A::Z];
    for origin in [
        Vec3A::ZERO,
        Vec3A::new(1.0, 1.0, 0.0),
        Vec3A::new(-2.0, 0.5, 1.0),
        Vec3A::new(0.5, 0.5, 0.5),
        Vec3A::new(-10.0, 0.0, 0.0),
        Vec3A::new(10.0, -1.0, 2.0),
    ] {
        for axis in axes {
            for sign in [1.0, -1.0] {
                rays.push(Ray::new(origin, axis * sign));
                // The same direction with negative zeros in the other components.
                let d = Vec3A::select(axis.cmpeq(Vec3A::ZERO), Vec3A::splat(-0.0), axis * sign);
                rays.push(Ray::new(origin, d));
            }
        }
        for d in [
            Vec3A::ONE,
            -Vec3A::ONE,
            Vec3A::new(1.0, -1.0, 0.0),
            Vec3A::new(-1.0, 0.0, 1.0),
            Vec3A::new(0.0, -1.0, -1.0),
            Vec3A::new(2.0, 1.0, -0.0),
        ] {
            rays.push(Ray::new(origin, d));
            rays.push(Ray::new(origin - d * 20.0, d));
        }
    }
    // Segments ending exactly on a plane, and rays starting inside a corner's boxes.
    rays.push(Ray::segment(
        Vec3A::new(-3.0, 0.0, 0.0),
        Vec3A::new(0.0, 0.0, 0.0),
    ));
    rays.push(Ray::with_range(
        Vec3A::new(-1.0, -1.0, -1.0),
        Vec3A::ONE,
        0.5,
        2.0,
    ));
    rays
}

#[test]
fn rays_along_grid_lines_and_through_cell_corners() {
    let entries = lattice_boxes();
    let model: HashMap<u32, Aabb> = entries.iter().copied().collect();
    for size in [1.0, 0.5, 2.0, 3.0] {
        let (grid, _) = build(GridConfig::fixed(size), &entries);
        for ray in lattice_rays() {
            compare_ray(&grid, &model, &ray, &format!("cell {size}"));
        }
    }
}

#[test]
fn rays_that_walk_the_cell_list() {
    // Two crowds a million units apart: a ray between them crosses far more cells than
    // exist, and goes over the cell list instead of the cells.
    let mut rng = Rng::new(51);
    let mut entries = Vec::new();
    for (i, centre) in [Vec3A::splat(-5e5), Vec3A::splat(5e5)]
        .into_iter()
        .enumerate()
    {
        for j in 0..100u32 {
            let c = centre + rng.vec3a(-5.0, 5.0);
            entries.push((
                i as u32 * 100 + j,
                Aabb::from_center_half_extents(c, rng.vec3a(0.1, 1.0)),
            ));
        }
    }
    let model: HashMap<u32, Aabb> = entries.iter().copied().collect();
    let (grid, _) = build(GridConfig::fixed(1.0), &entries);
    for _ in 0..200 {
        let from = entries[rng.below(200)].1.center();
        let to = entries[rng.below(200)].1.center() + rng.vec3a(-2.0, 2.0);
        compare_ray(&grid, &model, &Ray::new(from, to - from), "between crowds");
        // From a million units away: the walk's tolerance exceeds a cell.
        let far = to + rng.unit_vector() * 3e6;
        compare_ray(&grid, &model, &Ray::new(far, to - far), "from far away");
    }
    check_queries("two crowds", &grid, &entries, 52);
}

#[test]
fn closest_hits_behind_entries_found_early() {
    // Long boxes spanning several cells among small ones: a cell often holds a long box the
    // ray enters only cells later, so the walk finds a far hit first and must still visit
    // the cells before it.
    let mut rng = Rng::new(55);
    let entries: Vec<(u32, Aabb)> = (0..1500)
        .map(|i| {
            let mut half = rng.vec3a(0.05, 0.4);
            if i % 4 == 0 {
                half[rng.below(3)] = rng.range(1.0, 3.0);
            }
            (
                i,
                Aabb::from_center_half_extents(rng.vec3a(-12.0, 12.0), half),
            )
        })
        .collect();
    let model: HashMap<u32, Aabb> = entries.iter().copied().collect();
    for size in [0.5, 1.0] {
        let (grid, _) = build(GridConfig::fixed(size), &entries);
        for _ in 0..1500 {
            let ray = Ray::new(rng.vec3a(-14.0, 14.0), rng.unit_vector());
            compare_ray(&grid, &model, &ray, &format!("cell {size}"));
        }
    }
}

#[test]
fn updates_write_only_the_box_within_the_same_cells() {
    let mut grid = UniformGrid::with_config(GridConfig::fixed(1.0));
    let h = grid
        .insert(7, Aabb::new(Vec3A::splat(0.1), Vec3A::splat(0.4)))
        .unwrap();
    assert_eq!(
        grid.update(h, Aabb::new(Vec3A::splat(0.2), Vec3A::splat(0.9))),
        Ok(false)
    );
    assert_eq!(
        grid.update(h, Aabb::new(Vec3A::splat(0.2), Vec3A::splat(1.0))),
        Ok(true)
    );
    assert_eq!(grid.cell_count(), 8);
    // Into the oversize list and back out.
    let huge = Aabb::new(Vec3A::splat(-50.0), Vec3A::splat(50.0));
    assert_eq!(grid.update(h, huge), Ok(true));
    assert_eq!((grid.oversize_count(), grid.cell_count()), (1, 0));
    assert_eq!(grid.update(h, huge.expanded(Vec3A::ONE)), Ok(false));
    assert_eq!(
        grid.update(h, Aabb::from_point(Vec3A::splat(3.5))),
        Ok(true)
    );
    assert_eq!((grid.oversize_count(), grid.cell_count()), (0, 1));
    grid.validate().unwrap();
    // Refused edits leave everything as it was.
    for bad in [
        Aabb::new(Vec3A::ONE, Vec3A::ZERO),
        Aabb::new(Vec3A::splat(f32::NAN), Vec3A::ONE),
        Aabb::new(Vec3A::ZERO, Vec3A::splat(f32::INFINITY)),
    ] {
        assert_eq!(grid.update(h, bad), Err(IndexError::InvalidBounds));
        assert_eq!(grid.insert(8, bad), Err(IndexError::InvalidBounds));
    }
    assert_eq!(grid.bounds_of(h), Some(Aabb::from_point(Vec3A::splat(3.5))));
    assert_eq!(grid.remove(h), Ok(7));
    assert_eq!(grid.remove(h), Err(IndexError::StaleHandle));
    assert_eq!(grid.update(h, huge), Err(IndexError::StaleHandle));
    assert_eq!(grid.id(h), None);
    grid.validate().unwrap();
}

#[test]
fn the_cell_size_follows_the_population() {
    let mut rng = Rng::new(61);
    let mut grid = UniformGrid::new();
    let mut model = HashMap::new();
    let mut add = |grid: &mut UniformGrid, n: u32, extent: f32| {
        for _ in 0..n {
            let id = model.len() as u32;
            let b = accel_testkit::random_box(&mut rng, extent, 0.2..0.6);
            grid.insert(id, b).unwrap();
            model.insert(id, b);
        }
    };
    add(&mut grid, 200, 10.0);
    assert!(
        grid.maintain(Duration::ZERO).rebuilt,
        "the first sizing bins again"
    );
    let sparse = grid.cell_size();
    // Twenty times as many in the same world: denser, so smaller cells.
    add(&mut grid, 4000, 10.0);
    assert!(grid.maintain(Duration::ZERO).rebuilt);
    assert!(
        grid.cell_size() < sparse,
        "{} then {}",
        sparse,
        grid.cell_size()
    );
    // A small change is not a reason to bin everything again.
    add(&mut grid, 100, 10.0);
    assert!(!grid.maintain(Duration::ZERO).rebuilt);
    grid.validate().unwrap();
    let entries: Vec<(u32, Aabb)> = model.into_iter().collect();
    check_queries("after re-sizing", &grid, &entries, 62);
}

#[test]
fn ten_thousand_frames_of_churn() {
    const TARGET: usize = 300;
    let mut rng = Rng::new(71);
    let mut grid = UniformGrid::new();
    let mut model: HashMap<u32, (GridHandle, Aabb)> = HashMap::new();
    let mut next_id = 0u32;
    let mut peak = [0usize; 2];
    for frame in 0..10_000 {
        for _ in 0..rng.below(TARGET / 10) + 1 {
            let grow = model.len() < TARGET;
            match rng.below(10) {
                0..=1 if grow || model.is_empty() => {
                    let b = churn_box(&mut rng);
                    let h = grid.insert(next_id, b).unwrap();
                    model.insert(next_id, (h, b));
                    next_id += 1;
                }
                0..=1 => {
                    let id = *model.keys().nth(rng.below(model.len())).unwrap();
                    let (h, _) = model.remove(&id).unwrap();
                    assert_eq!(grid.remove(h), Ok(id));
                }
                _ if !model.is_empty() => {
                    let id = *model.keys().nth(rng.below(model.len())).unwrap();
                    let (h, b) = model[&id];
                    let moved = if rng.chance(0.9) {
                        let step = rng.vec3a(-0.4, 0.4);
                        Aabb::new(b.min + step, b.max + step)
                    } else if rng.chance(0.1) {
                        // Now and then one grows huge, or shrinks back.
                        Aabb::from_center_half_extents(b.center(), rng.vec3a(5.0, 30.0))
                    } else {
                        churn_box(&mut rng)
                    };
                    grid.update(h, moved).unwrap();
                    model.insert(id, (h, moved));
                }
                _ => {}
            }
        }
        grid.maintain(Duration::ZERO);
        grid.validate()
            .unwrap_or_else(|e| panic!("frame {frame}: {e}"));
        assert_eq!(grid.len(), model.len());
        compare_one_query(&grid, &model, &mut rng, frame);
        if frame >= 1000 {
            let half = usize::from(frame >= 5500);
            peak[half] = peak[half].max(grid.index_stats().memory_bytes);
        }
    }
    // The second half of the run holds no more than the first, allowing for the map's
    // doubling when its deleted markers run out: nothing grows with the number of edits.
    assert!(peak[1] <= 2 * peak[0], "memory grew: {peak:?}");
}

fn churn_box(rng: &mut Rng) -> Aabb {
    accel_testkit::random_box(rng, 30.0, 0.1..1.5)
}

/// One query each frame, its kind in turn, compared with brute force over the model.
fn compare_one_query(
    grid: &UniformGrid,
    model: &HashMap<u32, (GridHandle, Aabb)>,
    rng: &mut Rng,
    frame: usize,
) {
    let boxes: HashMap<u32, Aabb> = model.iter().map(|(&id, &(_, b))| (id, b)).collect();
    let centre = rng.vec3a(-35.0, 35.0);
    match frame % 5 {
        0 => {
            let ray = Ray::new(rng.vec3a(-40.0, 40.0), rng.unit_vector());
            compare_ray(grid, &boxes, &ray, &format!("frame {frame}"));
        }
        1 => compare_region(
            grid,
            &boxes,
            &Aabb::from_center_half_extents(centre, rng.vec3a(0.0, 10.0)),
        ),
        2 => {
            let sphere = Sphere::new(centre, rng.range(0.0, 10.0));
            let mut got = Vec::new();
            grid.for_each_overlapping_sphere(&sphere, |id| {
                got.push(id);
                ControlFlow::Continue(())
            });
            got.retain(|id| sphere.intersects_aabb(&boxes[id]));
            got.sort_unstable();
            let mut want: Vec<u32> = boxes
                .iter()
                .filter(|(_, b)| sphere.intersects_aabb(b))
                .map(|(&id, _)| id)
                .collect();
            want.sort_unstable();
            assert_eq!(got, want, "frame {frame}: sphere");
        }
        3 => {
            let f = random_frustum(rng, 35.0);
            let mut got = Vec::new();
            grid.for_each_in_frustum(&f, |id, c| {
                assert!(
                    c != Containment::Inside || f.classify_aabb(&boxes[&id]) == Containment::Inside
                );
                got.push(id);
            });
            got.sort_unstable();
            let mut want: Vec<u32> = boxes
                .iter()
                .filter(|(_, b)| f.intersects_aabb(b))
                .map(|(&id, _)| id)
                .collect();
            want.sort_unstable();
            assert_eq!(got, want, "frame {frame}: frustum");
        }
        _ => {
            let mut oracle = BruteForceIndex::new();
            for (&id, &b) in &boxes {
                oracle.insert(id, b).unwrap();
            }
            let d2 = |id: u32| boxes[&id].distance_squared_to_point(centre);
            assert_eq!(
                grid.nearest_k(centre, 5, d2),
                oracle.nearest_k(centre, 5, d2),
                "frame {frame}: nearest"
            );
        }
    }
}

#[test]
fn removing_everything_gives_the_memory_back() {
    let empty = UniformGrid::new().index_stats().memory_bytes;
    let mut grid = UniformGrid::new();
    let mut rng = Rng::new(81);
    let mut handles = Vec::new();
    for round in 0..3 {
        for i in 0..20_000u32 {
            let b = accel_testkit::random_box(&mut rng, 200.0, 0.1..2.0);
            handles.push(grid.insert(i, b).unwrap());
        }
        grid.maintain(Duration::ZERO);
        let full = grid.index_stats().memory_bytes;
        for &h in &handles {
            grid.remove(h).unwrap();
        }
        grid.maintain(Duration::ZERO);
        grid.validate().unwrap();
        let after = grid.index_stats().memory_bytes;
        assert!(
            after <= empty + 16 * 1024,
            "round {round}: {after} bytes left of {full}"
        );
        assert!(after * 100 < full, "round {round}: {after} of {full}");
        // The slots were given back, and no old handle names a new entry.
        let fresh = grid.insert(99, Aabb::from_point(Vec3A::ZERO)).unwrap();
        assert!(handles.iter().all(|&h| grid.id(h).is_none()));
        assert_eq!(grid.id(fresh), Some(99));
        grid.remove(fresh).unwrap();
        handles.clear();
    }
    assert!(grid.is_empty());
}

#[test]
fn rays_from_many_threads_see_what_one_thread_sees() {
    let mut rng = Rng::new(91);
    let entries: Vec<(u32, Aabb)> = (0..3000)
        .map(|i| (i, accel_testkit::random_box(&mut rng, 60.0, 0.2..2.5)))
        .collect();
    let boxes: HashMap<u32, Aabb> = entries.iter().copied().collect();
    let (grid, _) = build(GridConfig::default(), &entries);
    let rays: Vec<Ray> = (0..400)
        .map(|_| Ray::new(rng.vec3a(-70.0, 70.0), rng.unit_vector()))
        .collect();
    let answer = |ray: &Ray| {
        let hit = |id: u32, r: &Ray| r.intersect_aabb(&boxes[&id]);
        let closest = grid.cast_ray(ray, hit);
        let mut all = Vec::new();
        grid.cast_ray_all(ray, hit, &mut all);
        (closest, all)
    };
    let want: Vec<(Option<RayHit>, Vec<RayHit>)> = rays.iter().map(answer).collect();
    assert!(
        want.iter().filter(|(c, _)| c.is_some()).count() > 100,
        "the rays hit things"
    );
    std::thread::scope(|s| {
        let workers: Vec<_> = (0..4)
            .map(|t| {
                let (rays, answer) = (&rays, &answer);
                // Each thread starts at a different ray, so the threads overlap in time on
                // different queries as well as on the same ones.
                s.spawn(move || {
                    let n = rays.len();
                    (0..n)
                        .map(|i| (i + t * n / 4) % n)
                        .map(|i| (i, answer(&rays[i])))
                        .collect::<Vec<_>>()
                })
            })
            .collect();
        for w in workers {
            for (i, got) in w.join().unwrap() {
                assert_eq!(got, want[i], "ray {i} from a worker thread");
            }
        }
    });
}

/// Closest, any and all hits of one ray against brute force over `boxes`.
fn compare_ray(grid: &UniformGrid, boxes: &HashMap<u32, Aabb>, ray: &Ray, name: &str) {
    let hit = |id: u32, r: &Ray| r.intersect_aabb(&boxes[&id]);
    let want = boxes
        .values()
        .filter_map(|b| ray.intersect_aabb(b))
        .min_by(f32::total_cmp);
    let got = grid.cast_ray(ray, hit);
    assert_eq!(got.map(|h| h.t), want, "{name}: closest hit of {ray:?}");
    let any = grid.cast_ray_any(ray, |id, r| hit(id, r).is_some());
    assert_eq!(any.is_some(), want.is_some(), "{name}: any hit of {ray:?}");
    let mut got_all = Vec::new();
    grid.cast_ray_all(ray, hit, &mut got_all);
    let mut want_all: Vec<RayHit> = boxes
        .iter()
        .filter_map(|(&id, b)| ray.intersect_aabb(b).map(|t| RayHit { primitive: id, t }))
        .collect();
    spatial_accel::query::sort_hits(&mut want_all);
    assert_eq!(got_all, want_all, "{name}: all hits of {ray:?}");
}

/// A box query against brute force over `boxes`, each id at most once.
fn compare_region(grid: &UniformGrid, boxes: &HashMap<u32, Aabb>, q: &Aabb) {
    let mut got = Vec::new();
    grid.for_each_overlapping_aabb(q, |id| {
        got.push(id);
        ControlFlow::Continue(())
    });
    got.sort_unstable();
    let mut want: Vec<u32> = boxes
        .iter()
        .filter(|(_, b)| b.intersects_aabb(q))
        .map(|(&id, _)| id)
        .collect();
    want.sort_unstable();
    assert_eq!(got, want, "box query {q:?}");
}
