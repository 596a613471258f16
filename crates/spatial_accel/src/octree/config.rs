//! The loose tree's settings: how loose its cells are, how deep it may go, and the world cube
//! its root starts as.

use crate::Aabb;
use core::fmt;
use glam::Vec3A;

/// The smallest looseness accepted: at 1 the loose cells are the cells themselves and the tree
/// is a classic octree, where an object on a cell boundary stays in the parent.
pub const MIN_LOOSENESS: f32 = 1.0;

/// The largest looseness accepted. Ulrich (Game Programming Gems 1, "Loose Octrees") uses 2,
/// where an object's depth follows from its size alone. Past 4 a loose cell reaches more than
/// one and a half cells beyond its own on each side, so a query enters most of its
/// neighbours' subtrees as well and the tree stops pruning.
pub const MAX_LOOSENESS: f32 = 4.0;

/// The root never grows past this half size: the loose bounds of a larger one, at the largest
/// looseness, would come within reach of `f32` overflow once offset by its centre.
pub const MAX_ROOT_HALF_SIZE: f32 = 1e30;

/// The deepest [`OctreeConfig::max_depth`] accepted.
pub const MAX_DEPTH_LIMIT: u8 = 40;

/// Tuning of a [`LooseTree`](super::LooseTree) (the [`LooseOctree`](super::LooseOctree) and
/// the [`Quadtree`](super::Quadtree)); the defaults suit game worlds measured in metres.
///
/// Every field is plain data so that a benchmark can sweep it;
/// [`LooseTree::with_config`](super::LooseTree::with_config) refuses a configuration outside
/// the ranges documented here (it never clamps silently).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OctreeConfig {
    /// How far a loose cell reaches: its half size is `looseness` times its cell's. Must lie
    /// in [`MIN_LOOSENESS`]`..=`[`MAX_LOOSENESS`]. Larger values let objects sit deeper and
    /// move further before they change cell; smaller ones make cells overlap less, so queries
    /// enter fewer of them.
    pub looseness: f32,
    /// Levels of cells below the world cube: the deepest cells have half size
    /// `world_half_size / 2^max_depth`. At most [`MAX_DEPTH_LIMIT`], and the deepest cells
    /// must keep a normal `f32` half size.
    pub max_depth: u8,
    /// The centre of the cube the root starts as.
    pub world_center: Vec3A,
    /// Half the side of the cube the root starts as. Finite, positive, at most
    /// [`MAX_ROOT_HALF_SIZE`]. Objects outside it are not lost: the root grows to take them.
    pub world_half_size: f32,
    /// Entries per deepest cell the tree's depth aims at: it goes no deeper than the first
    /// level whose cells, `2^axes` times more at each level, would hold the entries at this
    /// many each, however small they are (and never past `max_depth`). 0, the default: depth
    /// follows from size alone, up to `max_depth`.
    ///
    /// Why: with depth from size alone, small objects each end at an octant of their own a
    /// dozen levels down, so a box query walks a chain of octants per object found, where an
    /// R-tree reads one node per few. The limit keeps several objects per deepest octant
    /// instead, and rises as the tree fills: box queries, updates and frusta get cheaper, but
    /// rays slower, since a ray tests a shared octant's objects in no order (BENCHMARKS.md,
    /// "Quadtree against rstar" and "Loose octree"). So it is off by default, for the rays
    /// of picking and the preview.
    pub target_occupancy: u32,
}

impl Default for OctreeConfig {
    fn default() -> Self {
        Self {
            looseness: 2.0,
            max_depth: 12,
            world_center: Vec3A::ZERO,
            world_half_size: 1024.0,
            target_occupancy: 0,
        }
    }
}

/// Why [`LooseTree::with_config`](super::LooseTree::with_config) refused a configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OctreeConfigError {
    /// The looseness is NaN or outside [`MIN_LOOSENESS`]`..=`[`MAX_LOOSENESS`].
    LoosenessOutOfRange(f32),
    /// The world cube's centre is not finite, or its half size is not finite, not positive,
    /// or above [`MAX_ROOT_HALF_SIZE`].
    InvalidWorld,
    /// `max_depth` exceeds [`MAX_DEPTH_LIMIT`], or makes the deepest cells too small for a
    /// normal `f32`.
    TooDeep(u8),
}

impl fmt::Display for OctreeConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::LoosenessOutOfRange(k) => write!(
                f,
                "looseness {k} is outside {MIN_LOOSENESS}..={MAX_LOOSENESS}"
            ),
            Self::InvalidWorld => {
                f.write_str("the world cube needs a finite centre and a positive, finite half size")
            }
            Self::TooDeep(d) => write!(f, "max_depth {d} makes the deepest cells too small"),
        }
    }
}

impl std::error::Error for OctreeConfigError {}

impl OctreeConfig {
    /// The default settings with the world cube around `bounds`: its centre, and its largest
    /// half extent (at least a millimetre, so a flat or point-sized world still has cells).
    pub fn for_world(bounds: &Aabb) -> Self {
        Self {
            world_center: bounds.center(),
            world_half_size: bounds.half_extents().max_element().max(1e-3),
            ..Self::default()
        }
    }

    /// This configuration with the looseness replaced.
    pub fn with_looseness(self, looseness: f32) -> Self {
        Self { looseness, ..self }
    }

    /// Checks every field against its documented range.
    pub fn validate(&self) -> Result<(), OctreeConfigError> {
        if !(MIN_LOOSENESS..=MAX_LOOSENESS).contains(&self.looseness) {
            return Err(OctreeConfigError::LoosenessOutOfRange(self.looseness));
        }
        let half = self.world_half_size;
        let world_ok = self.world_center.is_finite() && half > 0.0 && half <= MAX_ROOT_HALF_SIZE;
        if !world_ok {
            return Err(OctreeConfigError::InvalidWorld);
        }
        let deepest_half = half / 2f32.powi(i32::from(self.max_depth));
        if self.max_depth > MAX_DEPTH_LIMIT || !deepest_half.is_normal() {
            return Err(OctreeConfigError::TooDeep(self.max_depth));
        }
        Ok(())
    }
}
