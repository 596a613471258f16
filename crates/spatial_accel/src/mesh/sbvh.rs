//! Spatial-split BVH (SBVH; Stich, Friedrich and Dietrich 2009, "Spatial splits in bounding
//! volume hierarchies") over a mesh's triangles.
//!
//! A top-down binned SAH build that, at each node, also prices cutting the node's space in
//! two: references that straddle the plane are clipped into a piece on each side
//! (`sbvh_spatial.rs`). Where the best object split leaves children that overlap, a spatial
//! split can separate them, at the cost of more references. Pre-splitting (`presplit.rs`)
//! cuts before the build, at planes the build may never use; an SBVH cuts where the tree
//! needs a cut, at the planes the tree actually splits at, and only where the SAH says it
//! pays. The output is the same as a pre-split build's (references, each a piece box and its
//! triangle, under a binary tree), so leaf merging and packing are shared.

use super::presplit::SplitReferences;
use super::sbvh_spatial::{best_spatial_split, partition_spatially};
use crate::bvh::BvhNode;
use crate::{Aabb, BuildConfig, Bvh};
use glam::Vec3A;

/// Settings of a spatial-split build ([`crate::mesh::MeshBvh::with_spatial_splits`]).
///
/// The leaf size, depth limit and SAH costs come from the [`BuildConfig`] it is given with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpatialSplits {
    /// Extra references allowed, per triangle: `0.5` lets the tree hold up to 1.5 references
    /// per triangle. Shared among a node's children in proportion to their references, so
    /// that the first subtrees built cannot spend it all.
    pub reference_budget: f32,
    /// Bins per axis, for object and spatial splits alike (2 to 64).
    pub bins: u32,
    /// Spatial splits are priced only at nodes whose best object split leaves children
    /// overlapping in more than this fraction of the root's (half) surface area: Stich et
    /// al.'s alpha. Where children hardly overlap, no spatial split can do much better, and
    /// pricing one costs a clipping pass over the node.
    pub overlap_threshold: f32,
}

impl Default for SpatialSplits {
    /// Half again as many references as triangles, 16 bins, and spatial splits priced where
    /// the children overlap in more than 10^-5 of the root's area (Stich et al.'s choice).
    ///
    /// On the million-triangle benchmark scene (BENCHMARKS.md, Rays on meshes), tinybvh's 8
    /// bins and 10^-4 build faster but trace primary and diffuse rays slower; a larger budget
    /// or more bins trace no faster.
    fn default() -> Self {
        Self {
            reference_budget: 0.5,
            bins: 16,
            overlap_threshold: 1e-5,
        }
    }
}

/// A piece of a triangle in the build: the box of the part of the triangle it stands for.
#[derive(Clone, Copy, Debug)]
pub(super) struct Reference {
    pub bounds: Aabb,
    pub triangle: u32,
}

impl Reference {
    /// The box's centroid, halved before adding so that corners near the largest float do not
    /// overflow.
    #[inline(always)]
    pub fn centroid(&self) -> Vec3A {
        self.bounds.min * 0.5 + self.bounds.max * 0.5
    }
}

/// A node still to be built: its references are the last `count` in the work stack.
struct Task {
    node: usize,
    count: usize,
    bounds: Aabb,
    /// Extra references this subtree may still add.
    budget: usize,
    depth: u32,
}

