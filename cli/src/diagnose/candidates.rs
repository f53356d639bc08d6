//! The candidate catalogue of the discrepancy search: every effect of docs/formats.md "Effects" on
//! every joint where it can mean something, and how each is added to a model, read back and
//! said in words.
//!
//! Choices (and why):
//! - `joint-cyclic` of orders 1..=K (K = 3 by default): gear and encoder eccentricities show up
//!   once or a few times per turn; higher orders are possible but the table covers them.
//! - `axis-tilt` only where the tilt is a missing parameter: for a joint whose axis is nominally
//!   parallel to the previous one (|alpha| within 2° of 0° or 180°), and for joint 1 when the
//!   base is known and joint 1's axis is parallel to the base z axis. Elsewhere the modified DH
//!   row already describes any axis direction, so beta would duplicate alpha/theta/d.
//! - `joint-compliance` only where the lever arm is not identically zero (joint 1 of an upright
//!   arm turns about the gravity direction and feels no moment).
//! - `joint-table`: a piecewise-linear correction whose resolution and knot positions are part
//!   of the model choice, offered on two ladders and compared by the same cross-validation:
//!   - *range fractions*: `M` equal intervals over the joint's limits (`M` = 2…24 and a ladder
//!     of finer ones, 30 … 200), anchored at the lower limit, as `kinecal simulate` and the
//!     robot file's default `start_deg` write a table; on the UR10 (limits ±360°) `M` = 200
//!     gives the 3.6° knots of the findings;
//!   - *fixed pitches* (1°, 2°, 3°, 3.6°, 4° … 90°) with knots on multiples of the pitch: gear
//!     and encoder errors repeat per motor or gear revolution, so their natural grid is a fixed
//!     angle, not a fraction of the limits (on a ±185° joint the 36-interval grid is 10.28°
//!     from −185°, and a 10° table aligned to 0° would keep a kink unmodelled at every knot).
//!     Each pitch is offered at two phases (knots at multiples of the pitch, and shifted by half
//!     of it); the best grids of the most promising tables then have their phase fitted by
//!     bisection down to 1/64 of the pitch ([`shifted`], `diagnose::phase`), so a table
//!     whose knots sit at 2° + k·5° is matched too. Every grid is trimmed to the range the data
//!     cover and offered only with at least 4 poses per knot interval and at least 4 knots.
//!     Every grid of the catalogue counts in the Bonferroni correction of the round; the phase
//!     bisection is the fit of one more continuous parameter of a candidate (like its knot
//!     values) and a shift is kept only when it lowers the screen's held-out error by 1 %; the
//!     null cases of the test matrices measure what both do to the false-alarm rate.
//! - `thermal-expansion` once (it acts on no joint: listed on joint 1), when every pose has a
//!   temperature and they span at least [`CatalogueConfig::min_temperature_span_c`]; its
//!   reference temperature is the data's mean, so that `c` does not trade with the lengths.
//! - `base-drift` once (the measuring instrument drifting: listed on joint 1), when every pose
//!   has a time (`t_s`) and they span a positive time; its reference time is the data's mean,
//!   so that the drift does not trade with the base position. It is told apart from
//!   thermal expansion by the pattern: a drift moves every point alike, an expansion moves each
//!   point in proportion to its distance from the base origin; and from a base error by the
//!   time: a drift grows along the session, a base error is the same at every row.

use crate::formats::robot_file::AXIS_TILT;
use crate::output::numfmt::sig;
use kinecal::model::effects::EffectKind;
use kinecal::model::param::Param;
use kinecal::{ForwardKinematics, Joint, Measurement, Robot};

/// What kind of correction a candidate adds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum CandidateKind {
    /// `k · τ_j`.
    Compliance,
    /// `a·sin(n q_j) + b·cos(n q_j)` of the given order `n`.
    Cyclic(u16),
    /// `s · q_j`.
    Scale,
    /// The joint's `beta` becomes free.
    Tilt,
    /// Piecewise-linear in `q_j`: first knot at `start` (rad), spacing `step` (rad).
    Table { start: f64, step: f64, knots: usize },
    /// Every length scales by `1 + c·(T − reference)` (°C).
    Thermal { reference: f64 },
    /// The base translates by `v·(t − reference)` (s): the tracker drifting.
    Drift { reference: f64 },
}

/// One candidate: a kind on a joint (0-based).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Candidate {
    pub kind: CandidateKind,
    pub joint: usize,
}

