//! A fixed-size three-layer back-propagation network (the BPNN of the BPNN-PSO paper, §3.2.1).
//!
//! `INPUTS` inputs → `HIDDEN` hidden neurons (tanh or sigmoid) → `OUTPUTS` linear outputs. Inputs
//! and outputs are mapped to [−1, 1] by per-component ranges stored in the net
//! ([`Bpnn::fit_ranges`]), so millimetres and radians train alike and a trained net is
//! self-contained.
//!
//! Training is plain back-propagation of the squared error with momentum,
//! `Δw ← μ·Δw − η·∇E`, over mini-batches of `batch` samples (1 = per-sample updates). The sample
//! order of each epoch is a permutation drawn from the net's own generator, so training is
//! deterministic for a seed. Weights start Glorot-uniform, biases at zero. Nothing allocates:
//! the weights, their momentum and the batch gradient are three copies of one fixed block.
//!
//! **Hidden size.** The paper's empirical rule is `h = √(m + n) + a` with `a` between 1 and 10;
//! [`hidden_size`] rounds the root and adds `a`. We take `a = 5` ([`DEFAULT_A`], the middle of the
//! range): 24 parameters in and out give `h = 7 + 5 = 12`.

use crate::io::snapshot::{
    restore_with, save_with, Decoder, Encoder, Kind, Snapshot, SnapshotError,
};
use crate::Real;
use embedded_io::{Read, Write};
use rand_core::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// The `a` of the hidden-size rule used by default.
pub const DEFAULT_A: usize = 5;

/// The paper's hidden-layer size `round(√(inputs + outputs)) + a` (usable in const generics:
/// `Bpnn<f32, 24, { hidden_size(24, 24, DEFAULT_A) }, 24>`).
pub const fn hidden_size(inputs: usize, outputs: usize, a: usize) -> usize {
    let n = inputs + outputs;
    // Integer square root, then round: n > r² + r  ⇔  √n > r + ½.
    let mut r = 0usize;
    while (r + 1) * (r + 1) <= n {
        r += 1;
    }
    if n > r * r + r {
        r += 1;
    }
    r + a
}

/// Largest learning rate a configuration accepts: steps of normalised size far beyond 1 only
/// diverge, and a rate near `f64::MAX` overflows the first update to ∞ − ∞ = NaN.
pub const MAX_LEARNING_RATE: f64 = 1e6;

/// Largest magnitude of a weight or bias. The net works in normalised units (inputs and
/// targets in [−1, 1]), where a trained net's weights are of order 1; an epoch that drives one
/// beyond this bound (or a momentum beyond twice it) has diverged and is undone
/// ([`BpnnError::Diverged`]). With inputs clamped ([`MAX_INPUT_SCALE`]) and ranges within
/// [`MAX_RANGE`], the bound keeps every output finite, in `f32` as in `f64`.
pub const MAX_WEIGHT: f64 = 1e4;

/// Largest magnitude of a range bound ([`Bpnn::set_ranges`]): readings in mm or radians are
/// far below it; beyond it the denormalised output could overflow.
pub const MAX_RANGE: f64 = 1e12;

/// An input far outside its training range is clamped to this many half-ranges from the
/// range's middle (the net extrapolates no further), so no input overflows the first layer.
pub const MAX_INPUT_SCALE: f64 = 1e6;

/// Hidden-layer activation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Activation {
    /// `tanh` (zero-centred; the default).
    Tanh,
    /// The logistic function `1 / (1 + e^−x)`.
    Sigmoid,
}

/// Training settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BpnnConfig<T: Real> {
    /// Step size `η` on the mean gradient of a batch.
    pub learning_rate: T,
    /// Momentum `μ` in [0, 1).
    pub momentum: T,
    /// Samples per update (≥ 1).
    pub batch: u32,
    /// Activation function of the hidden layer.
    pub activation: Activation,
}

