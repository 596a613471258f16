//! The bottom level: a 16-wide BVH over one mesh's triangles.

use super::MeshHit;
use super::leaf_merge::merge_leaves;
use super::packets::{LeafPackets, triangle_bounds};
use super::presplit::presplit_triangles;
use super::sbvh::{SpatialSplits, build_spatial_splits};
use crate::bvh::wide::Bvh16;
use crate::{Aabb, Backfaces, BuildConfig, Bvh, Ray, SpatialQuery, SplitStrategy, WatertightRay};
use core::fmt;
use core::ops::ControlFlow;
use glam::{Vec3, Vec3A};

/// Why a mesh could not be built or refit.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MeshError {
    /// The index count is not a multiple of three (only triangle lists are supported).
    NotATriangleList {
        /// The number of indices given.
        index_count: usize,
    },
    /// An index names a vertex that does not exist.
    IndexOutOfRange {
        /// The offending index.
        index: u32,
        /// The number of vertices.
        vertex_count: usize,
    },
    /// A refit was given a different number of vertices than the mesh was built with.
    VertexCountChanged {
        /// Vertices at build time.
        expected: usize,
        /// Vertices given.
        got: usize,
    },
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NotATriangleList { index_count } => {
                write!(
                    f,
                    "{index_count} indices is not a triangle list (not a multiple of 3)"
                )
            }
            Self::IndexOutOfRange {
                index,
                vertex_count,
            } => {
                write!(
                    f,
                    "index {index} is out of range for {vertex_count} vertices"
                )
            }
            Self::VertexCountChanged { expected, got } => {
                write!(f, "refit with {got} vertices, but the mesh has {expected}")
            }
        }
    }
}

impl std::error::Error for MeshError {}

/// A 16-wide BVH over the triangles of one indexed mesh, answering exact (watertight) ray
/// queries in the mesh's own space.
///
/// Triangles are copied into leaf order at build time, four to a SIMD packet
/// ([`crate::Triangle4`]): a leaf's triangles sit next to each other in memory and a ray tests
/// them four at a time instead of chasing the index buffer. Triangles with non-finite corners
/// are left out (they cannot be hit). [`MeshBvh::new`] builds over pre-split triangles: a
/// large slanted triangle is bounded by several small boxes instead of one large one, and sits
/// in each leaf one of them reached (see [`MeshBvh::with_splits`]).
///
/// ```
/// use spatial_accel::{Backfaces, Ray};
/// use spatial_accel::mesh::MeshBvh;
/// use glam::{Vec3, Vec3A};
/// // A unit quad in the z = 0 plane, facing +z.
/// let vertices = [Vec3::new(0., 0., 0.), Vec3::new(1., 0., 0.), Vec3::new(1., 1., 0.), Vec3::new(0., 1., 0.)];
/// let mesh = MeshBvh::new(&vertices, &[0, 1, 2, 0, 2, 3]).unwrap();
/// let ray = Ray::new(Vec3A::new(0.25, 0.75, 5.0), Vec3A::NEG_Z);
/// let hit = mesh.cast_ray(&ray, Backfaces::Cull).unwrap();
/// assert_eq!((hit.t, hit.triangle, hit.front_face), (5.0, 1, true));
/// ```
#[derive(Clone, Debug)]
pub struct MeshBvh {
    /// The tree over packets: its primitive ids are packet indices.
    tree: MeshTree,
    pub(super) packets: LeafPackets,
    /// The packet boxes of the last refit, kept so refits do not allocate (and fault in) a
    /// fresh array each frame.
    refit_boxes: Vec<Aabb>,
    /// Each packet's part of its leaf while the tree is as built over pre-split triangles
    /// (the union of its triangles' pieces there); empty for a tree over whole triangles,
    /// and after a refit, which bounds whole triangles again.
    piece_boxes: Vec<Aabb>,
    /// Whether a triangle may sit in more than one leaf (the tree was built over pieces).
    pub(super) split: bool,
    triangle_count: usize,
    vertex_count: usize,
    /// How the tree was built, for a refit that must build it again.
    recipe: Recipe,
    /// The triangles with a non-finite corner at the build: the tree has no place for them.
    left_out: Vec<u32>,
    /// The index list, kept only when `left_out` is not empty (a refit that makes one of
    /// those triangles finite builds again from it).
    indices: Vec<u32>,
}

