//! Triangle pre-splitting: large, slanted triangles enter the build as several tighter boxes.
//!
//! A long triangle across a scene has a box far larger than itself, and a BVH over boxes
//! cannot do better than that box: every ray through it tests the triangle, and the box
//! overlaps its neighbours' all the way up the tree. Splitting the box (the spatial splits of
//! Stich et al. 2009's SBVH, or Ernst and Greiner 2007's early split clipping) fixes that.
//! This is the variant of Karras and Aila 2013 ("Fast parallel construction of high-quality
//! bounding volume hierarchies", section 5): before any build, a budget of extra references
//! is shared out among the triangles whose boxes waste the most area, and each is cut at the
//! planes of a power-of-two grid over the scene, the planes a top-down or Morton-order build
//! splits at first. Any builder then runs on the references unchanged.

use crate::Aabb;
use crate::geometry::cut_triangle_part;
use glam::Vec3A;

/// Most pieces one triangle is cut into: past this a triangle's pieces are far smaller than
/// the leaves around them and further cuts only add references.
const MAX_PIECES_PER_TRIANGLE: u32 = 256;

/// Triangles whose boxes waste less than this many times the mean waste are not cut, however
/// much budget is left: in a mesh of like triangles (a tessellated sphere, the bunny) cuts
/// buy rays little for a much slower build.
const WORTH_CUTTING: f64 = 4.0;

/// A triangle whose box is larger (in area) than this many typical leaves' boxes of the mesh
/// is cut whatever the mesh's other triangles are like, and counts towards the budget as many
/// triangles as such leaves its box spans.
///
/// Why: in a mesh of like triangles that are each large against the mesh's leaves (a soup of
/// large overlapping triangles: the benchmark scene's large triangles built as a mesh of their
/// own), every waste is near the mean, so the rule above cuts none of them, while rays through
/// such a mesh walk leaves of overlapping large boxes. With this rule rays through the
/// benchmark's two-level scene, answered almost wholly inside that mesh, are faster
/// (BENCHMARKS.md, Rays on meshes); the flattened scene, whose large triangles the rule above
/// already cuts, and the sphere and the bunny, whose triangles are smaller than their leaves,
/// are unaffected.
const LARGE_AGAINST_LEAVES: f32 = 1.0;

/// Triangles in the typical leaf that [`LARGE_AGAINST_LEAVES`] measures against: one packet.
const LEAF_TRIANGLES: f32 = 4.0;

/// The references a build runs on: each a box and the triangle it bounds part of.
#[derive(Clone, Debug, Default)]
pub(super) struct SplitReferences {
    /// The reference boxes; together a triangle's cover all of it.
    pub boxes: Vec<Aabb>,
    /// The triangle each reference belongs to.
    pub triangles: Vec<u32>,
}

