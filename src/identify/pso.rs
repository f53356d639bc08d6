//! Particle swarm optimisation as a sliced stepper (the BPNN-PSO paper, §3.1).
//!
//! `SWARM` particles search a box in `D` dimensions for the minimum of an [`Objective`] (for
//! calibration: [`crate::identify::fitness::PositionFitness`] over parameter deltas). Each iteration moves
//! every particle with the paper's update
//!
//! `v ← w·v + c1·r1·(pbest − x) + c2·r2·(gbest − x)`, `x ← x + v`
//!
//! (`r1`, `r2` uniform in [0, 1), drawn independently per particle and per dimension), then
//! evaluates it and updates its personal best. The update is *synchronous*, as in the paper's
//! steps 5–6: every particle of an iteration sees the global best of the previous iteration.
//!
//! **Defaults** are the paper's: 200 particles (the caller's `SWARM`), `c1 = 0.5`, `c2 = 1.25`,
//! `w = 0.9`. [`PsoConfig::calibration`] builds the box for a parameter set: ±0.5° for angles and
//! ±2 mm for lengths around the reference (the paper's errors are a fraction of that). The paper
//! leaves the rest open; we chose (on the 24-parameter ER20 problem) a velocity limit of 0.1 of
//! the range and particles starting at rest (both converged faster than the alternatives tried),
//! 1,000 iterations at most, and the stagnation stop below. With these coefficients PSO gets from
//! the nominal model to 10–25× the noise floor in ~400 iterations and to the floor in ~1,500:
//! the global search is quick, the refinement slow (see [`crate::identify::bpnn_pso`]), so polish with LM.
//!
//! **Bounds.** Each velocity component is clamped to ±`max_velocity`·(upper − lower) of its
//! dimension. A position that leaves the box is clamped onto the wall and that velocity
//! component is set to zero (an absorbing wall: the particle stays feasible and is not thrown
//! back out on the next update).
//!
//! **Termination** (checked after the initial swarm and after every iteration, in this order):
//! the global best fitness is at or below `target_fitness`; `max_iterations` iterations are done;
//! the global best has not improved by more than `stagnation_tolerance` (relative, default
//! 10⁻³) over the last `stagnation_window` iterations (default 50; 0 disables).
//!
//! **Slices.** [`Pso::step`] evaluates at most `budget` particles (one evaluation = one model
//! evaluation over all poses), so firmware can run a swarm in idle cycles; the state between
//! calls is complete, and [`Snapshot`] saves it, random generator included. Same seed, same
//! calls → bit-identical results, whatever the slicing.
//!
//! **History.** The global best after the initial swarm and after each iteration is kept for
//! plots (fitness against iteration) in a fixed buffer of `HISTORY_LEN` entries; later iterations
//! are not recorded once it is full.
//!
//! A swarm run in slices, saved half-way and resumed in another swarm, ends exactly where an
//! uninterrupted run ends:
//!
//! ```
//! use kinecal::identify::fitness::Objective;
//! use kinecal::identify::pso::{Pso, PsoConfig};
//! use kinecal::io::snapshot::Snapshot;
//!
//! /// `(x − 1)² + (y + 2)²`, smallest at (1, −2).
//! struct Bowl;
//! impl Objective<f64> for Bowl {
//!     fn dimension(&self) -> usize { 2 }
//!     fn fitness(&mut self, x: &[f64]) -> f64 { (x[0] - 1.0).powi(2) + (x[1] + 2.0).powi(2) }
//! }
//!
//! let mut cfg = PsoConfig::new([-5.0, -5.0], [5.0, 5.0]).unwrap();
//! cfg.max_iterations = 200;
//! let mut a: Pso<f64, 20, 2> = Pso::new(cfg, 7).unwrap();
//! let mut b = a.clone();
//! a.run(&mut Bowl).unwrap();
//!
//! // The same swarm, 15 evaluations per slice, saved after 105 evaluations.
//! for _ in 0..7 {
//!     b.step(&mut Bowl, 15).unwrap();
//! }
//! let mut buf = [0u8; 64 * 1024];
//! let mut w = &mut buf[..];
//! b.save(&mut w).unwrap();
//! let len = 64 * 1024 - w.len(); // bytes written
//! assert_eq!(&buf[..4], b"KCSN");
//! let mut c: Pso<f64, 20, 2> = Pso::new(cfg, 99).unwrap(); // any swarm of the same shape
//! c.restore(&mut &buf[..len]).unwrap();
//! while !c.is_finished() {
//!     c.step(&mut Bowl, 15).unwrap();
//! }
//! assert_eq!(c.best_position(), a.best_position()); // bit-identical
//! assert!((a.best_position()[0] - 1.0).abs() < 1e-3 && (a.best_position()[1] + 2.0).abs() < 1e-3);
//! ```

