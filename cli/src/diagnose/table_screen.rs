//! The screen's shortcut for a correction table.
//!
//! Every column of a table candidate at a block of rows is a scalar times one direction: the
//! block's reading column of the table's joint (`∂p/∂r_j`, weighted as the block is), times
//! the knot's hat function at the reading over its scale. So the products of a candidate's
//! columns with the model's columns, with each other and with the residual are scalar multiples
//! of three per-block figures, `g = Jᵀd`, `dᵀd` and `dᵀr`, which are the same for every table on
//! that joint. [`ReadingProducts`] holds them, computed once per round and joint, with each
//! fold's blocks in the order of their readings.
//!
//! Between two knots `t_k` and `t_k + h` the hat functions are linear in the reading `q`, with
//! weight `w = (q − t_k)/h` for the upper knot. A table's `B = JᵀC` over a fold is therefore made
//! of two running sums over the fold's sorted blocks, `Σ g` and `Σ (q − c) g` (`c` the fold's
//! middle reading): each knot interval costs two differences of them, whatever the number of
//! poses in it (the round's screen compares hundreds of tables on the same joints). That holds
//! for the model's leading columns (the geometry's, which nearly every block excites); an
//! earlier table's knots, two per block, are added block by block, like `D = CᵀC` and
//! `e = Cᵀr`: one multiply-add per block and knot.

use crate::compute::banded::SymmetricBand;
use kinecal::model::effects::Effect;
use nalgebra::{DVector, Vector3};
use std::sync::Arc;

/// A table candidate's columns along its joint's reading direction: block `b`'s columns are
/// the hat functions of `table`'s knots at `blocks.readings[b]`, over the knots' `scales`,
/// times `blocks.directions[b]`.
#[derive(Clone, Debug, PartialEq)]
pub struct AlongReading {
    /// Each block's direction and reading, shared by every table on the joint in a round.
    pub blocks: Arc<ReadingBlocks>,
    /// The table (its grid: `start`, `step`, `len` knots).
    pub table: Effect<f64>,
    /// Each knot's column scale.
    pub scales: Vec<f64>,
}

/// One joint's reading at every block of rows, and the block's direction: the weighted column
/// of the corrected reading (`∂p/∂r_j`), what every table on the joint is a multiple of.
#[derive(Clone, Debug, PartialEq)]
pub struct ReadingBlocks {
    pub directions: Vec<Vector3<f64>>,
    /// The joint's reading (rad), as a table reads it.
    pub readings: Vec<f64>,
}

/// The per-block products of one joint's reading directions with the model's columns and the
/// residuals of a linearised model, per fold in the order of the readings.
#[derive(Debug)]
pub struct ReadingProducts {
    /// The directions and readings the products were formed with.
    blocks: Arc<ReadingBlocks>,
    /// The number of model columns, and of those (from column 0 on) summed per knot interval.
    p: usize,
    dense: usize,
    folds: Vec<FoldReadings>,
}

/// One block of rows: its model columns `(column, ∂p/∂x)` and its residual.
pub type Block<'a> = (&'a [(usize, Vector3<f64>)], &'a Vector3<f64>);

/// One fold's blocks, sorted by their readings.
#[derive(Debug)]
struct FoldReadings {
    /// The readings, ascending.
    q: Vec<f64>,
    /// `dᵀd` and `dᵀr` per block, in the same order.
    dd: Vec<f64>,
    dr: Vec<f64>,
    /// The reference reading `c` of `sum_qg`.
    centre: f64,
    /// `Σ g` and `Σ (q − c) g` of the leading model columns `0..dense` over the first `i`
    /// blocks: entries `i·dense..(i + 1)·dense`.
    sum_g: Vec<f64>,
    sum_qg: Vec<f64>,
    /// Block `i`'s products with its columns from `dense` on (an earlier table's knots, two
    /// per block, and any effect after the geometry): `sparse[offsets[i]..offsets[i + 1]]`,
    /// `(column, g)`.
    offsets: Vec<usize>,
    sparse: Vec<(usize, f64)>,
}

impl ReadingProducts {
    /// The products over `blocks` (each block's model columns and residual), with the
    /// directions and readings of `along`, and the blocks of each fold (`folds`, indices into
    /// `blocks`) sorted by reading; `p` model columns.
    pub fn new<'a>(
        p: usize,
        blocks: &[Block<'a>],
        along: &Arc<ReadingBlocks>,
        folds: impl Iterator<Item = Vec<usize>>,
    ) -> Self {
        let (readings, directions) = (&along.readings, &along.directions);
        // The columns `0..dense`, `dense` the longest run from column 0 of any block (the
        // geometry's, which nearly every block excites): through the running sums, whatever
        // a block has of them; the others, sparse, block by block. The split decides only the
        // speed: every entry goes to one of the two by its index.
        let dense = blocks
            .iter()
            .map(|(columns, _)| {
                let run = columns.iter().enumerate().take_while(|(k, (j, _))| k == j);
                run.count()
            })
            .max()
            .unwrap_or(0)
            .min(p);
        let folds = folds
            .map(|mut members| {
                members.sort_by(|&a, &b| readings[a].total_cmp(&readings[b]));
                let q: Vec<f64> = members.iter().map(|&b| readings[b]).collect();
                let centre = q.get(q.len() / 2).copied().unwrap_or(0.0);
                let n = members.len();
                let mut sum_g = vec![0.0; (n + 1) * dense];
                let mut sum_qg = vec![0.0; (n + 1) * dense];
                let (mut dd, mut dr) = (Vec::with_capacity(n), Vec::with_capacity(n));
                let (mut offsets, mut sparse) = (Vec::with_capacity(n + 1), Vec::new());
                offsets.push(0);
                for (i, &b) in members.iter().enumerate() {
                    let ((columns, r), d) = (blocks[b], &directions[b]);
                    let (last, next) = sum_g.split_at_mut((i + 1) * dense);
                    next[..dense].copy_from_slice(&last[i * dense..]);
                    let (last_q, next_q) = sum_qg.split_at_mut((i + 1) * dense);
                    next_q[..dense].copy_from_slice(&last_q[i * dense..]);
                    let dq = q[i] - centre;
                    for (j, c) in columns {
                        let g = dot3(c, d);
                        if *j < dense {
                            next[*j] += g;
                            next_q[*j] += dq * g;
                        } else {
                            sparse.push((*j, g));
                        }
                    }
                    offsets.push(sparse.len());
                    dd.push(dot3(d, d));
                    dr.push(dot3(d, r));
                }
                FoldReadings {
                    q,
                    dd,
                    dr,
                    centre,
                    sum_g,
                    sum_qg,
                    offsets,
                    sparse,
                }
            })
            .collect();
        Self {
            blocks: Arc::clone(along),
            p,
            dense,
            folds,
        }
    }

