//! The traversal stack: inline for the depths real trees have, growing for the ones they don't.

use core::mem::MaybeUninit;

/// A LIFO of node ids that lives on the call stack up to `INLINE` entries and spills to the heap
/// beyond. A ray query that allocated would cost more than the traversal itself (a shallow
/// traversal takes less time than an allocation), yet a dynamic tree or a degenerate build
/// can be far deeper than any fixed array, and overflowing one must not be possible.
///
/// The inline entries start uninitialised: a picking ray starts a walk per candidate mesh as
/// well as its own, and zeroing 64 entries each time (512 bytes for a wide walk's
/// `(node, distance)` pairs) cost more than the few entries a shallow walk pushes.
pub(crate) struct TraversalStack<T: Copy, const INLINE: usize = 64> {
    inline: [MaybeUninit<T>; INLINE],
    len: usize,
    spill: Vec<T>,
}

impl<T: Copy, const INLINE: usize> TraversalStack<T, INLINE> {
    #[inline]
    pub(crate) fn new() -> Self {
        Self {
            inline: [const { MaybeUninit::uninit() }; INLINE],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline]
    pub(crate) fn push(&mut self, v: T) {
        if self.len < INLINE {
            self.inline[self.len] = MaybeUninit::new(v);
            self.len += 1;
        } else {
            self.spill.push(v);
        }
    }

    #[inline]
    pub(crate) fn pop(&mut self) -> Option<T> {
        if let Some(v) = self.spill.pop() {
            return Some(v);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: entries below `len` were written by `push` (and `T: Copy`, so reading one
        // leaves it valid).
        Some(unsafe { self.inline[self.len].assume_init() })
    }
}