impl<T: Real> Default for BpnnConfig<T> {
    /// `η = 0.01`, `μ = 0.9`, per-sample updates, tanh.
    fn default() -> Self {
        Self {
            learning_rate: T::of(0.01),
            momentum: T::of(0.9),
            batch: 1,
            activation: Activation::Tanh,
        }
    }
}

/// Why a network call was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BpnnError {
    /// `INPUTS`, `HIDDEN` or `OUTPUTS` is zero.
    Empty,
    /// Learning rate not in (0, [`MAX_LEARNING_RATE`]], momentum outside [0, 1), or batch zero.
    Config,
    /// No samples, or inputs and targets differ in count.
    Shape,
    /// A sample or range holds NaN or infinity, a range has `lo > hi`, or a bound lies beyond
    /// ±[`MAX_RANGE`].
    NonFinite,
    /// A weight left ±[`MAX_WEIGHT`] (or became non-finite) during the epoch (learning rate
    /// too large); the net was put back as it was before the epoch.
    Diverged,
}

/// The trainable parameters of a net (also the shape of its momentum and gradient).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Weights<T: Real, const INPUTS: usize, const HIDDEN: usize, const OUTPUTS: usize> {
    w1: [[T; INPUTS]; HIDDEN],
    b1: [T; HIDDEN],
    w2: [[T; HIDDEN]; OUTPUTS],
    b2: [T; OUTPUTS],
}

impl<T: Real, const INPUTS: usize, const HIDDEN: usize, const OUTPUTS: usize>
    Weights<T, INPUTS, HIDDEN, OUTPUTS>
{
    fn zero() -> Self {
        Self {
            w1: [[T::zero(); INPUTS]; HIDDEN],
            b1: [T::zero(); HIDDEN],
            w2: [[T::zero(); HIDDEN]; OUTPUTS],
            b2: [T::zero(); OUTPUTS],
        }
    }
    /// Every weight and bias finite and within ±`limit` (NaN fails).
    fn bounded(&self, limit: f64) -> bool {
        let ok = |v: &T| v.abs() <= T::of(limit);
        self.w1.iter().all(|r| r.iter().all(ok))
            && self.b1.iter().all(ok)
            && self.w2.iter().all(|r| r.iter().all(ok))
            && self.b2.iter().all(ok)
    }
    fn encode<W: Write>(&self, e: &mut Encoder<'_, W>) -> Result<(), SnapshotError> {
        e.real_rows(&self.w1)?;
        e.reals(&self.b1)?;
        e.real_rows(&self.w2)?;
        e.reals(&self.b2)
    }
    fn decode<R: Read>(&mut self, d: &mut Decoder<'_, R>) -> Result<(), SnapshotError> {
        d.real_rows(&mut self.w1)?;
        d.reals(&mut self.b1)?;
        d.real_rows(&mut self.w2)?;
        d.reals(&mut self.b2)
    }
}

/// Per-component affine map to [−1, 1]: `n = (x − mid) / half`.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Range<T: Real, const K: usize> {
    mid: [T; K],
    half: [T; K],
}

impl<T: Real, const K: usize> Range<T, K> {
    fn unit() -> Self {
        Self {
            mid: [T::zero(); K],
            half: [T::one(); K],
        }
    }
    /// From `lo ≤ hi`; a component with `lo == hi` gets `half = 1`, so it maps to 0 without
    /// dividing by zero.
    fn from_bounds(lo: &[T; K], hi: &[T; K]) -> Result<Self, BpnnError> {
        let mut r = Self::unit();
        for k in 0..K {
            let span = hi[k] - lo[k];
            // A finite span implies finite bounds; NaN fails.
            let inside = lo[k].abs() <= T::of(MAX_RANGE) && hi[k].abs() <= T::of(MAX_RANGE);
            if !(inside && span.finite() && lo[k] <= hi[k]) {
                return Err(BpnnError::NonFinite);
            }
            let half = span * T::of(0.5);
            r.mid[k] = lo[k] + half;
            r.half[k] = if half > T::zero() { half } else { T::one() };
        }
        Ok(r)
    }
    fn normalise(&self, x: &[T; K]) -> [T; K] {
        let mut n = [T::zero(); K];
        for k in 0..K {
            let m = T::of(MAX_INPUT_SCALE);
            n[k] = ((x[k] - self.mid[k]) / self.half[k]).max(-m).min(m);
        }
        n
    }
    fn valid(&self) -> bool {
        let r = T::of(MAX_RANGE);
        self.mid.iter().all(|v| v.abs() <= r) && self.half.iter().all(|v| *v > T::zero() && *v <= r)
    }
}