/// How a mesh's tree was built: the settings of [`MeshBvh::with_splits`] or of
/// [`MeshBvh::with_spatial_splits`].
#[derive(Clone, Copy, Debug)]
enum Recipe {
    /// Pre-split triangles (none for a budget of 0).
    Splits { config: BuildConfig, budget: f32 },
    /// Spatial splits.
    Spatial {
        config: BuildConfig,
        splits: SpatialSplits,
    },
}

/// The wide layout the mesh tree uses.
///
/// 16-wide rather than 8: the 16-wide node test runs 8 lanes at a time where the walk is
/// compiled with AVX2 (`bvh/wide/ray.rs`), which makes diffuse and incoherent rays on the
/// million-triangle scene faster, for a slightly slower build (BENCHMARKS.md, Rays on
/// meshes).
pub type MeshTree = Bvh16;

impl MeshBvh {
    /// Builds with [`MeshBvh::default_config`] for the mesh's size over triangles pre-split
    /// with [`MeshBvh::DEFAULT_SPLIT_BUDGET`] (see [`MeshBvh::with_splits`]), collapsed to
    /// 16-wide.
    pub fn new(vertices: &[Vec3], indices: &[u32]) -> Result<Self, MeshError> {
        Self::with_splits(
            vertices,
            indices,
            &Self::default_config(indices.len() / 3),
            Self::DEFAULT_SPLIT_BUDGET,
        )
    }

    /// The pre-split budget [`MeshBvh::new`] uses: up to 30% more references than
    /// triangles, Karras and Aila's choice.
    ///
    /// On the million-triangle benchmark scene (bunnies among large slanted triangles) every
    /// kind of ray traces faster than over whole triangles, for a longer build; budgets from
    /// 0.2 to 0.4 trace alike (BENCHMARKS.md, Rays on meshes). A mesh of like triangles (a
    /// tessellated sphere, the bunny) has none worth cutting and builds as over whole
    /// triangles, but for one pass over its triangles.
    pub const DEFAULT_SPLIT_BUDGET: f32 = 0.3;

    /// The build [`MeshBvh::new`] uses for a mesh of `triangles` triangles: binned SAH up to
    /// 65,536 triangles, PLOC with reinsertion of 1.5% of the nodes above; leaves of up to 8
    /// triangles chosen by cost either way.
    ///
    /// A mesh is built once and traced for many frames, so it reinserts more than
    /// [`SplitStrategy::PLOC`] (1.2%, the preset balanced against build speed): on the
    /// million-triangle benchmark scene, 1.2% traces shadow and diffuse rays slower than 1.5%
    /// (BENCHMARKS.md, Rays on meshes).
    ///
    /// Why the two builds: on a small mesh (a sphere of about a thousand triangles) the binned
    /// tree answers rays faster than the PLOC one, and both build in a blink; on the
    /// million-triangle benchmark scene PLOC builds much faster and its tree traces as fast or
    /// faster (BENCHMARKS.md, Static BVH builds and Rays on meshes). Where between the two the
    /// crossover lies is not measured.
    pub fn default_config(triangles: usize) -> BuildConfig {
        if triangles <= 1 << 16 {
            BuildConfig::default()
        } else {
            BuildConfig::with_split(SplitStrategy::Ploc {
                search_radius: 1,
                reinsert_per_mille: 15,
            })
        }
    }

    /// Builds with a chosen configuration, over whole triangles.
    pub fn with_config(
        vertices: &[Vec3],
        indices: &[u32],
        config: &BuildConfig,
    ) -> Result<Self, MeshError> {
        Self::with_splits(vertices, indices, config, 0.0)
    }

