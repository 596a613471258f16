//! What the three builds share: the SAH cost of a candidate plane, the order in which planes
//! compete, how a split sorts a node's triangles, and how it clips the ones it cuts.
//!
//! The builds differ only in how they count triangles at each plane; everything that decides
//! the tree is here, written once, so that they cannot drift apart.

use super::KdTreeConfig;
use crate::{Aabb, clipped_triangle_bounds};
use glam::Vec3A;

/// A triangle's part in a node: its index and the box of what of it lies inside the node.
#[derive(Clone, Copy, Debug)]
pub(super) struct Part {
    /// The caller's triangle index.
    pub triangle: u32,
    /// The box of the triangle clipped to the node (Wald and Havran's "perfect splits").
    pub bounds: Aabb,
}

impl Part {
    /// A part with its box made canonical: `-0.0` becomes `0.0`, so that the sorted sweep
    /// (which orders by bits) and the counting builds (which compare with `==`) see one
    /// position where a box edge sits at zero.
    pub fn new(triangle: u32, bounds: Aabb) -> Self {
        Self {
            triangle,
            bounds: Aabb::new(bounds.min + Vec3A::ZERO, bounds.max + Vec3A::ZERO),
        }
    }
}

/// Where a split puts a triangle.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Side {
    /// Only the child below the plane.
    Below,
    /// Only the child above the plane.
    Above,
    /// Both: the triangle crosses the plane and is clipped to each side.
    Both,
}

/// A chosen split: the plane, and the side that triangles lying in it go to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Split {
    pub axis: usize,
    pub position: f32,
    /// [`Side::Below`] or [`Side::Above`].
    pub planar: Side,
}

impl Split {
    /// The boxes of the child below and the child above.
    pub fn children(&self, node: &Aabb) -> (Aabb, Aabb) {
        let (mut below, mut above) = (*node, *node);
        below.max[self.axis] = self.position;
        above.min[self.axis] = self.position;
        (below, above)
    }

    /// Which side gets a part with box `bounds`: a box in the plane goes to the planar side,
    /// one that ends at or before the plane below, one that starts at or after it above, and
    /// one that crosses it to both. (The counts the search was given match this exactly:
    /// below `#{min < p}`, above `#{max > p}` after the planar ones are placed.)
    #[inline]
    pub fn classify(&self, bounds: &Aabb) -> Side {
        let (lo, hi) = (bounds.min[self.axis], bounds.max[self.axis]);
        if lo == self.position && hi == self.position {
            self.planar
        } else if hi <= self.position {
            Side::Below
        } else if lo >= self.position {
            Side::Above
        } else {
            Side::Both
        }
    }
}

/// The search for the cheapest plane of one node, fed every candidate plane in one fixed
/// order (axis 0 to 2, each by increasing position); ties go to the first, so every build
/// that feeds the same counts in that order picks the same plane.
pub(super) struct SplitSearch<'a> {
    node: Aabb,
    half_area: f32,
    config: &'a KdTreeConfig,
    best: Option<Split>,
    /// The cost to beat: a leaf's at first (cost-based termination), then the best split's.
    best_cost: f32,
}

impl<'a> SplitSearch<'a> {
    /// A search over `node` holding `n` triangle parts.
    pub fn new(node: &Aabb, n: usize, config: &'a KdTreeConfig) -> Self {
        Self {
            node: *node,
            half_area: node.half_area(),
            config,
            best: None,
            best_cost: config.intersection_cost * n as f32,
        }
    }

    /// True when the node has no extent on `axis`: no plane across it divides anything.
    pub fn is_flat(&self, axis: usize) -> bool {
        // Node boxes are finite (a NaN one would price every plane at NaN, which never wins).
        self.node.min[axis] >= self.node.max[axis]
    }

    /// The split found, if one is cheaper than a leaf.
    pub fn best(&self) -> Option<Split> {
        self.best
    }

    /// The SAH cost of a split whose sides have relative areas `area_below`, `area_above`
    /// and hold `below`, `above` parts; a side left empty earns the bonus.
    fn cost(&self, area_below: f32, area_above: f32, below: usize, above: usize) -> f32 {
        let c = &self.config;
        let cost = c.traversal_cost
            + c.intersection_cost * (area_below * below as f32 + area_above * above as f32);
        if below == 0 || above == 0 {
            cost * c.empty_bonus
        } else {
            cost
        }
    }

    /// Prices the plane `point[axis] = position` with `below` parts wholly on the lower side
    /// or crossing it (`#{min < p}`), `above` likewise (`#{max > p}`) and `planar` lying in
    /// it, placing the planar ones on whichever side costs less (Wald and Havran, section
    /// 4.2).
    pub fn consider(
        &mut self,
        axis: usize,
        position: f32,
        below: usize,
        above: usize,
        planar: usize,
    ) {
        // A child's half area `xy + yz + zx` with its extent on `axis` replaced, written out
        // so each candidate costs a few products instead of two boxes.
        let (lo, hi) = (self.node.min[axis], self.node.max[axis]);
        let extent = self.node.extent();
        let (e1, e2) = (extent[(axis + 1) % 3], extent[(axis + 2) % 3]);
        let (side_sum, cross) = (e1 + e2, e1 * e2);
        let area_below = ((position - lo) * side_sum + cross) / self.half_area;
        let area_above = ((hi - position) * side_sum + cross) / self.half_area;
        let with_below = self.cost(area_below, area_above, below + planar, above);
        let with_above = self.cost(area_below, area_above, below, above + planar);
        // A plane on the node's face makes one child the whole node: it is worth anything
        // only as a flat child holding the triangles that lie in that face. Any other choice
        // there hands one child everything the node had, and the build would never end.
        let (cost, side) = if position <= lo {
            if planar == 0 {
                return;
            }
            (with_below, Side::Below)
        } else if position >= hi {
            if planar == 0 {
                return;
            }
            (with_above, Side::Above)
        } else if with_below < with_above {
            (with_below, Side::Below)
        } else {
            (with_above, Side::Above)
        };
        if cost < self.best_cost {
            self.best_cost = cost;
            self.best = Some(Split {
                axis,
                position,
                planar: side,
            });
        }
    }
}

/// The parts of a triangle that crosses the split, in the child below and the child above:
/// the triangle clipped to each child's box (and kept inside its part in the node), or `None`
/// where clipping finds nothing of it on that side.
pub(super) fn clip_to_children(
    corners: &[Vec3A; 3],
    part: &Part,
    node: &Aabb,
    split: &Split,
) -> [Option<Part>; 2] {
    let (below, above) = split.children(node);
    [below, above].map(|side| {
        // Both boxes hold the triangle's part in `side`, so their overlap does too.
        let clipped = clipped_triangle_bounds(corners, &side).intersection(&part.bounds);
        (!clipped.is_empty()).then(|| Part::new(part.triangle, clipped))
    })
}
