//! Snapshots of a solver's complete state: their size, saving and restoring.

use super::solver::{each_lm, Lm, Solver, Solvers};
use crate::handle;
use crate::KC_SNAPSHOT_INVALID;
use crate::{obj_mut, slice_mut, slice_ref, Kc, KC_BUFFER_TOO_SMALL, KC_NOT_INITIALIZED};
use kinecal::io::snapshot::{Snapshot, SnapshotError};

struct Count(usize);

impl embedded_io::ErrorType for Count {
    type Error = core::convert::Infallible;
}

impl embedded_io::Write for Count {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.0 = self.0.saturating_add(buf.len());
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

fn snapshot_size<const N: usize, const P: usize>(lm: &Lm<N, P>) -> Kc<usize> {
    let mut c = Count(0);
    lm.save(&mut c).map_err(|_| KC_SNAPSHOT_INVALID)?;
    Ok(c.0)
}

pub(super) unsafe fn lm_snapshot_size<H: Solver<P>, const P: usize>(
    lm: *const H,
    size: *mut usize,
) -> Kc<()> {
    // SAFETY: the header contract.
    let lm = unsafe { handle::get(lm) }?;
    // SAFETY: the header contract.
    let size = unsafe { obj_mut(size) }?;
    *size = each_lm!(lm, s => snapshot_size(s))?;
    Ok(())
}

fn save<const N: usize, const P: usize>(
    lm: &Lm<N, P>,
    buf: &mut [u8],
    written: &mut usize,
) -> Kc<()> {
    let cap = buf.len();
    let mut w: &mut [u8] = buf;
    match lm.save(&mut w) {
        Ok(()) => {
            *written = cap - w.len();
            Ok(())
        }
        Err(SnapshotError::Io) => {
            *written = snapshot_size(lm)?;
            Err(KC_BUFFER_TOO_SMALL)
        }
        Err(_) => Err(KC_SNAPSHOT_INVALID),
    }
}

pub(super) unsafe fn lm_save<H: Solver<P>, const P: usize>(
    lm: *const H,
    buf: *mut u8,
    cap: usize,
    written: *mut usize,
) -> Kc<()> {
    // SAFETY: the header contract.
    let lm = unsafe { handle::get(lm) }?;
    // SAFETY: the header contract.
    let written = unsafe { obj_mut(written) }?;
    // SAFETY: the header contract (`cap` bytes).
    let buf: &mut [u8] = unsafe { slice_mut(buf, cap) }?;
    each_lm!(lm, s => save(s, buf, written))
}

pub(super) unsafe fn lm_restore<H: Solver<P>, const P: usize>(
    lm: *mut H,
    buf: *const u8,
    len: usize,
) -> Kc<()> {
    // SAFETY: the header contract.
    let lm = unsafe { handle::get_mut(lm) }?;
    // SAFETY: the header contract (`len` bytes).
    let r: &[u8] = unsafe { slice_ref(buf, len) }?;
    each_lm!(lm, s => restore(s, r).map_err(|_| KC_SNAPSHOT_INVALID))
}

#[inline(never)]
fn restore<const N: usize, const P: usize>(
    lm: &mut Lm<N, P>,
    mut r: &[u8],
) -> Result<(), SnapshotError> {
    lm.restore(&mut r)
}
