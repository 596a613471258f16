//! The generational handle every dynamic index gives out for its entries.

use core::fmt;
use core::hash::{Hash, Hasher};
use core::marker::PhantomData;

/// A stable reference to one entry of a dynamic structure `S`: valid from `insert` until
/// `remove`.
///
/// It names a slot (a dynamic BVH's leaf node, an entry of an octree's or grid's slot table)
/// and the generation that slot had when the entry was inserted, 8 bytes in all. Removing the
/// entry advances the slot's generation, so a handle kept past `remove` no longer matches: the
/// structure reports it stale ([`IndexError::StaleHandle`](super::IndexError::StaleHandle))
/// instead of naming whatever entry later reused the slot.
///
/// `S`, the structure the handle came from, is only a marker: the compiler refuses a grid
/// handle given to an octree, and the handle is `Copy`, `Send` and `Sync`, compared and
/// hashed by its index and generation, whatever `S` is. The structures' own names for it are
/// aliases: [`LeafHandle`](crate::dynamic::LeafHandle),
/// [`OctreeHandle`](crate::octree::OctreeHandle), [`GridHandle`](crate::grid::GridHandle)
/// and [`FlatHandle`](super::FlatHandle).
///
/// ```
/// use spatial_accel::{Aabb, DynamicBvh, LeafHandle};
/// use glam::Vec3A;
/// let mut tree = DynamicBvh::new();
/// let handle: LeafHandle = tree.insert(7, Aabb::new(Vec3A::ZERO, Vec3A::ONE)).unwrap();
/// // Packed into a `u64` to be stored elsewhere, and back.
/// assert_eq!(LeafHandle::from_bits(handle.to_bits()), handle);
/// assert_eq!(tree.remove(handle), Ok(7));
/// // Kept past `remove`: stale, even once another entry reuses the slot.
/// let _ = tree.insert(8, Aabb::new(Vec3A::ZERO, Vec3A::ONE)).unwrap();
/// assert!(tree.remove(handle).is_err());
/// ```
///
/// A handle of one structure is refused by another:
///
/// ```compile_fail
/// use spatial_accel::query::DynamicIndex;
/// use spatial_accel::{Aabb, LooseOctree, UniformGrid};
/// use glam::Vec3A;
/// let mut grid = UniformGrid::new();
/// let handle = grid.insert(7, Aabb::new(Vec3A::ZERO, Vec3A::ONE)).unwrap();
/// LooseOctree::new().remove(handle);
/// ```
pub struct Handle<S> {
    index: u32,
    generation: u32,
    /// `fn() -> S`: the marker neither owns an `S` nor takes `S`'s auto traits.
    structure: PhantomData<fn() -> S>,
}

const _: () = assert!(
    size_of::<Handle<()>>() == 8
        && size_of::<crate::dynamic::LeafHandle>() == 8
        && size_of::<crate::octree::OctreeHandle>() == 8
        && size_of::<crate::grid::GridHandle>() == 8
        && size_of::<super::FlatHandle>() == 8
);

impl<S> Handle<S> {
    /// The handle of slot `index` at `generation`: for the structures that give handles out.
    #[inline]
    pub(crate) const fn new(index: u32, generation: u32) -> Self {
        Self {
            index,
            generation,
            structure: PhantomData,
        }
    }

    /// The slot the entry occupies. For a [`DynamicBvh`](crate::DynamicBvh) leaf, its node
    /// index in the tree (a [`BoundingTree`](super::BoundingTree) node id).
    #[inline]
    pub const fn index(self) -> u32 {
        self.index
    }

    /// The slot's generation when the entry was inserted.
    #[inline]
    pub const fn generation(self) -> u32 {
        self.generation
    }

    /// The handle packed into 64 bits (to store it in a component or a slot map): the
    /// generation in the high half, the index in the low half.
    pub const fn to_bits(self) -> u64 {
        ((self.generation as u64) << 32) | self.index as u64
    }

    /// The handle packed by [`Handle::to_bits`].
    pub const fn from_bits(bits: u64) -> Self {
        Self::new(bits as u32, (bits >> 32) as u32)
    }
}

impl<S> Clone for Handle<S> {
    #[inline]
    fn clone(&self) -> Self {
        *self
    }
}

impl<S> Copy for Handle<S> {}

impl<S> PartialEq for Handle<S> {
    #[inline]
    fn eq(&self, other: &Self) -> bool {
        self.index == other.index && self.generation == other.generation
    }
}

impl<S> Eq for Handle<S> {}

impl<S> Hash for Handle<S> {
    fn hash<H: Hasher>(&self, state: &mut H) {
        self.index.hash(state);
        self.generation.hash(state);
    }
}

impl<S> fmt::Debug for Handle<S> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Handle")
            .field("index", &self.index)
            .field("generation", &self.generation)
            .finish()
    }
}

#[cfg(test)]
mod tests {
    use super::Handle;

    /// A marker that implements nothing: the handle's traits must not need it to.
    struct Bare;

    #[test]
    fn bits_round_trip_and_traits_ignore_the_marker() {
        let h = Handle::<Bare>::new(3, 9);
        assert_eq!(h.to_bits(), (9 << 32) | 3);
        let back = Handle::<Bare>::from_bits(h.to_bits());
        assert_eq!((back.index(), back.generation()), (3, 9));
        assert_eq!(back, h);
        assert_ne!(Handle::<Bare>::new(3, 10), h);
        let copy = h;
        assert_eq!(format!("{copy:?}"), "Handle { index: 3, generation: 9 }");
        let set: std::collections::HashSet<_> = [h, copy].into();
        assert_eq!(set.len(), 1);
    }
}
