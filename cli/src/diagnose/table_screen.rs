//! The screen's shortcut for a correction table.
//!
//! Every column of a table candidate at a block of rows is a scalar times one direction: the
//! block's reading column of the table's joint (`∂p/∂r_j`, weighted as the block is), times
//! the knot's hat function at the reading over its scale. So the products of a candidate's
//! columns with the model's columns, with each other and with the residual are scalar multiples
//! of three per-block figures, `Jᵀd`, `dᵀd` and `dᵀr`, which are the same for every table on
//! that joint. [`ReadingProducts`] holds them, computed once per round and joint; a table
//! candidate's normal sums then cost a multiply-add per model column and knot instead of a
//! three-vector product (the round's screen compares hundreds of tables on the same joints).

use nalgebra::{DMatrix, DVector, Vector3};

/// A table candidate's columns along its joint's reading direction: block `b`'s columns are
/// `scalars[k] · directions[b]`, `k` over the block's entries.
#[derive(Clone, Debug, PartialEq)]
pub struct AlongReading {
    /// The table's joint (0-based).
    pub joint: usize,
    /// Each block's direction (the weighted reading column).
    pub directions: Vec<Vector3<f64>>,
    /// One scalar per column entry, in the order of the entries.
    pub scalars: Vec<f64>,
}

/// The per-block products of one joint's reading directions with the model's columns and the
/// residuals of a linearised model.
#[derive(Debug)]
pub struct ReadingProducts {
    /// The directions the products were formed with.
    directions: Vec<Vector3<f64>>,
    /// Block `b`'s products `d_bᵀ ∂p/∂x` with its model columns, in their order, are
    /// `value[offsets[b]..offsets[b + 1]]` (the columns' indices are the model's own, not
    /// copied); the first `dense[b]` columns are `0, 1, …` (the geometry's, which nearly every
    /// pose excites), added as one run.
    offsets: Vec<usize>,
    value: Vec<f64>,
    dense: Vec<usize>,
    /// `d_bᵀ d_b` and `d_bᵀ r_b` per block.
    dd: Vec<f64>,
    dr: Vec<f64>,
}

impl ReadingProducts {
    /// The products over `blocks`: each block's model columns, residual and direction.
    pub fn new<'a>(
        blocks: impl ExactSizeIterator<
            Item = (
                &'a [(usize, Vector3<f64>)],
                &'a Vector3<f64>,
                &'a Vector3<f64>,
            ),
        >,
    ) -> Self {
        let n = blocks.len();
        let mut out = Self {
            directions: Vec::with_capacity(n),
            offsets: Vec::with_capacity(n + 1),
            value: Vec::new(),
            dense: Vec::with_capacity(n),
            dd: Vec::with_capacity(n),
            dr: Vec::with_capacity(n),
        };
        out.offsets.push(0);
        for (columns, r, d) in blocks {
            out.value.extend(columns.iter().map(|(_, c)| dot3(c, d)));
            let dense = columns.iter().enumerate().take_while(|(k, (j, _))| k == j);
            out.dense.push(dense.count());
            out.offsets.push(out.value.len());
            out.directions.push(*d);
            out.dd.push(dot3(d, d));
            out.dr.push(dot3(d, r));
        }
        out
    }

    /// Whether these products were formed with `directions`.
    pub fn fits(&self, directions: &[Vector3<f64>]) -> bool {
        self.directions == directions
    }

    /// Adds block `b`'s share of a table candidate to a fold's own sums: `bf` is `B = JᵀC`
    /// (`p × m`, column-major), `df` is `D = CᵀC` and `ef` is `e = Cᵀr`; `model` are the
    /// model's columns at the block (those the products were formed with), `columns` the
    /// candidate's entries at the block and `scalars` their scalars.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn add_block(
        &self,
        b: usize,
        model: &[(usize, Vector3<f64>)],
        columns: &[(usize, Vector3<f64>)],
        scalars: &[f64],
        p: usize,
        bf: &mut [f64],
        df: &mut DMatrix<f64>,
        ef: &mut DVector<f64>,
    ) {
        let (dd, dr) = (self.dd[b], self.dr[b]);
        for (x, ((ci, _), sx)) in columns.iter().zip(scalars).enumerate() {
            ef[*ci] += sx * dr;
            for ((cj, _), sy) in columns[..=x].iter().zip(scalars) {
                let v = sx * sy * dd;
                df[(*ci, *cj)] += v;
                if ci != cj {
                    df[(*cj, *ci)] += v;
                }
            }
        }
        let (start, end) = (self.offsets[b], self.offsets[b + 1]);
        let dense = self.dense[b];
        let (run, sparse, value) = (
            &self.value[start..start + dense],
            &model[dense..],
            &self.value[start + dense..end],
        );
        for ((c, _), s) in columns.iter().zip(scalars) {
            let bc = &mut bf[c * p..(c + 1) * p];
            for (x, g) in bc[..dense].iter_mut().zip(run) {
                *x += s * g;
            }
            for ((gj, _), g) in sparse.iter().zip(value) {
                bc[*gj] += s * g;
            }
        }
    }
}

/// `a · b`, written out: the screen's inner loops run it billions of times on large data.
#[inline(always)]
pub(crate) fn dot3(a: &Vector3<f64>, b: &Vector3<f64>) -> f64 {
    a.x * b.x + a.y * b.y + a.z * b.z
}
