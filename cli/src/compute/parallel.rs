//! Both cores for the passes over many poses: the library's Levenberg–Marquardt passes
//! ([`kinecal::identify::lm`]) and per-pose evaluations, spread over scoped threads.
//!
//! Large data are always cut into the same [`PARTS`] contiguous parts, whatever the number of
//! threads, and the parts are summed in order: a result does not depend on the machine's core
//! count. Below [`PARALLEL_MIN_POSES`] everything runs on the calling thread in one piece
//! (starting threads would cost more than it saves), exactly as the library's own `step` does.

use crate::compute::vec_lm::VecLm;
use kinecal::identify::lm::{Levenberg, LmError, LmPenalty, LmProgress, PassPart};
use kinecal::{ForwardKinematics, Measurement};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// The number of parts a pass is cut into (and the most threads used).
pub const PARTS: usize = 8;
/// Fewer poses than this run on one thread.
pub const PARALLEL_MIN_POSES: usize = 4096;

/// Threads to use: the cores the process may run on, at most [`PARTS`].
pub fn workers() -> usize {
    std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .clamp(1, PARTS)
}

/// `f` of every item, in the order of `items`, computed on up to [`workers`] threads: the
/// calling one and scoped helpers with the default stack. Items are handed out one at a time
/// from a shared counter (their costs may differ a lot: a 200-knot table against a scale
/// factor, a fit that converges in two steps against one that takes twenty) and every result
/// is stored at its item's index, so the output does not depend on the scheduling.
pub fn map_each<I: Sync, R: Send>(items: &[I], f: impl Fn(&I) -> R + Sync) -> Vec<R> {
    let threads = workers().min(items.len());
    if threads < 2 {
        return items.iter().map(f).collect();
    }
    let next = AtomicUsize::new(0);
    let work = || {
        let mut done = Vec::new();
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            let Some(item) = items.get(i) else {
                return done;
            };
            done.push((i, f(item)));
        }
    };
    let mut out: Vec<Option<R>> = std::iter::repeat_with(|| None).take(items.len()).collect();
    std::thread::scope(|s| {
        let helpers: Vec<_> = (1..threads).map(|_| s.spawn(work)).collect();
        let mut parts = vec![work()];
        for h in helpers {
            parts.push(h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)));
        }
        for (i, r) in parts.into_iter().flatten() {
            out[i] = Some(r);
        }
    });
    // Every index below items.len() was handed out exactly once.
    out.into_iter().flatten().collect()
}

/// [`map_each`] over items the jobs change (each item is locked by the one job that takes
/// it: never contended).
pub fn map_each_mut<I: Send, R: Send>(items: &mut [I], f: impl Fn(&mut I) -> R + Sync) -> Vec<R> {
    let cells: Vec<Mutex<&mut I>> = items.iter_mut().map(Mutex::new).collect();
    map_each(&cells, |c| {
        let mut item = c.lock().unwrap_or_else(|e| e.into_inner());
        f(&mut item)
    })
}

/// [`map_each`] with the items taken largest first (by `size`), the results in the items'
/// order: the longest jobs start first, so that no core is left alone with one of them at the
/// end.
pub fn map_each_largest_first<I: Sync, R: Send>(
    items: &[I],
    size: impl Fn(&I) -> usize,
    f: impl Fn(&I) -> R + Sync,
) -> Vec<R> {
    let order = largest_first(items, size);
    let results = map_each(&order, |&i| f(&items[i]));
    let mut out: Vec<Option<R>> = (0..items.len()).map(|_| None).collect();
    for (i, r) in order.into_iter().zip(results) {
        out[i] = Some(r);
    }
    out.into_iter().flatten().collect()
}

/// The indices of `items` by decreasing `size`, equal sizes in the items' order: the order
/// [`map_each_largest_first`] hands them out in.
pub fn largest_first<I>(items: &[I], size: impl Fn(&I) -> usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by_key(|&i| std::cmp::Reverse(size(&items[i])));
    order
}

/// `f` of each of the [`PARTS`] contiguous parts of `items` on [`workers`] threads, results in
/// order; `f` of all of them at once below [`PARALLEL_MIN_POSES`] items.
pub fn map_parts<I: Sync, R: Send>(items: &[I], f: impl Fn(&[I]) -> R + Sync) -> Vec<R> {
    if items.len() < PARALLEL_MIN_POSES {
        return vec![f(items)];
    }
    let chunks: Vec<&[I]> = items.chunks(items.len().div_ceil(PARTS)).collect();
    map_each(&chunks, |c| f(c))
}

/// Memory for the parts' normal matrices of one pass: fewer parts for large models (each part
/// holds a `P × P` matrix).
pub const PART_MATRIX_BYTES: usize = 32 << 20;

/// Parts a pass over a model with `params` parameters is cut into: [`PARTS`], fewer (at least
/// 2) when their matrices would exceed [`PART_MATRIX_BYTES`]. It depends on the problem only,
/// never on the machine.
pub fn pass_parts(params: usize) -> usize {
    let matrix = (8 * params * params).max(1);
    (PART_MATRIX_BYTES / matrix).clamp(2, PARTS)
}

/// True when [`run_lm`]'s passes over `poses` poses sum them in the same parts for a model
/// of `a` parameters as for one of `b`: both on the calling thread, or both cut alike.
pub fn same_parts(a: usize, b: usize, poses: usize) -> bool {
    poses < PARALLEL_MIN_POSES || pass_parts(a) == pass_parts(b)
}

/// Runs `lm` (with or without a penalty) over `data` to the end, its passes over the poses on
/// [`workers`] threads when there are many poses; `on_progress` sees the progress after every
/// call into the solver.
pub fn run_lm<const N: usize, V: kinecal::ValueStorage, Q: LmPenalty<f64>>(
    lm: &mut Levenberg<f64, N, V, VecLm<f64>, Q>,
    data: &[Measurement<f64, N>],
    mut on_progress: impl FnMut(&Levenberg<f64, N, V, VecLm<f64>, Q>, &LmProgress<f64>),
) -> Result<LmProgress<f64>, LmError> {
    // In parts whenever the data are large, even on one core: the sums then do not depend on
    // the machine.
    let parallel = data.len() >= PARALLEL_MIN_POSES;
    let chunks: Vec<&[Measurement<f64, N>]> = if parallel {
        data.chunks(data.len().div_ceil(pass_parts(lm.params().len())))
            .collect()
    } else {
        Vec::new()
    };
    let mut parts: Vec<PassPart<f64, VecLm<f64>>> = chunks
        .iter()
        .map(|_| PassPart::new(VecLm::for_pass(lm.params())))
        .collect();
    loop {
        let progress = match lm.pass().filter(|_| parallel) {
            Some(pass) => {
                let mut jobs: Vec<_> = parts.iter_mut().zip(&chunks).collect();
                map_each_mut(&mut jobs, |(part, poses)| {
                    pass.accumulate(&mut ForwardKinematics::new(), poses, part)
                })
                .into_iter()
                .collect::<Result<(), LmError>>()?;
                lm.complete_pass(&parts)?
            }
            // A solve, or the whole run on this thread.
            None => lm.step(data, if parallel { 1 } else { usize::MAX })?,
        };
        on_progress(lm, &progress);
        if progress.stopped.is_some() {
            return Ok(progress);
        }
    }
}
