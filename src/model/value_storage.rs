//! Where a model keeps its effect values: the third type parameter of [`crate::Robot`].
//!
//! A firmware model holds them inline ([`Inline`]`<V>`: an array of `V` values inside the robot,
//! `V = 0` for a plain geometric model, which then compiles without the effect code). A host
//! that calibrates tables on every joint needs room for many values but uses few: it supplies
//! its own storage (a heap buffer that grows to what the effects use) by implementing
//! [`ValueStorage`] in its crate, and the robot's API stays the same.

use crate::Real;
use core::fmt::Debug;

/// A kind of effect-value store: the most values it holds and its buffer for each scalar type.
pub trait ValueStorage: Clone + Debug + PartialEq {
    /// Most values a model with this storage can hold (the limit of
    /// [`crate::Effects::push`]).
    const CAPACITY: usize;
    /// The buffer of values of one scalar type.
    type Buffer<T: Real>: ValueBuffer<T>;
}

/// The values of one effect list: at least as many slots as the list uses, zero when unused
/// (shared between threads as the robot is).
pub trait ValueBuffer<T>: Clone + Debug + PartialEq + Send + Sync {
    /// A buffer with no value in use.
    fn empty() -> Self;
    /// Every slot the buffer has now (at least the list's used values).
    fn slots(&self) -> &[T];
    /// Every slot the buffer has now, writable.
    fn slots_mut(&mut self) -> &mut [T];
    /// Makes sure the buffer has `len` slots (new ones zero); false when it cannot, and then
    /// nothing changes.
    fn reserve_slots(&mut self, len: usize) -> bool;
    /// The list uses only the first `len` slots again: a buffer that grows may drop the rest.
    fn release_slots(&mut self, len: usize);
}

/// Room for `V` values inside the robot (the firmware's storage; `V = 0`: none).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Inline<const V: usize>;

impl<const V: usize> ValueStorage for Inline<V> {
    const CAPACITY: usize = V;
    type Buffer<T: Real> = [T; V];
}

impl<T: Real, const V: usize> ValueBuffer<T> for [T; V] {
    #[inline(always)]
    fn empty() -> Self {
        [T::zero(); V]
    }
    #[inline(always)]
    fn slots(&self) -> &[T] {
        self
    }
    #[inline(always)]
    fn slots_mut(&mut self) -> &mut [T] {
        self
    }
    #[inline(always)]
    fn reserve_slots(&mut self, len: usize) -> bool {
        len <= V
    }
    #[inline(always)]
    fn release_slots(&mut self, _len: usize) {}
}