/// A three-layer network with `INPUTS` inputs, `HIDDEN` hidden neurons and `OUTPUTS` outputs.
#[derive(Clone, Debug)]
pub struct Bpnn<T: Real, const INPUTS: usize, const HIDDEN: usize, const OUTPUTS: usize> {
    cfg: BpnnConfig<T>,
    weights: Weights<T, INPUTS, HIDDEN, OUTPUTS>,
    momentum: Weights<T, INPUTS, HIDDEN, OUTPUTS>,
    /// Batch gradient scratch (zero between calls).
    grad: Weights<T, INPUTS, HIDDEN, OUTPUTS>,
    input: Range<T, INPUTS>,
    output: Range<T, OUTPUTS>,
    rng: Xoshiro256PlusPlus,
    epochs: u32,
}

impl<T: Real, const INPUTS: usize, const HIDDEN: usize, const OUTPUTS: usize>
    Bpnn<T, INPUTS, HIDDEN, OUTPUTS>
{
    /// A fresh net with Glorot-uniform weights drawn from `seed` and unit ranges.
    pub fn new(cfg: BpnnConfig<T>, seed: u64) -> Result<Self, BpnnError> {
        if INPUTS == 0 || HIDDEN == 0 || OUTPUTS == 0 {
            return Err(BpnnError::Empty);
        }
        check_config(&cfg)?;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut w = Weights::zero();
        let l1 = T::of(libm::sqrt(6.0 / (INPUTS + HIDDEN) as f64));
        let l2 = T::of(libm::sqrt(6.0 / (HIDDEN + OUTPUTS) as f64));
        for row in w.w1.iter_mut() {
            for v in row.iter_mut() {
                *v = symmetric::<T>(&mut rng) * l1;
            }
        }
        for row in w.w2.iter_mut() {
            for v in row.iter_mut() {
                *v = symmetric::<T>(&mut rng) * l2;
            }
        }
        Ok(Self {
            cfg,
            weights: w,
            momentum: Weights::zero(),
            grad: Weights::zero(),
            input: Range::unit(),
            output: Range::unit(),
            rng,
            epochs: 0,
        })
    }

    /// The training settings in use.
    pub fn config(&self) -> &BpnnConfig<T> {
        &self.cfg
    }
    /// Changes the training settings (e.g. a smaller step for fine tuning).
    pub fn set_config(&mut self, cfg: BpnnConfig<T>) -> Result<(), BpnnError> {
        check_config(&cfg)?;
        self.cfg = cfg;
        Ok(())
    }
    /// Epochs trained so far.
    pub fn epochs(&self) -> u32 {
        self.epochs
    }

    /// Sets the ranges mapped to [−1, 1]: inputs `[in_lo, in_hi]`, outputs `[out_lo, out_hi]`.
    pub fn set_ranges(
        &mut self,
        in_lo: &[T; INPUTS],
        in_hi: &[T; INPUTS],
        out_lo: &[T; OUTPUTS],
        out_hi: &[T; OUTPUTS],
    ) -> Result<(), BpnnError> {
        let input = Range::from_bounds(in_lo, in_hi)?;
        let output = Range::from_bounds(out_lo, out_hi)?;
        self.input = input;
        self.output = output;
        Ok(())
    }

    /// Sets the ranges to the per-component minimum and maximum of the training data.
    pub fn fit_ranges(
        &mut self,
        inputs: &[[T; INPUTS]],
        targets: &[[T; OUTPUTS]],
    ) -> Result<(), BpnnError> {
        check_data(inputs, targets)?;
        let (ilo, ihi) = min_max(inputs);
        let (olo, ohi) = min_max(targets);
        self.set_ranges(&ilo, &ihi, &olo, &ohi)
    }

    /// The network's output for `x` (in the units of the training targets).
    pub fn forward(&self, x: &[T; INPUTS]) -> [T; OUTPUTS] {
        let xn = self.input.normalise(x);
        let mut h = [T::zero(); HIDDEN];
        let yn = self.pass(&xn, &mut h);
        let mut y = [T::zero(); OUTPUTS];
        for k in 0..OUTPUTS {
            y[k] = yn[k] * self.output.half[k] + self.output.mid[k];
        }
        y
    }

    /// Mean squared error per output component, in normalised output units (so 1 is the
    /// size of the target range), over a data set.
    pub fn loss(&self, inputs: &[[T; INPUTS]], targets: &[[T; OUTPUTS]]) -> Result<T, BpnnError> {
        check_data(inputs, targets)?;
        let mut h = [T::zero(); HIDDEN];
        let mut s = T::zero();
        for (x, t) in inputs.iter().zip(targets) {
            let y = self.pass(&self.input.normalise(x), &mut h);
            let tn = self.output.normalise(t);
            for k in 0..OUTPUTS {
                let e = y[k] - tn[k];
                s += e * e;
            }
        }
        Ok(s / T::of((inputs.len() * OUTPUTS) as f64))
    }

    /// One pass of back-propagation over the data in a random order; returns the mean squared
    /// error (as [`Bpnn::loss`]) seen during the pass, each sample measured before its update.
    /// If the weights diverge the net is restored to its state before the call.
    pub fn train_epoch(
        &mut self,
        inputs: &[[T; INPUTS]],
        targets: &[[T; OUTPUTS]],
    ) -> Result<T, BpnnError> {
        check_data(inputs, targets)?;
        let saved = (self.weights, self.momentum, self.rng.clone());
        let n = inputs.len();
        let (start, stride) = permutation(&mut self.rng, n);
        let batch = self.cfg.batch as usize;
        let mut in_batch = 0usize;
        let mut sum = T::zero();
        let mut h = [T::zero(); HIDDEN];
        self.grad = Weights::zero();
        for k in 0..n {
            let idx = ((start as u64 + k as u64 * stride as u64) % n as u64) as usize;
            let (Some(x), Some(t)) = (inputs.get(idx), targets.get(idx)) else {
                continue;
            };
            let xn = self.input.normalise(x);
            let tn = self.output.normalise(t);
            sum += self.accumulate(&xn, &tn, &mut h);
            in_batch += 1;
            if in_batch == batch || k + 1 == n {
                self.apply(in_batch);
                in_batch = 0;
            }
        }
        if !self.weights_bounded() || !sum.finite() {
            self.weights = saved.0;
            self.momentum = saved.1;
            self.rng = saved.2;
            self.grad = Weights::zero();
            return Err(BpnnError::Diverged);
        }
        self.epochs = self.epochs.saturating_add(1);
        Ok(sum / T::of((n * OUTPUTS) as f64))
    }

    /// Weights within ±[`MAX_WEIGHT`] and momentum within twice that: what a trained or
    /// restored net must satisfy.
    fn weights_bounded(&self) -> bool {
        self.weights.bounded(MAX_WEIGHT) && self.momentum.bounded(2.0 * MAX_WEIGHT)
    }

    /// Hidden activations into `h`, normalised output returned.
    fn pass(&self, xn: &[T; INPUTS], h: &mut [T; HIDDEN]) -> [T; OUTPUTS] {
        let w = &self.weights;
        for j in 0..HIDDEN {
            let mut z = w.b1[j];
            for i in 0..INPUTS {
                z += w.w1[j][i] * xn[i];
            }
            h[j] = match self.cfg.activation {
                Activation::Tanh => z.tanh(),
                Activation::Sigmoid => T::one() / (T::one() + (-z).exp()),
            };
        }
        let mut y = [T::zero(); OUTPUTS];
        for k in 0..OUTPUTS {
            let mut s = w.b2[k];
            for j in 0..HIDDEN {
                s += w.w2[k][j] * h[j];
            }
            y[k] = s;
        }
        y
    }

    /// Adds one sample's gradient of ½|y − t|² to the batch gradient; returns |y − t|².
    fn accumulate(&mut self, xn: &[T; INPUTS], tn: &[T; OUTPUTS], h: &mut [T; HIDDEN]) -> T {
        let y = self.pass(xn, h);
        let mut e = [T::zero(); OUTPUTS];
        let mut sq = T::zero();
        for k in 0..OUTPUTS {
            e[k] = y[k] - tn[k];
            sq += e[k] * e[k];
        }
        let w = &self.weights;
        let g = &mut self.grad;
        for k in 0..OUTPUTS {
            g.b2[k] += e[k];
            for j in 0..HIDDEN {
                g.w2[k][j] += e[k] * h[j];
            }
        }
        for j in 0..HIDDEN {
            let mut back = T::zero();
            for k in 0..OUTPUTS {
                back += w.w2[k][j] * e[k];
            }
            let slope = match self.cfg.activation {
                Activation::Tanh => T::one() - h[j] * h[j],
                Activation::Sigmoid => h[j] * (T::one() - h[j]),
            };
            let dz = back * slope;
            g.b1[j] += dz;
            for i in 0..INPUTS {
                g.w1[j][i] += dz * xn[i];
            }
        }
        sq
    }

    /// Momentum step on the mean gradient of `count` samples; clears the gradient.
    fn apply(&mut self, count: usize) {
        let eta = self.cfg.learning_rate / T::of(count.max(1) as f64);
        let mu = self.cfg.momentum;
        let (w, m, g) = (&mut self.weights, &mut self.momentum, &mut self.grad);
        let upd = |w: &mut T, m: &mut T, g: &mut T| {
            *m = mu * *m - eta * *g;
            *w += *m;
            *g = T::zero();
        };
        for j in 0..HIDDEN {
            for i in 0..INPUTS {
                upd(&mut w.w1[j][i], &mut m.w1[j][i], &mut g.w1[j][i]);
            }
            upd(&mut w.b1[j], &mut m.b1[j], &mut g.b1[j]);
        }
        for k in 0..OUTPUTS {
            for j in 0..HIDDEN {
                upd(&mut w.w2[k][j], &mut m.w2[k][j], &mut g.w2[k][j]);
            }
            upd(&mut w.b2[k], &mut m.b2[k], &mut g.b2[k]);
        }
    }

    fn encode<W: Write>(&self, e: &mut Encoder<'_, W>) -> Result<(), SnapshotError> {
        e.usize(INPUTS)?;
        e.usize(HIDDEN)?;
        e.usize(OUTPUTS)?;
        e.real(self.cfg.learning_rate)?;
        e.real(self.cfg.momentum)?;
        e.u32(self.cfg.batch)?;
        e.u8(match self.cfg.activation {
            Activation::Tanh => 0,
            Activation::Sigmoid => 1,
        })?;
        self.weights.encode(e)?;
        self.momentum.encode(e)?;
        e.reals(&self.input.mid)?;
        e.reals(&self.input.half)?;
        e.reals(&self.output.mid)?;
        e.reals(&self.output.half)?;
        e.rng(&self.rng)?;
        e.u32(self.epochs)
    }

    fn decode<R: Read>(&mut self, d: &mut Decoder<'_, R>) -> Result<(), SnapshotError> {
        d.expect_shape(INPUTS)?;
        d.expect_shape(HIDDEN)?;
        d.expect_shape(OUTPUTS)?;
        self.cfg.learning_rate = d.real()?;
        self.cfg.momentum = d.real()?;
        self.cfg.batch = d.u32()?;
        self.cfg.activation = match d.u8()? {
            0 => Activation::Tanh,
            1 => Activation::Sigmoid,
            _ => return Err(SnapshotError::Invalid),
        };
        check_config(&self.cfg).map_err(|_| SnapshotError::Invalid)?;
        self.weights.decode(d)?;
        self.momentum.decode(d)?;
        d.reals(&mut self.input.mid)?;
        d.reals(&mut self.input.half)?;
        d.reals(&mut self.output.mid)?;
        d.reals(&mut self.output.half)?;
        self.rng = d.rng()?;
        self.epochs = d.u32()?;
        self.grad = Weights::zero();
        let ok = self.weights_bounded() && self.input.valid() && self.output.valid();
        if ok {
            Ok(())
        } else {
            Err(SnapshotError::Invalid)
        }
    }
}

