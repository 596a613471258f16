//! The index over the tracked entities, whatever its structure: [`EntityIndex`] and its
//! backends. It holds no entity and runs no system: slots, their entities and their own
//! spaces are [`AccelTrees`](crate::AccelTrees)' (`trees`), and the systems that edit and
//! keep it are in `systems`. Which structure holds the moving entities is [`IndexChoice`],
//! set in [`AccelSettings::index`](crate::AccelSettings::index) and changeable at run time.
//!
//! - `entity_index`: the static tree, the dynamic structure and the busy movers, queried as
//!   one.
//! - `bvh_backend`: the BVH's settings and stats.
//! - `automatic`: the thresholds of [`IndexChoice::Automatic`], the structure chosen from the
//!   workload.

mod automatic;
mod bvh_backend;
mod entity_index;

pub use automatic::{AutomaticIndexSettings, AutomaticIndexStats};
pub(crate) use bvh_backend::dynamic_config;
pub use bvh_backend::{BvhIndexSettings, BvhIndexStats};
pub use entity_index::EntityIndex;

use bevy::prelude::*;

/// The structure that holds the moving entities. Static entities
/// ([`AccelStatic`](crate::AccelStatic)) are always in a static BVH.
#[derive(Reflect, Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[reflect(Default)]
pub enum IndexChoice {
    /// A dynamic BVH with fat leaves, fused with the static tree, and a 16-wide snapshot for
    /// rays ([`BvhIndexSettings`]).
    Bvh,
    /// A loose octree ([`spatial_accel::LooseOctree`]): an entity at the depth its size gives, a move
    /// inside its loose cell one box write.
    Octree,
    /// A loose quadtree over x and y ([`spatial_accel::Quadtree`]), for 2D games: sprites and
    /// `Mesh2d` on the xy plane.
    Quadtree,
    /// A hashed uniform grid ([`spatial_accel::UniformGrid`]): entities in every cell they overlap,
    /// rays by 3D DDA.
    Grid,
    /// A flat list: every query tests every moving entity. For a handful of movers, and to
    /// check the others against.
    BruteForce,
    /// Chosen by the plugin from what it sees each frame (movers and rays;
    /// [`AutomaticIndexSettings`]): the BVH, or the grid for a busy set of movers that few
    /// rays walk. It starts on the BVH; [`AccelStats::index`](crate::AccelStats::index)
    /// names the structure in use. The default: in the whole-frame runs it was within the
    /// runs' spread of the best fixed choice (BENCHMARKS.md, Whole frame).
    #[default]
    Automatic,
}

impl IndexChoice {
    /// Every choice, in declaration order.
    pub const ALL: [IndexChoice; 6] = [
        IndexChoice::Bvh,
        IndexChoice::Octree,
        IndexChoice::Quadtree,
        IndexChoice::Grid,
        IndexChoice::BruteForce,
        IndexChoice::Automatic,
    ];

    /// The choice after this one in [`Self::ALL`], wrapping around: for a key or a button that
    /// cycles through them.
    ///
    /// ```
    /// use bevy_accel::IndexChoice;
    /// assert_eq!(IndexChoice::Bvh.next(), IndexChoice::Octree);
    /// assert_eq!(IndexChoice::Automatic.next(), IndexChoice::Bvh);
    /// ```
    pub fn next(self) -> Self {
        let i = Self::ALL.iter().position(|&c| c == self).unwrap_or(0);
        Self::ALL[(i + 1) % Self::ALL.len()]
    }

    /// The core's structure behind this choice; `None` for [`Automatic`](Self::Automatic),
    /// which is one of the others at any time.
    pub fn kind(self) -> Option<spatial_accel::query::IndexKind> {
        use spatial_accel::query::IndexKind;
        match self {
            Self::Bvh => Some(IndexKind::DynamicBvh),
            Self::Octree => Some(IndexKind::Octree),
            Self::Quadtree => Some(IndexKind::Quadtree),
            Self::Grid => Some(IndexKind::Grid),
            Self::BruteForce => Some(IndexKind::BruteForce),
            Self::Automatic => None,
        }
    }

    /// The choice that holds the core's structure `kind`.
    pub fn of_kind(kind: spatial_accel::query::IndexKind) -> Self {
        Self::ALL
            .into_iter()
            .find(|c| c.kind() == Some(kind))
            .unwrap_or_default()
    }
}