/// Builds a binary tree with spatial splits over the triangles with boxes `boxes` (invalid
/// ones left out) and corners `corners(t)`. Returns the tree, whose primitive indices name
/// the references, and the references.
pub(super) fn build_spatial_splits(
    boxes: &[Aabb],
    corners: impl Fn(u32) -> [Vec3A; 3],
    config: &BuildConfig,
    settings: &SpatialSplits,
) -> (Bvh, SplitReferences) {
    // The work stack: a task's references sit on top of those of the tasks under it, so the
    // subtree being built is always the last `count` entries, and its children replace them.
    let mut work: Vec<Reference> = boxes
        .iter()
        .enumerate()
        .filter(|(_, b)| b.is_valid())
        .map(|(t, b)| Reference {
            bounds: *b,
            triangle: t as u32,
        })
        .collect();
    let mut out = SplitReferences::default();
    let mut nodes = Vec::new();
    if work.is_empty() {
        return (Bvh::default(), out);
    }
    let root_bounds = union_of(&work);
    let bins = (settings.bins as usize).clamp(2, super::sbvh_spatial::MAX_BINS);
    let min_overlap = settings.overlap_threshold * root_bounds.half_area();
    // Stich et al.: no spatial split on an axis narrower than this, where clipping could no
    // longer place pieces apart from each other reliably.
    let min_extent = root_bounds.extent() * 1e-6;
    let budget = (settings.reference_budget.max(0.0) * work.len() as f32) as usize;
    // The stack never holds more than the finished tree's references: room for all of them
    // at once, so that it never grows by copying (a tenth of the build when it did).
    work.reserve(budget);
    out.boxes.reserve(work.len() + budget);
    out.triangles.reserve(work.len() + budget);
    nodes.push(BvhNode::default());
    let mut tasks = vec![Task {
        node: 0,
        count: work.len(),
        bounds: root_bounds,
        budget,
        depth: 0,
    }];
    let mut scratch = (Vec::new(), Vec::new());
    while let Some(task) = tasks.pop() {
        let start = work.len() - task.count;
        let refs = &mut work[start..];
        nodes[task.node].set_aabb(&task.bounds);
        let area = task.bounds.half_area();
        let leaf_cost = config.sah.intersection * area * refs.len() as f32;
        let must_stop = refs.len() == 1 || task.depth >= config.max_depth;
        let may_stop = config.sah_termination && refs.len() <= config.max_leaf_size as usize;
        let object = if must_stop {
            None
        } else {
            best_object_split(refs, bins)
        };
        let object_cost = object.as_ref().map_or(f32::INFINITY, |s| s.cost);
        let overlap = object
            .as_ref()
            .map_or(f32::INFINITY, |s| s.left.intersection(&s.right).half_area());
        let spatial = (!must_stop && task.budget > 0 && overlap > min_overlap)
            .then(|| best_spatial_split(refs, &task.bounds, &corners, bins, min_extent))
            .flatten()
            // A spatial split duplicates references; one that hardly beats the object split
            // is not worth them (tinybvh asks for 1.5%).
            .filter(|s| s.cost < 0.985 * object_cost)
            .filter(|s| (s.left_count + s.right_count).saturating_sub(refs.len()) <= task.budget);
        let split_cost = |c: f32| config.sah.traversal * area + config.sah.intersection * c;
        let best_cost = split_cost(spatial.as_ref().map_or(object_cost, |s| s.cost));
        if must_stop || (may_stop && leaf_cost <= best_cost) {
            let first = out.boxes.len() as u32;
            out.boxes.extend(refs.iter().map(|r| r.bounds));
            out.triangles.extend(refs.iter().map(|r| r.triangle));
            nodes[task.node].first = first;
            nodes[task.node].count = refs.len() as u32;
            work.truncate(start);
            continue;
        }
        // The right child's references go below the left's, which is built first: so the
        // leaves come out left before right, each subtree's references in one run.
        let partitioned = match &spatial {
            Some(split) => partition_spatially(refs, split, &corners, &mut scratch),
            None => None,
        };
        let (left_count, right_count) = match partitioned {
            Some((left, right)) => {
                let counts = (left.len(), right.len());
                work.truncate(start);
                work.extend_from_slice(right);
                work.extend_from_slice(left);
                counts
            }
            None => {
                let right = match &object {
                    Some(split) => partition_by(refs, |r| !split.goes_left(r)),
                    // No plane separates the centroids (all coincide): halves by count.
                    None => refs.len() / 2,
                };
                (refs.len() - right, right)
            }
        };
        let added = (left_count + right_count).saturating_sub(task.count);
        let remaining = task.budget.saturating_sub(added);
        let left_budget =
            (remaining as u64 * left_count as u64 / (left_count + right_count) as u64) as usize;
        let first = nodes.len();
        nodes.extend([BvhNode::default(); 2]);
        nodes[task.node].first = first as u32;
        let top = work.len();
        let right_refs = &work[top - left_count - right_count..top - left_count];
        tasks.push(Task {
            node: first + 1,
            count: right_count,
            bounds: union_of(right_refs),
            budget: remaining - left_budget,
            depth: task.depth + 1,
        });
        tasks.push(Task {
            node: first,
            count: left_count,
            bounds: union_of(&work[top - left_count..]),
            budget: left_budget,
            depth: task.depth + 1,
        });
    }
    let primitive_indices = (0..out.boxes.len() as u32).collect();
    let bvh = Bvh {
        nodes,
        primitive_indices,
    };
    (bvh, out)
}