    /// Builds with a chosen configuration over triangles pre-split into pieces: `split_budget`
    /// pieces per triangle are added (`0.3`: 30% more references than triangles) where
    /// triangles' boxes waste the most area (Karras and Aila 2013, see `presplit.rs`), and
    /// over triangles larger than the mesh's leaves, each of which counts towards the budget
    /// as the leaves it spans; `0.0` builds over whole triangles. A triangle cut into pieces
    /// sits in every leaf one of them reached, so rays test it where it is instead of
    /// wherever its box reaches.
    ///
    /// Queries answer as for a tree over whole triangles (each hit once), and refits work;
    /// a refit bounds whole triangles again, so it keeps the tree correct but not the pieces'
    /// tightness.
    pub fn with_splits(
        vertices: &[Vec3],
        indices: &[u32],
        config: &BuildConfig,
        split_budget: f32,
    ) -> Result<Self, MeshError> {
        let recipe = Recipe::Splits {
            config: *config,
            budget: split_budget,
        };
        Self::build_with(vertices, indices, recipe)
    }

    /// Builds a spatial-split BVH (SBVH; Stich et al. 2009): a binned SAH build that, where
    /// the best split by triangles leaves overlapping children, also prices splitting space,
    /// cutting the triangles that straddle the plane into a piece on each side (see
    /// [`SpatialSplits`]). `config` gives the leaf size, depth limit and SAH costs; its split
    /// strategy is not used.
    ///
    /// The highest-quality and slowest build, for static meshes traced many times: on the
    /// million-triangle benchmark scene it builds much slower than the pre-split
    /// [`MeshBvh::new`] and traces every kind of ray faster than that tree, incoherent rays
    /// most (BENCHMARKS.md, Rays on meshes). Queries and refits behave as after
    /// [`MeshBvh::with_splits`].
    ///
    /// ```
    /// use spatial_accel::mesh::{MeshBvh, SpatialSplits};
    /// use spatial_accel::{BuildConfig, Ray};
    /// use glam::Vec3;
    /// // A long sliver across a row of small triangles.
    /// let mut vertices = vec![Vec3::ZERO, Vec3::new(100.0, 10.0, 0.0), Vec3::new(100.0, 11.0, 0.0)];
    /// let mut indices = vec![0, 1, 2];
    /// for i in 0..50u32 {
    ///     let p = Vec3::new(2.0 * i as f32, 0.0, 5.0);
    ///     vertices.extend([p, p + Vec3::X, p + Vec3::Y]);
    ///     indices.extend([3 + 3 * i, 4 + 3 * i, 5 + 3 * i]);
    /// }
    /// let mesh = MeshBvh::with_spatial_splits(
    ///     &vertices,
    ///     &indices,
    ///     &BuildConfig::default(),
    ///     &SpatialSplits::default(),
    /// )
    /// .unwrap();
    /// mesh.validate().unwrap();
    /// let ray = Ray::new(Vec3::new(50.0, 5.2, -1.0), Vec3::Z);
    /// assert_eq!(mesh.cast_ray(&ray, Default::default()).unwrap().triangle, 0);
    /// ```
    pub fn with_spatial_splits(
        vertices: &[Vec3],
        indices: &[u32],
        config: &BuildConfig,
        splits: &SpatialSplits,
    ) -> Result<Self, MeshError> {
        let recipe = Recipe::Spatial {
            config: *config,
            splits: *splits,
        };
        Self::build_with(vertices, indices, recipe)
    }