/// How large the catalogue is.
#[derive(Clone, Debug, PartialEq)]
pub struct CatalogueConfig {
    /// Cyclic orders 1..=this.
    pub max_cyclic_order: u16,
    /// Table grids: numbers of equal intervals over the joint's limits.
    pub table_intervals: Vec<u32>,
    /// Table grids: fixed pitches (degrees), knots on multiples of the pitch.
    pub table_pitches_deg: Vec<f64>,
    /// Phases offered for every fixed pitch: the knots on multiples of the pitch shifted by
    /// `k / pitch_phases` of it, `k` = 0 … `pitch_phases − 1`.
    pub pitch_phases: u32,
    /// Bisection steps of the phase refinement of the best grids: shifts of ±1/(2·pitch_phases)
    /// of the pitch, then half that, and so on (0: no refinement).
    pub phase_levels: u32,
    /// How many of a promising table's best screened grids (distinct spacings) are refined…
    pub phase_search_grids: usize,
    /// …and on fewer poses, where a refinement costs less and cross-validation tells grids
    /// apart less surely, up to this many: as many as [`Self::phase_search_pose_grids`] poses
    /// × grids allow.
    pub phase_search_grids_most: usize,
    /// The work the phase refinement may spend, in poses × refined grids.
    pub phase_search_pose_grids: usize,
    /// A table grid is offered only when the data have at least this many poses per interval
    /// of the range they cover…
    pub min_poses_per_interval: f64,
    /// …and the table has at least this many knots over that range (fewer is little more than
    /// an offset and a scale).
    pub min_knots: usize,
    /// Axes within this angle (degrees) of parallel count as parallel (for `axis-tilt`).
    pub parallel_tolerance_deg: f64,
    /// `thermal-expansion` is offered when the poses' temperatures span at least this many
    /// kelvin (1.2e-5/K over 1 K moves a point 2 m out by 0.024 mm: about a tracker's noise).
    pub min_temperature_span_c: f64,
}

impl Default for CatalogueConfig {
    fn default() -> Self {
        Self {
            max_cyclic_order: 3,
            table_intervals: (2..=24)
                .chain([30, 36, 40, 48, 60, 72, 90, 100, 120, 150, 180, 200])
                .collect(),
            table_pitches_deg: vec![
                1.0, 2.0, 3.0, 3.6, 4.0, 4.5, 5.0, 6.0, 7.5, 9.0, 10.0, 12.0, 15.0, 18.0, 20.0,
                22.5, 30.0, 36.0, 45.0, 60.0, 90.0,
            ],
            pitch_phases: 2,
            phase_levels: 5,
            phase_search_grids: 6,
            phase_search_grids_most: 12,
            phase_search_pose_grids: 12_000,
            min_poses_per_interval: 4.0,
            min_knots: 4,
            parallel_tolerance_deg: 2.0,
            min_temperature_span_c: 1.0,
        }
    }
}

impl CatalogueConfig {
    /// How many grids of a promising table are refined on `poses` poses: at least
    /// `phase_search_grids`, at most `phase_search_grids_most`, as many as
    /// `phase_search_pose_grids / poses`.
    pub fn phase_grids_for(&self, poses: usize) -> usize {
        (self.phase_search_pose_grids / poses.max(1)).clamp(
            self.phase_search_grids,
            self.phase_search_grids_most.max(self.phase_search_grids),
        )
    }
}