use crate::identify::fitness::Objective;
use crate::io::snapshot::{
    restore_with, save_with, Decoder, Encoder, Kind, Snapshot, SnapshotError,
};
use crate::model::param::Param;
use crate::Real;
use embedded_io::{Read, Write};
use rand_core::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Default capacity of the fitness history.
pub const HISTORY: usize = 1024;

/// Settings of a swarm in `D` dimensions.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PsoConfig<T: Real, const D: usize> {
    /// Inertia weight `w` (paper: 0.9).
    pub inertia: T,
    /// Acceleration towards the personal best, `c1` (paper: 0.5).
    pub cognitive: T,
    /// Acceleration towards the global best, `c2` (paper: 1.25).
    pub social: T,
    /// Lower corner of the search box.
    pub lower: [T; D],
    /// Upper corner of the search box (`lower < upper` in every dimension).
    pub upper: [T; D],
    /// Velocity limit per dimension as a fraction of that dimension's range.
    pub max_velocity: T,
    /// Initial velocities are uniform in ±`initial_velocity`·(velocity limit).
    pub initial_velocity: T,
    /// Stop after this many iterations (the initial swarm is iteration 0).
    pub max_iterations: u32,
    /// Stop as soon as the global best fitness is at or below this.
    pub target_fitness: T,
    /// Stop when the global best has not improved by more than `stagnation_tolerance`
    /// (relative) for this many iterations; 0 disables.
    pub stagnation_window: u32,
    /// Relative improvement that counts as progress for the stagnation test.
    pub stagnation_tolerance: T,
}

/// Why a configuration or a call was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PsoError {
    /// `SWARM` or `D` is zero.
    Empty,
    /// A bound is not finite, `lower >= upper`, or a span `upper − lower` too wide for `T`
    /// (times the velocity factors it overflows: `±1e308` in `f64`, say).
    Bounds,
    /// A coefficient or tolerance is negative or not finite.
    Coefficient,
    /// The objective's dimension is not `D`, or a parameter list's length is not `D`.
    Dimension,
    /// A start position was given after the swarm was first evaluated, or is not finite, or
    /// the particle index is out of range.
    Start,
}

/// Why a run stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PsoStop {
    /// `max_iterations` reached.
    MaxIterations,
    /// The global best reached `target_fitness`.
    Target,
    /// No significant improvement over `stagnation_window` iterations.
    Stagnated,
}

/// Where a run stands after a [`Pso::step`] call.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PsoProgress<T: Real> {
    /// Completed iterations (0 while and right after the initial swarm is evaluated).
    pub iteration: u32,
    /// Particle evaluations so far (each is one model evaluation over all poses).
    pub evaluations: u64,
    /// Global best fitness (+∞ before the first particle of the initial swarm is evaluated).
    pub best_fitness: T,
    /// `Some` once the run has finished.
    pub stopped: Option<PsoStop>,
}

impl<T: Real, const D: usize> PsoConfig<T, D> {
    /// The paper's coefficients over the box `[lower, upper]`; velocity limit 0.1 of the range,
    /// particles starting at rest, 1,000 iterations at most, no fitness target (0), and a
    /// stagnation stop after 50 iterations that improve the best by less than 0.1 % in total.
    ///
    /// The paper gives no velocity settings; on the 24-parameter problem a limit of 0.1 converged
    /// faster than 0.05–0.5, and starting at rest faster than random initial velocities.
    pub fn new(lower: [T; D], upper: [T; D]) -> Result<Self, PsoError> {
        let c = Self {
            inertia: T::of(0.9),
            cognitive: T::of(0.5),
            social: T::of(1.25),
            lower,
            upper,
            max_velocity: T::of(0.1),
            initial_velocity: T::zero(),
            max_iterations: 1000,
            target_fitness: T::zero(),
            stagnation_window: 50,
            stagnation_tolerance: T::of(1e-3),
        };
        c.validate()?;
        Ok(c)
    }