/// Cuts the triangles into references, adding about `budget` references per triangle
/// (`0.3` adds 30%; a triangle larger than the mesh's leaves counts as the leaves it spans,
/// see [`LARGE_AGAINST_LEAVES`]), and keeps every triangle whole where none is worth cutting.
/// `boxes[t]` is triangle `t`'s box ([`Aabb::EMPTY`] to leave it out) and `corners(t)` its
/// corners.
pub(super) fn presplit_triangles(
    boxes: &[Aabb],
    corners: impl Fn(u32) -> [Vec3A; 3],
    budget: f32,
) -> SplitReferences {
    let scene = boxes
        .iter()
        .filter(|b| !b.is_empty())
        .fold(Aabb::EMPTY, |acc, b| acc.union(b));
    let spans = leaves_spanned(boxes, &scene);
    let weight: f64 = spans.iter().map(|&s| f64::from(s.max(1.0))).sum();
    let extra = (f64::from(budget.max(0.0)) * weight) as u64;
    let wastes: Vec<f32> = boxes
        .iter()
        .enumerate()
        .map(|(t, b)| wasted_area(b, &corners(t as u32)))
        .collect();
    let mean_waste = wastes.iter().map(|&w| f64::from(w)).sum::<f64>() / wastes.len().max(1) as f64;
    let worth_cutting = (WORTH_CUTTING * mean_waste) as f32;
    // (triangle, priority) of those worth cutting, in triangle order: few in most meshes that
    // need cuts at all, so the budget is shared out over them alone.
    let candidates: Vec<(u32, f32)> = wastes
        .iter()
        .enumerate()
        .filter(|&(t, &waste)| waste > worth_cutting || spans[t] > 0.0)
        .map(|(t, &waste)| (t as u32, split_priority(&boxes[t], waste, &scene)))
        .collect();
    let scale = budget_scale(&candidates, extra);
    let mut out = SplitReferences {
        boxes: Vec::with_capacity(boxes.len() + extra as usize),
        triangles: Vec::with_capacity(boxes.len() + extra as usize),
    };
    let mut pending = Vec::new();
    let mut next_candidate = candidates.iter().peekable();
    for (t, b) in boxes.iter().enumerate() {
        let cuts = match next_candidate.next_if(|&&(c, _)| c == t as u32) {
            Some(&(_, priority)) => pieces_for(priority, scale) - 1,
            None => 0,
        };
        if cuts == 0 {
            out.boxes.push(*b);
            out.triangles.push(t as u32);
            continue;
        }
        let corners = corners(t as u32);
        // Depth first over (region, piece box, cuts still to make in it).
        pending.push((*b, *b, cuts));
        while let Some((region, piece, cuts)) = pending.pop() {
            if cuts == 0 {
                out.boxes.push(piece);
                out.triangles.push(t as u32);
                continue;
            }
            let (axis, plane) = split_plane(&piece, &scene);
            let halves = cut_triangle_part(&corners, &region, axis, plane);
            match halves.map(|(_, piece)| !piece.is_empty()) {
                [true, true] => {
                    // The rest of the cuts go where the pieces are longer.
                    let lengths = halves.map(|(_, piece)| piece.extent().max_element());
                    let share = lengths[0] / (lengths[0] + lengths[1]).max(f32::MIN_POSITIVE);
                    let below_cuts = ((cuts - 1) as f32 * share).round() as u32;
                    let below_cuts = below_cuts.min(cuts - 1);
                    pending.push((halves[1].0, halves[1].1, cuts - 1 - below_cuts));
                    pending.push((halves[0].0, halves[0].1, below_cuts));
                }
                [true, false] => pending.push((halves[0].0, halves[0].1, cuts - 1)),
                [false, true] => pending.push((halves[1].0, halves[1].1, cuts - 1)),
                // Cannot happen for a plane inside the piece's box, which bounds part of the
                // triangle; kept whole rather than lost if rounding ever says otherwise.
                [false, false] => pending.push((region, piece, 0)),
            }
        }
    }
    out
}

/// For each triangle, how many typical leaves' boxes its box spans (by area) where that is
/// more than [`LARGE_AGAINST_LEAVES`] (at most [`MAX_PIECES_PER_TRIANGLE`]), else 0. A typical
/// leaf holds [`LEAF_TRIANGLES`] of a mesh spread evenly through its box; a closed surface's
/// leaves are larger than that, so its triangles are never large by this measure.
fn leaves_spanned(boxes: &[Aabb], scene: &Aabb) -> Vec<f32> {
    let live = boxes.iter().filter(|b| !b.is_empty()).count().max(1) as f32;
    let leaf_area = scene.half_area() * (LEAF_TRIANGLES / live).min(1.0).powf(2.0 / 3.0);
    boxes
        .iter()
        .map(|b| {
            let spanned = b.half_area() / leaf_area;
            if spanned.is_finite() && spanned > LARGE_AGAINST_LEAVES {
                spanned.min(MAX_PIECES_PER_TRIANGLE as f32)
            } else {
                0.0
            }
        })
        .collect()
}

/// How much a triangle gains from cuts: Karras and Aila's `(2^level * waste)^(1/3)`, where
/// `level` counts the grid levels its box crosses planes of, so that a triangle across the
/// top planes, stuck high in any tree, comes first.
fn split_priority(b: &Aabb, waste: f32, scene: &Aabb) -> f32 {
    let level = crossed_grid_levels(b, scene);
    (waste * (1u32 << level) as f32).cbrt()
}

/// A triangle's box's area above the least its pieces' boxes could have: that of infinitely
/// many infinitely small pieces, the triangle's area projected on the three axis planes,
/// twice. Zero for a triangle left out.
fn wasted_area(b: &Aabb, corners: &[Vec3A; 3]) -> f32 {
    if b.is_empty() || !b.is_finite() {
        return 0.0;
    }
    let [a, bb, c] = *corners;
    let ideal = (bb - a).cross(c - a).abs().element_sum();
    (b.surface_area() - ideal).max(0.0)
}