impl Candidate {
    /// The effect id of docs/formats.md "Effects".
    pub fn id(&self) -> &'static str {
        match self.kind {
            CandidateKind::Compliance => "joint-compliance",
            CandidateKind::Cyclic(_) => "joint-cyclic",
            CandidateKind::Scale => "joint-scale",
            CandidateKind::Tilt => AXIS_TILT,
            CandidateKind::Table { .. } => "joint-table",
            CandidateKind::Thermal { .. } => "thermal-expansion",
            CandidateKind::Drift { .. } => "base-drift",
        }
    }

    /// The library's effect kind (`None` for axis-tilt, which is geometric).
    pub fn effect_kind(&self) -> Option<EffectKind> {
        match self.kind {
            CandidateKind::Compliance => Some(EffectKind::Compliance),
            CandidateKind::Cyclic(_) => Some(EffectKind::Cyclic),
            CandidateKind::Scale => Some(EffectKind::Scale),
            CandidateKind::Tilt => None,
            CandidateKind::Table { .. } => Some(EffectKind::Table),
            CandidateKind::Thermal { .. } => Some(EffectKind::Thermal),
            CandidateKind::Drift { .. } => Some(EffectKind::Drift),
        }
    }

    /// Short label: `joint-cyclic order 2 on joint 3`, `joint-table every 3.6° on joint 1`.
    pub fn label(&self) -> String {
        let j = self.joint + 1;
        match self.kind {
            CandidateKind::Cyclic(n) => format!("joint-cyclic order {n} on joint {j}"),
            CandidateKind::Table { start, step, knots } => {
                format!(
                    "joint-table every {}° from {}° ({knots} knots) on joint {j}",
                    round_sig(step.to_degrees(), 4),
                    round_sig(start.to_degrees(), 6)
                )
            }
            CandidateKind::Thermal { reference } => format!(
                "thermal-expansion (reference {} °C)",
                round_sig(reference, 4)
            ),
            CandidateKind::Drift { .. } => {
                "base-drift (the tracker moving during the session)".into()
            }
            _ => format!("{} on joint {j}", self.id()),
        }
    }

    /// True when `other` is the same effect (tables of any grid are the same effect).
    pub fn same_effect(&self, other: &Candidate) -> bool {
        self.joint == other.joint
            && match (self.kind, other.kind) {
                (CandidateKind::Cyclic(a), CandidateKind::Cyclic(b)) => a == b,
                (CandidateKind::Table { .. }, CandidateKind::Table { .. }) => true,
                (a, b) => core::mem::discriminant(&a) == core::mem::discriminant(&b),
            }
    }

    /// True when `robot` already carries this effect (or a table on the joint, or a free tilt
    /// listed in `free_tilt`).
    pub fn present_in<const N: usize, V: kinecal::ValueStorage>(
        &self,
        robot: &Robot<f64, N, V>,
        free_tilt: &[usize],
    ) -> bool {
        match (self.kind, self.effect_kind()) {
            (CandidateKind::Tilt, _) => free_tilt.contains(&self.joint),
            (CandidateKind::Cyclic(n), Some(k)) => robot.effects().find(k, self.joint, n).is_some(),
            (_, Some(k)) => robot.effects().find(k, self.joint, 1).is_some(),
            _ => false,
        }
    }

    /// Adds the candidate to `robot` with zero values; returns the parameters it makes free.
    pub fn add_to<const N: usize, V: kinecal::ValueStorage>(
        &self,
        robot: &mut Robot<f64, N, V>,
    ) -> anyhow::Result<Vec<Param>> {
        anyhow::ensure!(self.joint < N, "joint {} does not exist", self.joint + 1);
        let (order, start, step, len) = match self.kind {
            CandidateKind::Tilt => return Ok(vec![Param::Beta(self.joint as u8)]),
            CandidateKind::Cyclic(n) => (n, 0.0, 0.0, 2),
            CandidateKind::Table { start, step, knots } => (1, start, step, knots),
            CandidateKind::Thermal { reference } => (1, reference, 0.0, 1),
            CandidateKind::Drift { reference } => (1, reference, 0.0, 3),
            _ => (1, 0.0, 0.0, 1),
        };
        let kind = self
            .effect_kind()
            .ok_or_else(|| anyhow::anyhow!("no effect kind"))?;
        let first = robot.effects().values().len();
        robot
            .effects_mut()
            .push(kind, self.joint, N, order, start, step, &vec![0.0; len])
            .map_err(|e| anyhow::anyhow!("cannot add {}: {e:?}", self.label()))?;
        Ok((first..first + len)
            .map(|k| Param::Effect(k as u16))
            .collect())
    }

    /// The candidate's values in `robot` (in the units of the robot file: rad, rad per m,
    /// dimensionless; axis-tilt: `[beta]` in rad).
    pub fn values<const N: usize, V: kinecal::ValueStorage>(
        &self,
        robot: &Robot<f64, N, V>,
    ) -> Vec<f64> {
        match (self.kind, self.effect_kind()) {
            (CandidateKind::Tilt, _) => {
                vec![robot.joints().get(self.joint).map_or(0.0, |j| j.beta)]
            }
            (kind, Some(k)) => {
                let order = if let CandidateKind::Cyclic(n) = kind {
                    n
                } else {
                    1
                };
                robot
                    .effects()
                    .find(k, self.joint, order)
                    .map(|i| robot.effects().values_of(i).to_vec())
                    .unwrap_or_default()
            }
            _ => Vec::new(),
        }
    }

    /// The joint correction (rad) the candidate's `values` give at reading `q` (rad) and lever
    /// arm `tau` (m); axis-tilt gives 0 (it is not a joint-angle error).
    pub fn correction(&self, values: &[f64], q: f64, tau: f64) -> f64 {
        let v = |i: usize| values.get(i).copied().unwrap_or(0.0);
        match self.kind {
            CandidateKind::Compliance => v(0) * tau,
            CandidateKind::Scale => v(0) * q,
            CandidateKind::Cyclic(n) => {
                let (s, c) = (q * n as f64).sin_cos();
                v(0) * s + v(1) * c
            }
            CandidateKind::Tilt | CandidateKind::Thermal { .. } | CandidateKind::Drift { .. } => {
                0.0
            }
            CandidateKind::Table { start, step, knots } => {
                if knots < 2 || values.len() < knots {
                    return 0.0;
                }
                let u = ((q - start) / step).clamp(0.0, (knots - 1) as f64);
                let k = (u.floor() as usize).min(knots - 2);
                let w = u - k as f64;
                v(k) * (1.0 - w) + v(k + 1) * w
            }
        }
    }

    /// What the effect means, in words a technician understands (without the numbers of the
    /// search): "joint 2 deflects under load (compliance 2.0e-4 rad per m of lever arm)".
    pub fn meaning(&self, values: &[f64]) -> String {
        let j = self.joint + 1;
        let v0 = values.first().copied().unwrap_or(0.0);
        match self.kind {
            CandidateKind::Compliance => format!(
                "joint {j} deflects under load (compliance {} rad per m of lever arm)",
                if v0.is_finite() { format!("{v0:.1e}") } else { "-".into() }
            ),
            CandidateKind::Scale => format!(
                "joint {j} turns {} than its reading says (scale error {} ppm: gear ratio or encoder resolution slightly off)",
                if v0 >= 0.0 { "further" } else { "less far" },
                if v0.is_finite() { format!("{}{}", if v0 >= 0.0 { "+" } else { "" }, sig(v0 * 1e6, 3)) } else { "-".into() }
            ),
            CandidateKind::Cyclic(n) => {
                let amp = (v0 * v0 + values.get(1).map_or(0.0, |b| b * b)).sqrt();
                let times = match n {
                    1 => "once per turn (an eccentric gear or encoder)".to_string(),
                    2 => "twice per turn".to_string(),
                    n => format!("{n} times per turn"),
                };
                format!("joint {j} has an angle error of ±{} that repeats {times}", fmt_deg(amp))
            }
            CandidateKind::Tilt => {
                let parent = if self.joint == 0 { "the base's vertical".to_string() } else { format!("joint {}'s axis", self.joint) };
                format!("joint {j}'s axis is tilted by {} out of parallel with {parent}", fmt_deg(v0.abs()))
            }
            CandidateKind::Thermal { reference } => {
                format!(
                    "the arm's lengths grow with its temperature (thermal expansion {} ppm per kelvin from {} °C; steel ≈ 12, aluminium ≈ 23)",
                    if v0.is_finite() { sig(v0 * 1e6, 3) } else { "-".into() },
                    round_sig(reference, 4)
                )
            }
            CandidateKind::Drift { .. } => {
                let v = (v0 * v0 + values.iter().skip(1).map(|x| x * x).sum::<f64>()).sqrt();
                format!(
                    "the measuring instrument drifted during the session ({} mm per hour against the robot: re-register the tracker, warm it up, or shorten the session)",
                    if v.is_finite() { sig(v * 3600.0, 3) } else { "-".into() }
                )
            }
            CandidateKind::Table { start, step, knots } => {
                let rms = (values.iter().map(|v| v * v).sum::<f64>() / values.len().max(1) as f64).sqrt();
                let peak = values.iter().fold(0.0f64, |a, v| a.max(v.abs()));
                format!(
                    "joint {j} has an angle error that changes over a few degrees of travel ({} RMS, peak {}; a correction table with {knots} knots every {}° from {}°: gear transmission error)",
                    fmt_deg(rms),
                    fmt_deg(peak),
                    round_sig(step.to_degrees(), 4),
                    round_sig(start.to_degrees(), 6)
                )
            }
        }
    }
}

