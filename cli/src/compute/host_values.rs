//! The host's effect-value storage: the library's [`ValueStorage`] on the heap.
//!
//! A firmware model keeps its values inline ([`kinecal::Inline`]); a host model may carry a
//! table on every joint (up to [`VCAP`] values) but most carry none or a few. Its values live in
//! a buffer that grows to what its effects use, so a robot is small, cheap to clone and to keep
//! on any thread's stack, and the robot's API is the library's own.

use crate::VCAP;
use kinecal::{Real, ValueBuffer, ValueStorage};

/// Effect values on the heap, at most [`VCAP`] of them: the storage of [`crate::HostRobot`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HostValues;

impl ValueStorage for HostValues {
    const CAPACITY: usize = VCAP;
    type Buffer<T: Real> = HeapValues<T>;
}

/// The values of one host model: exactly the slots its effects use.
#[derive(Clone, Debug, PartialEq)]
pub struct HeapValues<T>(Vec<T>);

impl<T: Real> ValueBuffer<T> for HeapValues<T> {
    fn empty() -> Self {
        HeapValues(Vec::new())
    }
    fn slots(&self) -> &[T] {
        &self.0
    }
    fn slots_mut(&mut self) -> &mut [T] {
        &mut self.0
    }
    fn reserve_slots(&mut self, len: usize) -> bool {
        if len > VCAP {
            return false;
        }
        if len > self.0.len() {
            self.0.resize(len, T::zero());
        }
        true
    }
    fn release_slots(&mut self, len: usize) {
        self.0.truncate(len);
    }
}