    /// A box of ±`angle` (rad; also used for non-length parameters) and ±`length` (mm) around
    /// zero delta for each parameter of `params` (in order), with the defaults of [`PsoConfig::new`].
    pub fn for_params(params: &[Param], angle: T, length: T) -> Result<Self, PsoError> {
        if params.len() != D {
            return Err(PsoError::Dimension);
        }
        let mut lower = [T::zero(); D];
        let mut upper = [T::zero(); D];
        for ((lo, hi), p) in lower.iter_mut().zip(upper.iter_mut()).zip(params) {
            let b = if p.is_length() { length } else { angle };
            *lo = -b;
            *hi = b;
        }
        Self::new(lower, upper)
    }

    /// The calibration box: ±0.5° for angles, ±2 mm for lengths (see [`PsoConfig::for_params`]).
    pub fn calibration(params: &[Param]) -> Result<Self, PsoError> {
        Self::for_params(params, T::of(0.5f64.to_radians()), T::of(2.0))
    }

    /// Checks bounds and coefficients.
    pub fn validate(&self) -> Result<(), PsoError> {
        if D == 0 {
            return Err(PsoError::Empty);
        }
        let nonneg = |v: T| v.finite() && v >= T::zero();
        // The largest velocity update of a dimension is at most span · k · (max_velocity + 1)
        // (coefficients ≥ 0 checked below): finite spans and that product keep every velocity
        // and position finite in `T`.
        let k = self.inertia + self.cognitive + self.social + self.initial_velocity + T::one();
        let fits = |l: &T, u: &T| {
            l < u
                && l.finite()
                && u.finite()
                && ((*u - *l) * k * (self.max_velocity + T::one())).finite()
        };
        if !self
            .lower
            .iter()
            .zip(self.upper.iter())
            .all(|(l, u)| fits(l, u))
        {
            return Err(PsoError::Bounds);
        }
        let ok = nonneg(self.inertia)
            && nonneg(self.cognitive)
            && nonneg(self.social)
            && nonneg(self.initial_velocity)
            && nonneg(self.stagnation_tolerance)
            && self.max_velocity.finite()
            && self.max_velocity > T::zero()
            && !is_nan(self.target_fitness);
        if ok {
            Ok(())
        } else {
            Err(PsoError::Coefficient)
        }
    }
}

#[inline(always)]
fn is_nan<T: Real>(v: T) -> bool {
    v.to_f64().is_nan()
}