    /// Whether these products were formed with `along`'s directions and readings.
    pub fn fits(&self, along: &AlongReading) -> bool {
        Arc::ptr_eq(&self.blocks, &along.blocks) || self.blocks == along.blocks
    }

    /// Fold `f`'s own sums of the table candidate `along`: `bf` is `B = JᵀC` (`p × m`,
    /// column-major, `m` the knots), `df` is `D = CᵀC` (a band) and `ef` is `e = Cᵀr`, all added to.
    // The comparisons are `Effect::segment`'s. The readings are finite (the files' readers
    // refuse others); a NaN reading would give meaningless sums, without a panic.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    pub fn add_fold<'a>(
        &'a self,
        f: usize,
        along: &AlongReading,
        bf: &mut [f64],
        df: &mut SymmetricBand,
        ef: &mut DVector<f64>,
    ) {
        let (fold, p, e, scales) = (&self.folds[f], self.p, &along.table, &along.scales[..]);
        // D, e and B's sparse rows: the two knots around each reading.
        for (i, ((&q, dd), dr)) in fold.q.iter().zip(&fold.dd).zip(&fold.dr).enumerate() {
            let (k, w) = e.segment(q);
            let lower = (1.0 - w) / scales[k];
            let sparse = &fold.sparse[fold.offsets[i]..fold.offsets[i + 1]];
            ef[k] += lower * dr;
            df.add_lower(k, k, lower * lower * dd);
            for (j, g) in sparse {
                bf[k * p + j] += lower * g;
            }
            if w != 0.0 {
                let upper = w / scales[k + 1];
                ef[k + 1] += upper * dr;
                df.add_lower(k + 1, k + 1, upper * upper * dd);
                df.add_lower(k + 1, k, lower * upper * dd);
                for (j, g) in sparse {
                    bf[(k + 1) * p + j] += upper * g;
                }
            }
        }
        // B's leading rows: per knot interval, from the running sums.
        let (n, knots, dense) = (fold.q.len(), e.len as usize, self.dense);
        let row = |sums: &'a [f64], i: usize| &sums[i * dense..(i + 1) * dense];
        let mut add = |k: usize, a: usize, b: usize, offset: Option<f64>| {
            if a == b {
                return;
            }
            let (g0, g1) = (row(&fold.sum_g, a), row(&fold.sum_g, b));
            let Some(offset) = offset else {
                // The whole range on knot k, with weight 1.
                let (column, s) = (&mut bf[k * p..k * p + dense], 1.0 / scales[k]);
                for ((x, lo), hi) in column.iter_mut().zip(g0).zip(g1) {
                    *x += (hi - lo) * s;
                }
                return;
            };
            // Σ w g = (Σ (q − c) g + (c − t_k) Σ g) / h over the interval from knot k.
            let (q0, q1) = (row(&fold.sum_qg, a), row(&fold.sum_qg, b));
            let (lower, upper) = bf[k * p..(k + 2) * p].split_at_mut(p);
            let (lower, upper) = (&mut lower[..dense], &mut upper[..dense]);
            let (sl, su, h) = (1.0 / scales[k], 1.0 / scales[k + 1], 1.0 / e.step);
            let rows = g0.iter().zip(g1).zip(q0.iter().zip(q1));
            for ((l, u), ((g0, g1), (q0, q1))) in lower.iter_mut().zip(upper).zip(rows) {
                let g = g1 - g0;
                let wg = (q1 - q0 + offset * g) * h;
                *l += (g - wg) * sl;
                *u += wg * su;
            }
        };
        if knots < 2 || !(e.step > 0.0) {
            add(0, 0, n, None);
            return;
        }
        let u = |q: f64| (q - e.start) / e.step;
        // Readings at or below the first knot: knot 0 with weight 1 (as `Effect::segment`).
        let mut a = fold.q.partition_point(|&q| !(u(q) > 0.0));
        add(0, 0, a, None);
        for k in 0..knots - 1 {
            let b = a + fold.q[a..].partition_point(|&q| u(q) < (k + 1) as f64);
            add(k, a, b, Some(fold.centre - e.knot(k)));
            a = b;
        }
        // Readings at or beyond the last knot: the last knot with weight 1.
        add(knots - 1, a, n, None);
    }
}

/// `a · b`, written out: the screen's inner loops run it billions of times on large data.
#[inline(always)]
pub(crate) fn dot3(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.x * b.x + a.y * b.y + a.z * b.z
}