/// A length in mm for sentences: three significant digits (`-` when not finite). To print
/// two figures that must be told apart, use [`crate::diagnose::distinct_figures`].
pub fn fmt_mm(x: f64) -> String {
    sig(x, 3)
}

/// An angle given in rad as degrees with three significant digits (`-` when not finite).
pub fn fmt_deg(rad: f64) -> String {
    format!("{}°", sig(rad.to_degrees(), 3))
}

fn round_sig(x: f64, digits: i32) -> f64 {
    // Below a millionth of the unit is rounding noise of the arithmetic (a table start of
    // -2.5e-14°), printed as 0.
    if x.abs() < 1e-6 || !x.is_finite() {
        return if x.is_finite() { 0.0 } else { x };
    }
    let m = 10f64.powi(digits - 1 - x.abs().log10().floor() as i32);
    (x * m).round() / m
}

/// True when row `j`'s axis is (nominally) parallel to the previous axis.
fn parallel(joint: &Joint<f64>, tol_deg: f64) -> bool {
    joint.alpha.sin().abs() < tol_deg.to_radians().sin()
}

/// Every candidate for `robot` and `data` (see the module doc for what is left out and why).
pub fn catalogue<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    base_known: bool,
    data: &[Measurement<f64, N>],
    cfg: &CatalogueConfig,
) -> Vec<Candidate> {
    let mut out = Vec::new();
    if data.is_empty() {
        return out;
    }
    let (lo, hi) = coverage(data);
    if let Some(reference) = temperature_reference(data, cfg.min_temperature_span_c) {
        out.push(Candidate {
            kind: CandidateKind::Thermal { reference },
            joint: 0,
        });
    }
    if let Some(reference) = crate::calibration::drift::mean_time(data) {
        out.push(Candidate {
            kind: CandidateKind::Drift { reference },
            joint: 0,
        });
    }
    let mut tau_max = [0.0f64; N];
    let mut fk = ForwardKinematics::new();
    for m in data {
        fk.compute_at(robot, &m.q, 0, m.conditions())
            .unwrap_or_default();
        let tau = fk.lever_arms();
        for j in 0..N {
            tau_max[j] = tau_max[j].max(tau[j].abs());
        }
    }
    for (j, row) in robot.joints().iter().enumerate() {
        let moved = hi[j] - lo[j] > 1e-3;
        if tau_max[j] > 1e-6 {
            out.push(Candidate {
                kind: CandidateKind::Compliance,
                joint: j,
            });
        }
        if moved {
            for n in 1..=cfg.max_cyclic_order {
                out.push(Candidate {
                    kind: CandidateKind::Cyclic(n),
                    joint: j,
                });
            }
            out.push(Candidate {
                kind: CandidateKind::Scale,
                joint: j,
            });
        }
        let tilt_ok = if j == 0 {
            base_known && parallel(row, cfg.parallel_tolerance_deg)
        } else {
            parallel(row, cfg.parallel_tolerance_deg)
        };
        if tilt_ok {
            out.push(Candidate {
                kind: CandidateKind::Tilt,
                joint: j,
            });
        }
        if moved {
            let n = data.len();
            let mut grids: Vec<(f64, f64, usize)> = Vec::new();
            for &m in &cfg.table_intervals {
                if m == 0 {
                    continue;
                }
                let step = (row.upper - row.lower) / m as f64;
                grids.extend(table_grid(row.lower, step, lo[j], hi[j], n, cfg));
            }
            for &p in &cfg.table_pitches_deg {
                // Knots on multiples of the pitch (and shifted by fractions of it): computed
                // in degrees, so that a knot at 10° is written back as 10, not 9.999999999999998.
                let phases = cfg.pitch_phases.max(1);
                for k in 0..phases {
                    let anchor = p * k as f64 / phases as f64;
                    grids.extend(table_grid_deg(anchor, p, lo[j], hi[j], n, cfg));
                }
            }
            grids.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.total_cmp(&b.1)));
            grids.dedup_by(|a, b| (a.0 - b.0).abs() < 1e-12 && (a.1 - b.1).abs() < 1e-12);
            for (step, start, knots) in grids {
                out.push(Candidate {
                    kind: CandidateKind::Table { start, step, knots },
                    joint: j,
                });
            }
        }
    }
    out
}