/// Uniform in [0, 1) from the top 53 bits (may round to 1 in `f32`).
#[inline(always)]
fn unit<T: Real>(rng: &mut Xoshiro256PlusPlus) -> T {
    T::of((rng.next_u64() >> 11) as f64 * (1.0 / 9_007_199_254_740_992.0))
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Phase {
    /// Evaluating the initial swarm.
    Start,
    /// Moving and evaluating particles.
    Iterate,
    Done(PsoStop),
}

/// A particle swarm of `SWARM` particles in `D` dimensions with a fitness history of `HISTORY_LEN`
/// entries.
///
/// Sizes are const generics: `Pso<f32, 200, 24>` holds four `200 × 24` arrays (positions,
/// velocities, personal bests, starting positions), about 77 kB in `f32`.
#[derive(Clone, Debug)]
pub struct Pso<T: Real, const SWARM: usize, const D: usize, const HISTORY_LEN: usize = HISTORY> {
    cfg: PsoConfig<T, D>,
    vmax: [T; D],
    rng: Xoshiro256PlusPlus,
    position: [[T; D]; SWARM],
    velocity: [[T; D]; SWARM],
    best: [[T; D]; SWARM],
    best_fitness: [T; SWARM],
    /// The positions drawn at construction (the BPNN's inputs in BPNN-PSO).
    initial: [[T; D]; SWARM],
    global: [T; D],
    global_fitness: T,
    phase: Phase,
    next: usize,
    iteration: u32,
    evaluations: u64,
    /// Global best at the last significant improvement (stagnation test).
    reference: T,
    since_improvement: u32,
    history: heapless::Vec<T, HISTORY_LEN>,
}

impl<T: Real, const SWARM: usize, const D: usize, const HISTORY_LEN: usize>
    Pso<T, SWARM, D, HISTORY_LEN>
{
    /// A swarm drawn uniformly in the box from `seed` (positions, then velocities, particle
    /// by particle), not yet evaluated.
    pub fn new(cfg: PsoConfig<T, D>, seed: u64) -> Result<Self, PsoError> {
        if SWARM == 0 {
            return Err(PsoError::Empty);
        }
        cfg.validate()?;
        let inf = T::of(f64::INFINITY);
        let mut s = Self {
            cfg,
            vmax: [T::zero(); D],
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
            position: [[T::zero(); D]; SWARM],
            velocity: [[T::zero(); D]; SWARM],
            best: [[T::zero(); D]; SWARM],
            best_fitness: [inf; SWARM],
            initial: [[T::zero(); D]; SWARM],
            global: [T::zero(); D],
            global_fitness: inf,
            phase: Phase::Start,
            next: 0,
            iteration: 0,
            evaluations: 0,
            reference: inf,
            since_improvement: 0,
            history: heapless::Vec::new(),
        };
        s.restart(cfg, seed)?;
        Ok(s)
    }

    /// Starts a new run in place (no second swarm on the stack): the same as [`Pso::new`].
    /// On error `self` is unchanged.
    pub fn restart(&mut self, cfg: PsoConfig<T, D>, seed: u64) -> Result<(), PsoError> {
        cfg.validate()?;
        let inf = T::of(f64::INFINITY);
        self.cfg = cfg;
        self.vmax = velocity_limits(&cfg);
        self.rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        for (x, v) in self.position.iter_mut().zip(self.velocity.iter_mut()) {
            for ((xd, lo), hi) in x.iter_mut().zip(cfg.lower.iter()).zip(cfg.upper.iter()) {
                // (`min`: the sum may round above the upper bound.)
                *xd = (*lo + unit::<T>(&mut self.rng) * (*hi - *lo)).min(*hi);
            }
            for (vd, vm) in v.iter_mut().zip(self.vmax.iter()) {
                *vd =
                    (unit::<T>(&mut self.rng) * T::of(2.0) - T::one()) * cfg.initial_velocity * *vm;
            }
        }
        self.best = self.position;
        self.initial = self.position;
        self.best_fitness = [inf; SWARM];
        self.global = self.position.first().copied().unwrap_or([T::zero(); D]);
        self.global_fitness = inf;
        self.phase = Phase::Start;
        self.next = 0;
        self.iteration = 0;
        self.evaluations = 0;
        self.reference = inf;
        self.since_improvement = 0;
        self.history.clear();
        Ok(())
    }

    /// Replaces particle `i`'s starting position (clamped into the box) and velocity (clamped
    /// to the velocity limit) before the swarm is first evaluated: how BPNN-PSO places its
    /// predicted particles. The drawn position stays available in [`Pso::initial_positions`].
    pub fn set_start(&mut self, i: usize, x: &[T; D], v: &[T; D]) -> Result<(), PsoError> {
        if self.evaluations != 0 || i >= SWARM || !x.iter().chain(v.iter()).all(|c| c.finite()) {
            return Err(PsoError::Start);
        }
        for d in 0..D {
            self.position[i][d] = x[d].max(self.cfg.lower[d]).min(self.cfg.upper[d]);
            self.velocity[i][d] = v[d].max(-self.vmax[d]).min(self.vmax[d]);
        }
        self.best[i] = self.position[i];
        if i == 0 {
            self.global = self.position[i];
        }
        Ok(())
    }

    /// The settings the swarm was built with.
    pub fn config(&self) -> &PsoConfig<T, D> {
        &self.cfg
    }
    /// Velocity limit of each dimension.
    pub fn velocity_limits(&self) -> &[T; D] {
        &self.vmax
    }
    /// Best position found so far (the first particle's before any evaluation).
    pub fn best_position(&self) -> &[T; D] {
        &self.global
    }
    /// Fitness of [`Pso::best_position`] (+∞ before any evaluation).
    pub fn best_fitness(&self) -> T {
        self.global_fitness
    }
    /// Every particle's current position.
    pub fn positions(&self) -> &[[T; D]; SWARM] {
        &self.position
    }
    /// Every particle's current velocity.
    pub fn velocities(&self) -> &[[T; D]; SWARM] {
        &self.velocity
    }
    /// Each particle's best position so far.
    pub fn personal_bests(&self) -> &[[T; D]; SWARM] {
        &self.best
    }
    /// Fitness of each particle's best position so far.
    pub fn personal_best_fitness(&self) -> &[T; SWARM] {
        &self.best_fitness
    }
    /// The positions drawn at construction, before any [`Pso::set_start`].
    pub fn initial_positions(&self) -> &[[T; D]; SWARM] {
        &self.initial
    }
    /// Global best after the initial swarm (index 0) and after each iteration (index k).
    pub fn history(&self) -> &[T] {
        &self.history
    }
    /// The first iteration whose global best is at or below `fitness`, from the history.
    pub fn iterations_to_reach(&self, fitness: T) -> Option<u32> {
        self.history
            .iter()
            .position(|f| *f <= fitness)
            .and_then(|k| u32::try_from(k).ok())
    }
    /// Iteration, evaluations, best fitness and, once finished, why it stopped.
    pub fn progress(&self) -> PsoProgress<T> {
        PsoProgress {
            iteration: self.iteration,
            evaluations: self.evaluations,
            best_fitness: self.global_fitness,
            stopped: match self.phase {
                Phase::Done(s) => Some(s),
                _ => None,
            },
        }
    }
    /// True once a stopping rule has fired: further [`Pso::step`] calls do nothing.
    pub fn is_finished(&self) -> bool {
        matches!(self.phase, Phase::Done(_))
    }

    /// Evaluates at most `budget` particles (moving each first, except in the initial swarm)
    /// and returns the progress. Does nothing once finished.
    pub fn step<F: Objective<T> + ?Sized>(
        &mut self,
        problem: &mut F,
        budget: usize,
    ) -> Result<PsoProgress<T>, PsoError> {
        if problem.dimension() != D {
            return Err(PsoError::Dimension);
        }
        let mut left = budget;
        while left > 0 {
            let moving = match self.phase {
                Phase::Done(_) => break,
                Phase::Start => false,
                Phase::Iterate => true,
            };
            let i = self.next;
            if moving {
                self.advance(i);
            }
            let f = problem.fitness(&self.position[i]);
            let f = if f.finite() { f } else { T::of(f64::INFINITY) };
            self.evaluations = self.evaluations.saturating_add(1);
            left -= 1;
            if f < self.best_fitness[i] {
                self.best_fitness[i] = f;
                self.best[i] = self.position[i];
            }
            self.next += 1;
            if self.next >= SWARM {
                self.next = 0;
                self.end_iteration();
            }
        }
        Ok(self.progress())
    }

    /// Runs to the end in one call (desktop use).
    pub fn run<F: Objective<T> + ?Sized>(
        &mut self,
        problem: &mut F,
    ) -> Result<PsoProgress<T>, PsoError> {
        loop {
            let p = self.step(problem, usize::MAX)?;
            if p.stopped.is_some() {
                return Ok(p);
            }
        }
    }

    /// Velocity and position update of particle `i`, with the absorbing walls.
    fn advance(&mut self, i: usize) {
        let (w, c1, c2) = (self.cfg.inertia, self.cfg.cognitive, self.cfg.social);
        for d in 0..D {
            let r1: T = unit(&mut self.rng);
            let r2: T = unit(&mut self.rng);
            let x = self.position[i][d];
            let vm = self.vmax[d];
            let mut v = w * self.velocity[i][d]
                + c1 * r1 * (self.best[i][d] - x)
                + c2 * r2 * (self.global[d] - x);
            v = v.max(-vm).min(vm);
            let mut nx = x + v;
            if nx < self.cfg.lower[d] {
                nx = self.cfg.lower[d];
                v = T::zero();
            } else if nx > self.cfg.upper[d] {
                nx = self.cfg.upper[d];
                v = T::zero();
            }
            self.position[i][d] = nx;
            self.velocity[i][d] = v;
        }
    }

    fn end_iteration(&mut self) {
        // Lowest personal best (first on ties); the global best only ever improves.
        for (b, f) in self.best.iter().zip(self.best_fitness.iter()) {
            if *f < self.global_fitness {
                self.global_fitness = *f;
                self.global = *b;
            }
        }
        if self.phase == Phase::Start {
            self.phase = Phase::Iterate;
            self.reference = self.global_fitness;
        } else {
            self.iteration = self.iteration.saturating_add(1);
            let improved = if self.reference.finite() {
                self.global_fitness
                    < self.reference - self.cfg.stagnation_tolerance * self.reference.abs()
            } else {
                self.global_fitness.finite()
            };
            if improved {
                self.reference = self.global_fitness;
                self.since_improvement = 0;
            } else {
                self.since_improvement = self.since_improvement.saturating_add(1);
            }
        }
        let _ = self.history.push(self.global_fitness);
        if self.global_fitness <= self.cfg.target_fitness {
            self.phase = Phase::Done(PsoStop::Target);
        } else if self.iteration >= self.cfg.max_iterations {
            self.phase = Phase::Done(PsoStop::MaxIterations);
        } else if self.cfg.stagnation_window > 0
            && self.since_improvement >= self.cfg.stagnation_window
        {
            self.phase = Phase::Done(PsoStop::Stagnated);
        }
    }

    /// As [`Snapshot::restore`], but decodes into `scratch` (any swarm of the same size; its
    /// contents are overwritten) instead of a temporary copy on the stack, and swaps the two on
    /// success: for large swarms on a controller. On error `self` is unchanged and `scratch` holds
    /// garbage.
    pub fn restore_using<R: Read>(
        &mut self,
        scratch: &mut Self,
        r: &mut R,
    ) -> Result<(), SnapshotError> {
        restore_with::<T, R, _, _>(r, Kind::Pso, |d| scratch.decode(d))?;
        core::mem::swap(self, scratch);
        Ok(())
    }

    fn encode<W: Write>(&self, e: &mut Encoder<'_, W>) -> Result<(), SnapshotError> {
        e.usize(SWARM)?;
        e.usize(D)?;
        e.usize(HISTORY_LEN)?;
        let c = &self.cfg;
        e.real(c.inertia)?;
        e.real(c.cognitive)?;
        e.real(c.social)?;
        e.reals(&c.lower)?;
        e.reals(&c.upper)?;
        e.real(c.max_velocity)?;
        e.real(c.initial_velocity)?;
        e.u32(c.max_iterations)?;
        e.real(c.target_fitness)?;
        e.u32(c.stagnation_window)?;
        e.real(c.stagnation_tolerance)?;
        e.rng(&self.rng)?;
        e.u8(match self.phase {
            Phase::Start => 0,
            Phase::Iterate => 1,
            Phase::Done(PsoStop::MaxIterations) => 2,
            Phase::Done(PsoStop::Target) => 3,
            Phase::Done(PsoStop::Stagnated) => 4,
        })?;
        e.usize(self.next)?;
        e.u32(self.iteration)?;
        e.u64(self.evaluations)?;
        e.real(self.reference)?;
        e.u32(self.since_improvement)?;
        e.reals(&self.global)?;
        e.real(self.global_fitness)?;
        e.real_rows(&self.position)?;
        e.real_rows(&self.velocity)?;
        e.real_rows(&self.best)?;
        e.reals(&self.best_fitness)?;
        e.real_rows(&self.initial)?;
        e.usize(self.history.len())?;
        e.reals(&self.history)
    }

    /// Overwrites every field from `d` and validates the result.
    fn decode<R: Read>(&mut self, d: &mut Decoder<'_, R>) -> Result<(), SnapshotError> {
        d.expect_shape(SWARM)?;
        d.expect_shape(D)?;
        d.expect_shape(HISTORY_LEN)?;
        let c = &mut self.cfg;
        c.inertia = d.real()?;
        c.cognitive = d.real()?;
        c.social = d.real()?;
        d.reals(&mut c.lower)?;
        d.reals(&mut c.upper)?;
        c.max_velocity = d.real()?;
        c.initial_velocity = d.real()?;
        c.max_iterations = d.u32()?;
        c.target_fitness = d.real()?;
        c.stagnation_window = d.u32()?;
        c.stagnation_tolerance = d.real()?;
        c.validate().map_err(|_| SnapshotError::Invalid)?;
        self.vmax = velocity_limits(c);
        self.rng = d.rng()?;
        self.phase = match d.u8()? {
            0 => Phase::Start,
            1 => Phase::Iterate,
            2 => Phase::Done(PsoStop::MaxIterations),
            3 => Phase::Done(PsoStop::Target),
            4 => Phase::Done(PsoStop::Stagnated),
            _ => return Err(SnapshotError::Invalid),
        };
        self.next = d.usize()?;
        self.iteration = d.u32()?;
        self.evaluations = d.u64()?;
        self.reference = d.real()?;
        self.since_improvement = d.u32()?;
        d.reals(&mut self.global)?;
        self.global_fitness = d.real()?;
        d.real_rows(&mut self.position)?;
        d.real_rows(&mut self.velocity)?;
        d.real_rows(&mut self.best)?;
        d.reals(&mut self.best_fitness)?;
        d.real_rows(&mut self.initial)?;
        let n = d.usize()?;
        if n > HISTORY_LEN {
            return Err(SnapshotError::Invalid);
        }
        self.history.clear();
        for _ in 0..n {
            let v: T = d.real()?;
            self.history.push(v).map_err(|_| SnapshotError::Invalid)?;
        }
        // Positions inside the box and velocities within their limits (the initial ones within
        // `initial_velocity` times them); NaN fails both.
        let (lo, hi, vm) = (&self.cfg.lower, &self.cfg.upper, &self.vmax);
        let f = self.cfg.initial_velocity.max(T::one());
        let inside = |x: &[T; D]| (0..D).all(|d| x[d] >= lo[d] && x[d] <= hi[d]);
        let rows_inside = |a: &[[T; D]; SWARM]| a.iter().all(inside);
        let ok = self.next < SWARM
            && rows_inside(&self.position)
            && self
                .velocity
                .iter()
                .all(|v| (0..D).all(|d| v[d].abs() <= vm[d] * f))
            && rows_inside(&self.best)
            && rows_inside(&self.initial)
            && inside(&self.global)
            && !self.best_fitness.iter().any(|f| is_nan(*f))
            && !is_nan(self.global_fitness)
            && !is_nan(self.reference)
            && !self.history.iter().any(|f| is_nan(*f));
        if ok {
            Ok(())
        } else {
            Err(SnapshotError::Invalid)
        }
    }
}

fn velocity_limits<T: Real, const D: usize>(cfg: &PsoConfig<T, D>) -> [T; D] {
    let mut v = [T::zero(); D];
    for d in 0..D {
        v[d] = cfg.max_velocity * (cfg.upper[d] - cfg.lower[d]);
    }
    v
}

impl<T: Real, const SWARM: usize, const D: usize, const HISTORY_LEN: usize> Snapshot
    for Pso<T, SWARM, D, HISTORY_LEN>
{
    fn save<W: Write>(&self, w: &mut W) -> Result<(), SnapshotError> {
        save_with::<T, W, _>(w, Kind::Pso, |e| self.encode(e))
    }

    /// Decodes into a copy (one extra swarm on the stack) and replaces `self` only when the
    /// whole snapshot is valid.
    fn restore<R: Read>(&mut self, r: &mut R) -> Result<(), SnapshotError> {
        let mut tmp = self.clone();
        restore_with::<T, R, _, _>(r, Kind::Pso, |d| tmp.decode(d))?;
        *self = tmp;
        Ok(())
    }
}