/// Of the 10 coarsest levels of the power-of-two grid over `scene`, how many have a plane
/// that crosses `b` (10 for a box across the middle of the scene, 0 for one inside a finest
/// cell): the bit length of the highest bit in which the box's corners' cell coordinates
/// differ, on the axis where that is highest.
fn crossed_grid_levels(b: &Aabb, scene: &Aabb) -> u32 {
    const CELLS: f32 = 1024.0;
    let to_cells = |p: Vec3A| {
        ((p - scene.min) / scene.extent().max(Vec3A::splat(f32::MIN_POSITIVE)) * CELLS)
            .clamp(Vec3A::ZERO, Vec3A::splat(CELLS - 1.0))
            .as_uvec3()
    };
    let differing = to_cells(b.min) ^ to_cells(b.max);
    32 - (differing.x | differing.y | differing.z).leading_zeros()
}

/// The factor that turns priorities into piece counts, chosen so that the extra pieces come
/// as close to `extra` as possible without going over (bisection: the count only grows with
/// the factor).
fn budget_scale(candidates: &[(u32, f32)], extra: u64) -> f32 {
    let total: f64 = candidates.iter().map(|&(_, p)| f64::from(p)).sum();
    if extra == 0 || total <= 0.0 {
        return 0.0;
    }
    let extra_pieces = |scale: f32| -> u64 {
        candidates
            .iter()
            .map(|&(_, p)| u64::from(pieces_for(p, scale) - 1))
            .sum()
    };
    // Rounding down each triangle's share keeps this one within budget.
    let mut low = (extra as f64 / total) as f32;
    let mut high = low * 2.0;
    // Past the point where every candidate has its most pieces, more scale buys nothing.
    let reachable = extra.min(candidates.len() as u64 * u64::from(MAX_PIECES_PER_TRIANGLE - 1));
    while extra_pieces(high) < reachable && high < f32::MAX / 4.0 {
        (low, high) = (high, high * 2.0);
    }
    for _ in 0..12 {
        let mid = 0.5 * (low + high);
        if extra_pieces(mid) <= extra {
            low = mid;
        } else {
            high = mid;
        }
    }
    low
}

/// Pieces for a triangle of priority `priority`: one, plus its share of the cuts.
fn pieces_for(priority: f32, scale: f32) -> u32 {
    1 + ((priority * scale) as u32).min(MAX_PIECES_PER_TRIANGLE - 1)
}