/// The mean temperature of `data` (°C) when every pose has one and they span at least
/// `min_span` kelvin: the reference of a thermal-expansion candidate.
pub fn temperature_reference<const N: usize>(
    data: &[Measurement<f64, N>],
    min_span: f64,
) -> Option<f64> {
    crate::calibration::stats::mean_if_spread(data.iter().map(|m| m.temp_c), |span| {
        span >= min_span
    })
}

/// The joint range `data` cover: lowest and highest reading of each joint (rad).
pub fn coverage<const N: usize>(data: &[Measurement<f64, N>]) -> ([f64; N], [f64; N]) {
    let mut lo = [f64::INFINITY; N];
    let mut hi = [f64::NEG_INFINITY; N];
    for m in data {
        for j in 0..N {
            lo[j] = lo[j].min(m.q[j]);
            hi[j] = hi[j].max(m.q[j]);
        }
    }
    (lo, hi)
}

/// The grid of spacing `step` (rad) through `anchor` (rad), trimmed to the covered range
/// `lo..=hi`: `(step, first knot, knots)`, or `None` when `n` poses are too few for it or it
/// has too few knots.
fn table_grid(
    anchor: f64,
    step: f64,
    lo: f64,
    hi: f64,
    n: usize,
    cfg: &CatalogueConfig,
) -> Option<(f64, f64, usize)> {
    let (k0, knots) = grid_span(anchor, step, lo, hi, n, cfg)?;
    Some((step, anchor + k0 * step, knots))
}