/// The box around the references.
pub(super) fn union_of(refs: &[Reference]) -> Aabb {
    refs.iter().fold(Aabb::EMPTY, |acc, r| acc.union(&r.bounds))
}

/// Moves the references for which `first` holds to the front; returns how many did.
fn partition_by(refs: &mut [Reference], mut first: impl FnMut(&Reference) -> bool) -> usize {
    let mut next = 0;
    for i in 0..refs.len() {
        if first(&refs[i]) {
            refs.swap(i, next);
            next += 1;
        }
    }
    next
}

/// The cheapest binned object split of a node: its plane, its SAH area cost
/// `area(L) n(L) + area(R) n(R)`, and the children's boxes.
struct ObjectSplit {
    axis: usize,
    /// The last bin on the left.
    last_left_bin: usize,
    origin: Vec3A,
    scale: Vec3A,
    bins: usize,
    cost: f32,
    left: Aabb,
    right: Aabb,
}

impl ObjectSplit {
    #[inline(always)]
    fn goes_left(&self, r: &Reference) -> bool {
        bin_of(r.centroid(), self.origin, self.scale, self.bins)[self.axis] <= self.last_left_bin
    }
}

/// The bins of a centroid on the three axes: the same arithmetic for binning and for the
/// partition, so that both see every reference on the same side.
#[inline(always)]
fn bin_of(c: Vec3A, origin: Vec3A, scale: Vec3A, bins: usize) -> [usize; 3] {
    let v = ((c - origin) * scale).clamp(Vec3A::ZERO, Vec3A::splat((bins - 1) as f32));
    [v.x as usize, v.y as usize, v.z as usize]
}

/// Bins the references' centroids and sweeps each axis for the cheapest plane; `None` when
/// all centroids coincide (no plane separates them).
fn best_object_split(refs: &[Reference], bins: usize) -> Option<ObjectSplit> {
    use super::sbvh_spatial::MAX_BINS;
    let centroids = refs
        .iter()
        .fold(Aabb::EMPTY, |acc, r| acc.grow(r.centroid()));
    let extent = centroids.extent();
    // Axes with no extent (or an infinite one) get scale 0: all in bin 0, no plane priced.
    let scale = Vec3A::select(
        extent.cmpgt(Vec3A::ZERO) & extent.is_finite_mask(),
        Vec3A::splat(bins as f32 * (1.0 - 1e-6)) / extent,
        Vec3A::ZERO,
    );
    let mut boxes = [[Aabb::EMPTY; MAX_BINS]; 3];
    let mut counts = [[0u32; MAX_BINS]; 3];
    for r in refs {
        let b = bin_of(r.centroid(), centroids.min, scale, bins);
        for axis in 0..3 {
            boxes[axis][b[axis]] = boxes[axis][b[axis]].union(&r.bounds);
            counts[axis][b[axis]] += 1;
        }
    }
    let mut best: Option<ObjectSplit> = None;
    for axis in 0..3 {
        if scale[axis] == 0.0 {
            continue;
        }
        let sweep = sweep_bins(
            &boxes[axis][..bins],
            &counts[axis][..bins],
            &counts[axis][..bins],
        );
        if let Some((plane, cost, left, right)) = sweep
            && best.as_ref().is_none_or(|b| cost < b.cost)
        {
            best = Some(ObjectSplit {
                axis,
                last_left_bin: plane,
                origin: centroids.min,
                scale,
                bins,
                cost,
                left,
                right,
            });
        }
    }
    best
}

