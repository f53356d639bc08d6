//! The handles: opaque, 8-byte aligned byte arrays in the caller's memory that hold a tag and
//! the library value. The tag (a per-type magic number) is written after the value, so a
//! zeroed or never-initialised handle (a C `static` before its `*_init`) is reported as
//! `KC_NOT_INITIALIZED` instead of being read as a value.

use crate::{Kc, KC_MISALIGNED, KC_NOT_INITIALIZED, KC_NULL_POINTER};
use core::mem::MaybeUninit;
use core::ptr;

/// What a handle's bytes hold.
#[repr(C)]
pub(crate) struct Slot<T> {
    /// [`Handle::MAGIC`] once `value` is initialised.
    pub magic: u32,
    /// The library value.
    pub value: T,
}

/// A C handle type and the value it holds.
pub(crate) trait Handle: Sized {
    /// The library value.
    type Inner;
    /// The tag of an initialised handle of this type: a byte repeated four times (a letter
    /// of the type), which Thumb-2 compares in one instruction (an immediate operand).
    const MAGIC: u32;
}

/// Implements [`Handle`] and asserts at compile time (for the target being built: the CI builds
/// the 64-bit host and `thumbv7em-none-eabihf`) that the value fits the handle's bytes and
/// needs no more than its 8-byte alignment.
macro_rules! handle {
    ($name:ident, $size:ident, $inner:ty, $magic:literal) => {
        impl crate::handle::Handle for $name {
            type Inner = $inner;
            const MAGIC: u32 = $magic;
        }
        const _: () = assert!(
            core::mem::size_of::<crate::handle::Slot<$inner>>() <= $size
                && core::mem::align_of::<crate::handle::Slot<$inner>>() <= 8
                && core::mem::size_of::<$name>() == $size
                && core::mem::align_of::<$name>() == 8
        );
    };
}
pub(crate) use handle;

/// The slot behind a handle pointer, checked for NULL and alignment.
#[inline(always)]
fn slot<H: Handle>(h: *const H) -> Kc<*const Slot<H::Inner>> {
    if h.is_null() {
        return Err(KC_NULL_POINTER);
    }
    if (h as usize) % 8 != 0 {
        return Err(KC_MISALIGNED);
    }
    Ok(h.cast())
}

/// The value of an initialised handle.
///
/// # Safety
/// `h` is NULL or points to a readable `H` (its declared size and alignment) that nothing
/// writes during the returned borrow.
#[inline(always)]
pub(crate) unsafe fn get<'a, H: Handle>(h: *const H) -> Kc<&'a H::Inner> {
    let s = slot(h)?;
    // SAFETY: `s` is non-NULL and aligned and the handle's bytes hold a `Slot` (its size is
    // asserted to fit); the tag is read as a plain u32 without forming a reference to the value.
    let magic = unsafe { ptr::addr_of!((*s).magic).read() };
    if magic != H::MAGIC {
        return Err(KC_NOT_INITIALIZED);
    }
    // SAFETY: the tag is written only after a valid value (see `init`); the caller's
    // contract keeps the bytes unchanged for the borrow.
    Ok(unsafe { &*ptr::addr_of!((*s).value) })
}

/// The value of an initialised handle, writable.
///
/// # Safety
/// `h` is NULL or points to a writable `H` that nothing else references during the borrow.
#[inline(always)]
pub(crate) unsafe fn get_mut<'a, H: Handle>(h: *mut H) -> Kc<&'a mut H::Inner> {
    let s = slot(h)?.cast_mut();
    // SAFETY: as in `get`.
    let magic = unsafe { ptr::addr_of!((*s).magic).read() };
    if magic != H::MAGIC {
        return Err(KC_NOT_INITIALIZED);
    }
    // SAFETY: as in `get`, and the caller's contract makes the borrow unique.
    Ok(unsafe { &mut *ptr::addr_of_mut!((*s).value) })
}

/// The handle's bytes as an uninitialised slot to construct a value in.
///
/// # Safety
/// `h` is NULL or points to a writable `H` that nothing else references during the borrow.
#[inline(always)]
pub(crate) unsafe fn uninit<'a, H: Handle>(h: *mut H) -> Kc<&'a mut MaybeUninit<Slot<H::Inner>>> {
    let s = slot(h)?.cast_mut();
    // SAFETY: non-NULL, aligned, the size fits (asserted); `MaybeUninit` makes no claim about
    // the bytes, and the caller's contract makes the borrow unique.
    Ok(unsafe { &mut *s.cast::<MaybeUninit<Slot<H::Inner>>>() })
}

/// Writes `value` into the handle and tags it initialised: the library value is built by the
/// caller's expression straight into the handle when LLVM can (no stack copy: the slot is a
/// unique `&mut`, so the call's return slot may be the handle itself).
#[inline(always)]
pub(crate) fn init<H: Handle>(
    slot: &mut MaybeUninit<Slot<H::Inner>>,
    value: H::Inner,
) -> &mut H::Inner {
    let s = slot.write(Slot { magic: 0, value });
    s.magic = H::MAGIC;
    &mut s.value
}

/// Marks a handle not initialised (after a constructor failed half-way).
#[inline(always)]
#[allow(dead_code)]
pub(crate) fn forget<H: Handle>(slot: &mut MaybeUninit<Slot<H::Inner>>) {
    // SAFETY-free: writes only the tag field through a raw pointer into memory we own.
    let p = slot.as_mut_ptr();
    // SAFETY: `p` points to the slot (valid for writes of its size); writing the u32 tag
    // needs no initialised value.
    unsafe { ptr::addr_of_mut!((*p).magic).write(0) };
}