/// Where to cut a piece: the plane of the coarsest power-of-two grid level over `scene` that
/// passes strictly inside its box, on the axis where that level is coarsest (the longer axis
/// on a tie); the middle of its longest axis where no grid plane down to 2^-20 of the scene
/// does.
fn split_plane(piece: &Aabb, scene: &Aabb) -> (usize, f32) {
    let mut best: Option<(u32, f32, usize, f32)> = None;
    for axis in 0..3 {
        let (lo, hi) = (piece.min[axis], piece.max[axis]);
        let (origin, size) = (scene.min[axis], scene.max[axis] - scene.min[axis]);
        if hi <= lo || size <= 0.0 {
            continue;
        }
        for level in 1..=20u32 {
            let cells = (1u32 << level) as f32;
            let index = ((lo - origin) / size * cells).floor() + 1.0;
            let plane = origin + index / cells * size;
            if plane > lo && plane < hi {
                let better = match best {
                    None => true,
                    Some((l, _, _, extent)) => level < l || (level == l && hi - lo > extent),
                };
                if better {
                    best = Some((level, plane, axis, hi - lo));
                }
                break;
            }
        }
    }
    match best {
        Some((_, plane, axis, _)) => (axis, plane),
        None => {
            let axis = piece.longest_axis();
            (axis, 0.5 * (piece.min[axis] + piece.max[axis]))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A thin diagonal sliver across a scene of small triangles: cut into many pieces whose
    /// boxes cover it and sum to far less area than its box, while the small ones stay whole.
    #[test]
    fn a_long_slanted_triangle_takes_the_cuts() {
        let mut tris: Vec<[Vec3A; 3]> = (0..99)
            .map(|i| {
                let p = Vec3A::new(i as f32, (i * 7 % 13) as f32, (i * 5 % 11) as f32);
                [p, p + Vec3A::X * 0.5, p + Vec3A::Y * 0.5]
            })
            .collect();
        tris.push([
            Vec3A::ZERO,
            Vec3A::new(100.0, 13.0, 11.0),
            Vec3A::new(100.0, 13.5, 11.0),
        ]);
        let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::from_points(*t)).collect();
        // 30% of 99 small triangles and the sliver, which counts as the 8.5 leaves it spans.
        let refs = presplit_triangles(&boxes, |t| tris[t as usize], 0.3);
        assert!(
            refs.boxes.len() <= 133 && refs.boxes.len() > 110,
            "{}",
            refs.boxes.len()
        );
        for t in 0..99 {
            assert_eq!(refs.triangles.iter().filter(|&&r| r == t).count(), 1);
        }
        let pieces: Vec<Aabb> = (0..refs.boxes.len())
            .filter(|&r| refs.triangles[r] == 99)
            .map(|r| refs.boxes[r])
            .collect();
        let area: f32 = pieces.iter().map(Aabb::surface_area).sum();
        assert!(area < 0.2 * boxes[99].surface_area());
        // Every point of the sliver lies in some piece.
        let [a, b, c] = tris[99];
        for i in 0..=1000 {
            for j in [0.0, 0.5, 1.0] {
                let u = i as f32 / 1000.0;
                let p = a + (b - a) * u + (c - b) * (u * j);
                assert!(pieces.iter().any(|piece| piece.contains_point(p)), "{p}");
            }
        }
    }

    /// A soup of like triangles, each larger than the mesh's leaves: no waste stands out from
    /// the mean, yet every triangle is a candidate, and each keeps its pieces' cover.
    #[test]
    fn like_triangles_large_against_the_leaves_are_cut() {
        let mut unit = crate::test_floats(0x2545_f491_4f6c_dd1d);
        let mut next = move || unit() * 2.0 - 1.0;
        let tris: Vec<[Vec3A; 3]> = (0..500)
            .map(|_| {
                let c = Vec3A::new(next(), next(), next()) * 20.0;
                [(); 3].map(|_| c + Vec3A::new(next(), next(), next()) * 12.0)
            })
            .collect();
        let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::from_points(*t)).collect();
        let refs = presplit_triangles(&boxes, |t| tris[t as usize], 0.3);
        assert!(refs.boxes.len() > 600, "{}", refs.boxes.len());
        for (t, tri) in tris.iter().enumerate() {
            let pieces: Vec<Aabb> = (0..refs.boxes.len())
                .filter(|&r| refs.triangles[r] == t as u32)
                .map(|r| refs.boxes[r])
                .collect();
            let inside = [(0.3, 0.3), (0.5, 0.49), (0.1, 0.8), (0.9, 0.05)]
                .map(|(u, v)| tri[0] + (tri[1] - tri[0]) * u + (tri[2] - tri[0]) * v);
            for p in tri.iter().chain(&inside) {
                assert!(pieces.iter().any(|b| b.contains_point(*p)), "{t} {p}");
            }
        }
    }

    /// A closed surface of small triangles (a tessellated sphere): its triangles are smaller
    /// than its leaves and alike, so none is cut.
    #[test]
    fn a_surface_of_like_small_triangles_stays_whole() {
        let point = |i: u32, j: u32| {
            let (theta, phi) = (i as f32 * 0.1, j as f32 * core::f32::consts::TAU / 64.0);
            Vec3A::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ) * 10.0
        };
        let tris: Vec<[Vec3A; 3]> = (0..31)
            .flat_map(|i| {
                (0..64).flat_map(move |j| {
                    [
                        [point(i, j), point(i + 1, j), point(i + 1, j + 1)],
                        [point(i, j), point(i + 1, j + 1), point(i, j + 1)],
                    ]
                })
            })
            .collect();
        let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::from_points(*t)).collect();
        let refs = presplit_triangles(&boxes, |t| tris[t as usize], 0.3);
        assert_eq!(refs.boxes.len(), tris.len());
    }

    /// No budget, or nothing worth cutting: one reference per triangle, in order.
    #[test]
    fn no_budget_keeps_triangles_whole() {
        let tris = [
            [Vec3A::ZERO, Vec3A::X, Vec3A::Y],
            [Vec3A::Z, Vec3A::ONE, Vec3A::X * 9.0],
        ];
        let boxes = tris.map(Aabb::from_points);
        let refs = presplit_triangles(&boxes, |t| tris[t as usize], 0.0);
        assert_eq!(refs.triangles, vec![0, 1]);
        assert_eq!(refs.boxes, boxes.to_vec());
    }
}