impl<T: Real, const INPUTS: usize, const HIDDEN: usize, const OUTPUTS: usize> Snapshot
    for Bpnn<T, INPUTS, HIDDEN, OUTPUTS>
{
    fn save<W: Write>(&self, w: &mut W) -> Result<(), SnapshotError> {
        save_with::<T, W, _>(w, Kind::Bpnn, |e| self.encode(e))
    }
    fn restore<R: Read>(&mut self, r: &mut R) -> Result<(), SnapshotError> {
        let mut tmp = self.clone();
        restore_with::<T, R, _, _>(r, Kind::Bpnn, |d| tmp.decode(d))?;
        *self = tmp;
        Ok(())
    }
}

fn check_config<T: Real>(cfg: &BpnnConfig<T>) -> Result<(), BpnnError> {
    let ok = cfg.learning_rate <= T::of(MAX_LEARNING_RATE)
        && cfg.learning_rate > T::zero()
        && cfg.momentum.finite()
        && cfg.momentum >= T::zero()
        && cfg.momentum < T::one()
        && cfg.batch >= 1;
    if ok {
        Ok(())
    } else {
        Err(BpnnError::Config)
    }
}

fn check_data<T: Real, const INPUTS: usize, const OUTPUTS: usize>(
    inputs: &[[T; INPUTS]],
    targets: &[[T; OUTPUTS]],
) -> Result<(), BpnnError> {
    if inputs.is_empty() || inputs.len() != targets.len() {
        return Err(BpnnError::Shape);
    }
    let finite = inputs.iter().all(|r| r.iter().all(|v| v.finite()))
        && targets.iter().all(|r| r.iter().all(|v| v.finite()));
    if finite {
        Ok(())
    } else {
        Err(BpnnError::NonFinite)
    }
}