/// [`table_grid`] with the anchor and spacing in degrees; the first knot is computed in degrees
/// (`anchor + k·step`) before it is converted, so that grids on round angles stay round.
fn table_grid_deg(
    anchor_deg: f64,
    step_deg: f64,
    lo: f64,
    hi: f64,
    n: usize,
    cfg: &CatalogueConfig,
) -> Option<(f64, f64, usize)> {
    let step = step_deg.to_radians();
    let (k0, knots) = grid_span(anchor_deg.to_radians(), step, lo, hi, n, cfg)?;
    // `+ 0.0`: a first knot at −0° is written as 0.
    Some((step, (anchor_deg + k0 * step_deg + 0.0).to_radians(), knots))
}

/// Index of the first knot (relative to `anchor`) and the number of knots of the grid of
/// spacing `step` through `anchor` that covers `lo..=hi`, if it is offered.
fn grid_span(
    anchor: f64,
    step: f64,
    lo: f64,
    hi: f64,
    n: usize,
    cfg: &CatalogueConfig,
) -> Option<(f64, usize)> {
    if !(step.is_finite() && step > 0.0 && lo.is_finite() && hi.is_finite() && hi > lo) {
        return None;
    }
    let k0 = ((lo - anchor) / step + 1e-9).floor();
    let k1 = ((hi - anchor) / step - 1e-9).ceil();
    let knots_f = k1 - k0 + 1.0;
    if !(knots_f.is_finite() && knots_f <= crate::MAX_TABLE_KNOTS as f64) {
        return None;
    }
    let knots = (knots_f as usize).max(2);
    let intervals = (knots - 1) as f64;
    (n as f64 / intervals >= cfg.min_poses_per_interval && knots >= cfg.min_knots)
        .then_some((k0, knots))
}

/// The same table grid with its knots shifted by `fraction` of the spacing, trimmed to the
/// covered range `lo..=hi` of its joint (rad; see [`coverage`]) and offered under the same rules
/// as the catalogue's grids. `None` for a candidate that is not a table or a grid not offered.
pub fn shifted(
    c: &Candidate,
    fraction: f64,
    lo: f64,
    hi: f64,
    n: usize,
    cfg: &CatalogueConfig,
) -> Option<Candidate> {
    let CandidateKind::Table { start, step, .. } = c.kind else {
        return None;
    };
    // Degrees rounded to 1e-9: round pitches and phases stay round (10° shifted by 1/8 of it
    // starts at 1.25°, not 1.2499999999999998°).
    let round = |x: f64| (x * 1e9).round() / 1e9;
    let step_deg = round(step.to_degrees());
    let anchor_deg = round(start.to_degrees() + fraction * step_deg);
    let (step, start, knots) = table_grid_deg(anchor_deg, step_deg, lo, hi, n, cfg)?;
    Some(Candidate {
        kind: CandidateKind::Table { start, step, knots },
        joint: c.joint,
    })
}