    /// Checks the triangle list, bounds its triangles, builds the binary tree the recipe
    /// asks for over their boxes (or over pieces of them), and finishes it.
    fn build_with(vertices: &[Vec3], indices: &[u32], recipe: Recipe) -> Result<Self, MeshError> {
        if !indices.len().is_multiple_of(3) {
            return Err(MeshError::NotATriangleList {
                index_count: indices.len(),
            });
        }
        if let Some(&index) = indices.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(MeshError::IndexOutOfRange {
                index,
                vertex_count: vertices.len(),
            });
        }
        let corners =
            |t: u32| [0, 1, 2].map(|k| Vec3A::from(vertices[indices[3 * t as usize + k] as usize]));
        let boxes: Vec<Aabb> = (0..(indices.len() / 3) as u32)
            .map(|t| triangle_bounds(&corners(t)))
            .collect();
        let triangle_count = boxes.iter().filter(|b| !b.is_empty()).count();
        let (config, (mut bvh, references)) = match recipe {
            Recipe::Splits { config, budget } => {
                let references = (budget > 0.0)
                    .then(|| presplit_triangles(&boxes, corners, budget))
                    .filter(|refs| refs.boxes.len() > boxes.len());
                let bvh = Bvh::build(
                    references.as_ref().map_or(&boxes, |refs| &refs.boxes),
                    &config,
                );
                (config, (bvh, references))
            }
            Recipe::Spatial { config, splits } => {
                let (bvh, references) = build_spatial_splits(&boxes, corners, &config, &splits);
                (config, (bvh, Some(references)))
            }
        };
        merge_leaves(
            &mut bvh,
            references.as_ref().map(|refs| refs.triangles.as_slice()),
            &config,
        );
        let left_out: Vec<u32> = (0..boxes.len() as u32)
            .filter(|&t| boxes[t as usize].is_empty())
            .collect();
        let (packets, piece_boxes) =
            LeafPackets::pack(&mut bvh, vertices, indices, references.as_ref());
        Ok(Self {
            tree: MeshTree::from_bvh(&bvh),
            packets,
            refit_boxes: Vec::new(),
            split: references.is_some(),
            piece_boxes,
            triangle_count,
            vertex_count: vertices.len(),
            recipe,
            indices: if left_out.is_empty() {
                Vec::new()
            } else {
                indices.to_vec()
            },
            left_out,
        })
    }

    /// The box around the mesh.
    pub fn bounds(&self) -> Aabb {
        self.tree.bounds()
    }

    /// Number of triangles in the tree.
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// Triangles as the leaves hold them: [`MeshBvh::triangle_count`] over whole triangles,
    /// more where pre-split triangles sit in several leaves (see [`MeshBvh::with_splits`]).
    pub fn leaf_triangle_count(&self) -> usize {
        (0..self.packets.packets.len() as u32)
            .map(|p| self.packets.used_lanes(p).count())
            .sum()
    }

    /// The tree; its primitive ids are packets of four triangles.
    pub fn tree(&self) -> &MeshTree {
        &self.tree
    }

    /// Memory held, in bytes.
    pub fn memory_bytes(&self) -> usize {
        self.tree.memory_bytes()
            + self.packets.memory_bytes()
            + (self.refit_boxes.capacity() + self.piece_boxes.capacity()) * size_of::<Aabb>()
            + (self.left_out.capacity() + self.indices.capacity()) * 4
    }

    /// The hits of a packet whose triangle's own box the ray touches, the others dropped.
    ///
    /// Why: on corners near the float range's ends (subnormal or `f32::MAX`-sized) the
    /// watertight test's rounding can report a hit at a point outside the triangle's box,
    /// which only some leaf boxes hold. A true hit always lies in the box, so the rule (the
    /// brute-force oracle's too) is that a triangle whose box the ray misses is not hit. Only
    /// hit lanes pay for the test.
    #[inline(always)]
    fn in_triangle_boxes(
        &self,
        packet: u32,
        ray: &Ray,
        mut hits: crate::Triangle4Hits,
    ) -> crate::Triangle4Hits {
        let mut mask = hits.mask;
        while mask != 0 {
            let lane = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            if !ray.hits_aabb(&Aabb::from_points(self.packets.corners(packet, lane))) {
                hits.mask &= !(1 << lane);
            }
        }
        hits
    }

    pub(super) fn hit_record(&self, packet: u32, lane: usize, hit: crate::TriangleHit) -> MeshHit {
        let [a, b, c] = self.packets.corners(packet, lane);
        MeshHit {
            t: hit.t,
            triangle: self.packets.triangle(packet, lane),
            barycentrics: hit.barycentrics(),
            geometric_normal: (b - a).cross(c - a).normalize_or_zero(),
            front_face: hit.front_face,
        }
    }

    /// The closest hit along the ray, or `None`.
    pub fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<MeshHit> {
        let mut wt = WatertightRay::new(ray);
        let mut best: Option<(u32, usize, crate::TriangleHit)> = None;
        self.tree.cast_ray(
            ray,
            // Inlined into the walk, so that the 4-lane test is compiled with it, with AVX2
            // where the walk is (see `bvh::wide::ray::visit_ray`).
            #[inline(always)]
            |packet, r| {
                wt.set_t_max(r.t_max);
                let hits = wt.intersect4(self.packets.corners4(packet), backfaces);
                let (lane, h) = self.in_triangle_boxes(packet, ray, hits).closest()?;
                if best.is_none_or(|(_, _, b)| h.t < b.t) {
                    best = Some((packet, lane, h));
                }
                Some(h.t)
            },
        )?;
        best.map(|(packet, lane, h)| self.hit_record(packet, lane, h))
    }

    /// True when anything blocks the ray (shadow rays: stops at the first hit found).
    pub fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool {
        let wt = WatertightRay::new(ray);
        self.tree
            .cast_ray_any(
                ray,
                // Inlined into the walk (see `cast_ray`).
                #[inline(always)]
                |packet, _| {
                    let hits = wt.intersect4(self.packets.corners4(packet), backfaces);
                    self.in_triangle_boxes(packet, ray, hits).mask != 0
                },
            )
            .is_some()
    }

    /// Every hit along the ray, nearest first (ties by triangle index), appended to `out`.
    pub fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<MeshHit>) {
        let wt = WatertightRay::new(ray);
        let start = out.len();
        // An any-hit traversal that never accepts visits every leaf the ray reaches.
        self.tree.cast_ray_any(ray, |packet, _| {
            let hits = wt.intersect4(self.packets.corners4(packet), backfaces);
            let hits = self.in_triangle_boxes(packet, ray, hits);
            let mut mask = hits.mask;
            while mask != 0 {
                let lane = mask.trailing_zeros() as usize;
                mask &= mask - 1;
                out.push(self.hit_record(packet, lane, hits.hit(lane)));
            }
            false
        });
        out[start..].sort_unstable_by(|a, b| a.t.total_cmp(&b.t).then(a.triangle.cmp(&b.triangle)));
        if self.split {
            // A triangle met in two leaves (through two of its pieces) is hit once: the same
            // lane test on the same corners gives the same bits, so the copies sit together.
            let mut kept = start;
            for i in start..out.len() {
                if kept == start || out[kept - 1].triangle != out[i].triangle {
                    out.swap(kept, i);
                    kept += 1;
                }
            }
            out.truncate(kept);
        }
    }

    /// Calls `visit(triangle index)` once for each triangle that may touch `aabb`: every
    /// triangle that does, and only triangles whose box overlaps `aabb`. (Over whole
    /// triangles that is exactly those whose box overlaps; over pre-split ones, a triangle
    /// whose box overlaps but none of whose pieces' boxes does is passed over.)
    pub fn for_each_triangle_overlapping(&self, aabb: &Aabb, mut visit: impl FnMut(u32)) {
        let mut found = Vec::new();
        self.tree.for_each_overlapping_aabb(aabb, |packet| {
            for lane in self.packets.used_lanes(packet) {
                if self.packets.lane_bounds(packet, lane).intersects_aabb(aabb) {
                    let triangle = self.packets.triangle(packet, lane);
                    if self.split {
                        found.push(triangle);
                    } else {
                        visit(triangle);
                    }
                }
            }
            ControlFlow::Continue(())
        });
        // Pieces of one triangle in several leaves: visited once.
        found.sort_unstable();
        found.dedup();
        found.into_iter().for_each(visit);
    }

    /// Checks the tree against the mesh's current triangles (see
    /// [`crate::bvh::wide::WideBvh::validate`]): every packet reachable once, inside its leaf.
    /// A tree as built over pre-split triangles is checked against its packets' pieces, and
    /// each piece against its packet's triangles.
    pub fn validate(&self) -> Result<(), crate::bvh::validate::ValidationError> {
        let boxes: Vec<Aabb> = (0..self.packets.packets.len() as u32)
            .map(|p| self.packets.packet_bounds(p))
            .collect();
        if self.piece_boxes.is_empty() {
            // A refit to a pose in which every triangle of a packet has a non-finite corner
            // leaves the packet in its leaf with an empty box: it is known, and bounded by
            // any leaf, but holds nothing to find (the plain validator would call it unknown).
            return self
                .tree
                .validate_with(boxes.len(), |p| boxes.get(p as usize).copied());
        }
        for (packet, (piece, whole)) in self.piece_boxes.iter().zip(&boxes).enumerate() {
            if !whole.contains_aabb(piece) {
                return Err(
                    crate::bvh::validate::ValidationError::PieceOutsidePrimitive(packet as u32),
                );
            }
        }
        self.tree.validate(&self.piece_boxes)
    }

    /// Moves the vertices (a skinned or morphed pose) and refits the tree to them, keeping
    /// its topology: fast, but the tree degrades if the pose strays far from the build pose.
    ///
    /// A triangle with a non-finite corner is never hit; one that had such a corner when the
    /// tree was built is in no leaf, so a pose that makes it finite again builds the tree
    /// anew (with the build's own settings): a refit would leave it unreachable, and rays
    /// through it would miss.
    pub fn refit(&mut self, vertices: &[Vec3]) -> Result<(), MeshError> {
        if vertices.len() != self.vertex_count {
            return Err(MeshError::VertexCountChanged {
                expected: self.vertex_count,
                got: vertices.len(),
            });
        }
        let indices = &self.indices;
        let corners =
            |t: u32| [0, 1, 2].map(|k| Vec3A::from(vertices[indices[3 * t as usize + k] as usize]));
        if self
            .left_out
            .iter()
            .any(|&t| !triangle_bounds(&corners(t)).is_empty())
        {
            let indices = core::mem::take(&mut self.indices);
            *self = Self::build_with(vertices, &indices, self.recipe)?;
            return Ok(());
        }
        // Two passes: the packets are rewritten in memory order (one sequential stream over
        // packets and vertex indices) and their boxes kept; the tree sweep then reads boxes.
        let boxes = &mut self.refit_boxes;
        boxes.clear();
        boxes.extend(
            (0..self.packets.packets.len() as u32).map(|p| self.packets.move_packet(p, vertices)),
        );
        self.tree.refit(|packet| boxes[packet as usize]);
        self.piece_boxes = Vec::new();
        Ok(())
    }
}

impl crate::query::TriangleQuery for MeshBvh {
    fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    fn bounds(&self) -> Aabb {
        MeshBvh::bounds(self)
    }

    fn cast_ray(&self, ray: &Ray, backfaces: Backfaces) -> Option<MeshHit> {
        MeshBvh::cast_ray(self, ray, backfaces)
    }

    fn cast_ray_any(&self, ray: &Ray, backfaces: Backfaces) -> bool {
        MeshBvh::cast_ray_any(self, ray, backfaces)
    }

    fn cast_ray_all(&self, ray: &Ray, backfaces: Backfaces, out: &mut Vec<MeshHit>) {
        MeshBvh::cast_ray_all(self, ray, backfaces, out)
    }

    fn for_each_triangle_overlapping<F: FnMut(u32)>(&self, aabb: &Aabb, visit: F) {
        MeshBvh::for_each_triangle_overlapping(self, aabb, visit)
    }
}