fn min_max<T: Real, const K: usize>(rows: &[[T; K]]) -> ([T; K], [T; K]) {
    let mut lo = rows.first().copied().unwrap_or([T::zero(); K]);
    let mut hi = lo;
    for r in rows {
        for k in 0..K {
            lo[k] = lo[k].min(r[k]);
            hi[k] = hi[k].max(r[k]);
        }
    }
    (lo, hi)
}

/// Uniform in [−1, 1).
fn symmetric<T: Real>(rng: &mut Xoshiro256PlusPlus) -> T {
    T::of((rng.next_u64() >> 11) as f64 * (2.0 / 9_007_199_254_740_992.0) - 1.0)
}

/// A random permutation of `0..n` as `start + k·stride (mod n)` with `gcd(stride, n) = 1`.
fn permutation(rng: &mut Xoshiro256PlusPlus, n: usize) -> (usize, usize) {
    if n <= 1 {
        return (0, 1);
    }
    let start = (rng.next_u64() % n as u64) as usize;
    loop {
        let stride = 1 + (rng.next_u64() % (n as u64 - 1)) as usize;
        if gcd(stride, n) == 1 {
            return (start, stride);
        }
    }
}

fn gcd(mut a: usize, mut b: usize) -> usize {
    while b != 0 {
        let t = a % b;
        a = b;
        b = t;
    }
    a
}