/// The cheapest plane between bins: bins `..=plane` on the left (counted by `enter`), the
/// rest on the right (counted by `leave`); returns `(plane, area cost, left box, right box)`,
/// or `None` when every plane leaves a side empty.
pub(super) fn sweep_bins(
    boxes: &[Aabb],
    enter: &[u32],
    leave: &[u32],
) -> Option<(usize, f32, Aabb, Aabb)> {
    let bins = boxes.len();
    let mut right = [(Aabb::EMPTY, 0u32); super::sbvh_spatial::MAX_BINS];
    let mut acc = (Aabb::EMPTY, 0u32);
    for i in (1..bins).rev() {
        acc = (acc.0.union(&boxes[i]), acc.1 + leave[i]);
        right[i] = acc;
    }
    let mut best = None;
    let mut left = (Aabb::EMPTY, 0u32);
    for i in 0..bins - 1 {
        left = (left.0.union(&boxes[i]), left.1 + enter[i]);
        let (r_box, r_count) = right[i + 1];
        if left.1 == 0 || r_count == 0 {
            continue;
        }
        let cost = left.0.half_area() * left.1 as f32 + r_box.half_area() * r_count as f32;
        if best.as_ref().is_none_or(|&(_, c, _, _)| cost < c) {
            best = Some((i, cost, left.0, r_box));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Slanted slivers across a grid of small triangles: the build cuts the slivers (more
    /// references than triangles, every sliver's pieces covering it), keeps within the
    /// reference budget, and every triangle has a reference.
    #[test]
    fn slivers_are_cut_within_the_budget() {
        let mut tris: Vec<[Vec3A; 3]> = Vec::new();
        for i in 0..400 {
            let p = Vec3A::new((i % 20) as f32, (i / 20) as f32, ((i * 7) % 5) as f32);
            tris.push([p, p + Vec3A::X * 0.5, p + Vec3A::Y * 0.5]);
        }
        for k in 0..20 {
            let y = k as f32;
            tris.push([
                Vec3A::new(0.0, y, 0.0),
                Vec3A::new(20.0, 20.0 - y, 5.0),
                Vec3A::new(20.0, 20.3 - y, 5.0),
            ]);
        }
        let boxes: Vec<Aabb> = tris.iter().map(|t| Aabb::from_points(*t)).collect();
        for budget in [0.05, 0.3, 1.0] {
            let settings = SpatialSplits {
                reference_budget: budget,
                ..SpatialSplits::default()
            };
            let (bvh, refs) = build_spatial_splits(
                &boxes,
                |t| tris[t as usize],
                &BuildConfig::default(),
                &settings,
            );
            let n = tris.len();
            assert!(refs.boxes.len() > n, "budget {budget}: nothing cut");
            assert!(
                refs.boxes.len() <= n + (budget * n as f32) as usize,
                "budget {budget}: {} references",
                refs.boxes.len()
            );
            assert_eq!(bvh.primitive_indices.len(), refs.boxes.len());
            for t in 0..n as u32 {
                let pieces: Vec<Aabb> = (0..refs.boxes.len())
                    .filter(|&r| refs.triangles[r] == t)
                    .map(|r| refs.boxes[r])
                    .collect();
                assert!(!pieces.is_empty(), "triangle {t} lost");
                let [a, b, c] = tris[t as usize];
                for i in 0..=50 {
                    let u = i as f32 / 50.0;
                    for v in [0.0, 0.5, 1.0] {
                        // The sample itself rounds: it may fall an ulp off the triangle.
                        let p = a + (b - a) * u + (c - b) * (u * v);
                        let near =
                            |piece: &Aabb| piece.expanded(Vec3A::splat(1e-5)).contains_point(p);
                        assert!(pieces.iter().any(near), "{p}");
                    }
                }
            }
        }
    }
}
