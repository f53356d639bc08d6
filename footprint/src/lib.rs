//! The shared part of the footprint images (`src/bin/*.rs`): a panic handler on bare metal, the
//! inputs an image hides from the optimiser, and a static slot for the feature's state (so its
//! RAM shows in `.bss`).
//!
//! Each image does one feature with the library and nothing else; `footprint/measure.sh`
//! prints their `.text` and static RAM (README.md) and checks the budgets.

#![no_std]

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;

#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo) -> ! {
    // No formatting machinery: a firmware's own handler would log and reset.
    loop {
        core::hint::spin_loop();
    }
}

/// A value the optimiser cannot see through (an input from the firmware's world).
#[inline(always)]
pub fn input<T>(x: T) -> T {
    core::hint::black_box(x)
}

/// Static room for one value of the feature's state: its bytes count in `.bss`.
pub struct Slot<T>(UnsafeCell<MaybeUninit<T>>);

// SAFETY: the images are single-threaded and take the slot once (`Slot::put` is called from
// `main` only, before anything else borrows it).
unsafe impl<T> Sync for Slot<T> {}

impl<T> Slot<T> {
    /// An empty slot.
    pub const fn new() -> Self {
        Self(UnsafeCell::new(MaybeUninit::uninit()))
    }

    /// Stores `value` and lends it for the rest of the program.
    ///
    /// # Safety
    /// Called at most once per slot, with no other borrow of it alive.
    #[allow(clippy::mut_from_ref)]
    pub unsafe fn put(&'static self, value: T) -> &'static mut T {
        // SAFETY: the caller's contract makes this the only borrow of the cell.
        unsafe { (*self.0.get()).write(value) }
    }
}

impl<T> Default for Slot<T> {
    fn default() -> Self {
        Self::new()
    }
}
