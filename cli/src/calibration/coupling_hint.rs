//! The `check` hint for a missing `[[couplings]]` table.
//!
//! FANUC arms (and most palletisers) report J3 from the horizontal: the model angle is
//! `q3 = J3 + J2`. Fed to a robot file without that coupling, such data look like a robot that
//! is tens of millimetres off everywhere. [`detect`] tries the likely couplings, each joint
//! read relative to the one before it (`q_j = r_j ± r_{j−1}`), places each candidate like
//! `check` places the nominal model (point-set registration when the file has no `[base]`),
//! and reports the candidate that explains the data far better than the file as written.
//! A file that states couplings is tried without them and with each candidate instead: a
//! coupling on the wrong joint or with the wrong sign leaves the model hundreds of millimetres
//! off, which `check` alone would only report as a large RMS.

use crate::calibration::{pose_errors, ErrorStats};
use crate::output::numfmt::sig;
use kinecal::{Measurement, Robot};
use serde_json::{json, Value};

/// A candidate must bring the RMS below this fraction of the nominal RMS to be reported.
pub const MAX_FRACTION: f64 = 0.25;
/// ... and gain at least this much (mm): a nominal model already within a millimetre or so of
/// the data has no coupling missing.
pub const MIN_GAIN_MM: f64 = 1.0;
/// Poses used (evenly spread over the file): the hint must stay cheap on large files.
pub const MAX_POSES: usize = 4000;

/// A coupling that explains the data far better than the robot file as written.
#[derive(Clone, Debug, PartialEq)]
pub struct CouplingHint {
    /// 1-based joint whose reading looks relative.
    pub joint: usize,
    /// 1-based joint it looks relative to.
    pub from: usize,
    /// `q_joint = reading_joint + ratio · reading_from`; 0 when the file's couplings are
    /// better removed (then `joint` and `from` are the file's first coupling).
    pub ratio: f64,
    /// The file states couplings, and this candidate replaces them.
    pub replaces_stated: bool,
    /// Every coupling of the candidate, 1-based `(joint, from, ratio)` (empty: none); with
    /// `replaces_stated`, `joint`, `from` and `ratio` are the one it changes.
    pub couplings: Vec<(usize, usize, f64)>,
    /// RMS (mm) of the nominal model with that coupling.
    pub rms_mm: f64,
    /// RMS (mm) of the nominal model as written.
    pub nominal_rms_mm: f64,
}

impl CouplingHint {
    /// The one-line warning `kinecal check` prints.
    pub fn message(&self) -> String {
        let (j, f) = (self.joint, self.from);
        if self.replaces_stated {
            let fits = sig(self.rms_mm, 3);
            let stated = sig(self.nominal_rms_mm, 3);
            return if self.couplings.is_empty() {
                format!(
                    "hint: the robot file's [[couplings]] do not explain the data ({stated} mm); \
                     without them the data fit {fits} mm: remove them, or check each one's \
                     joint, from and ratio"
                )
            } else {
                let list: Vec<String> = self
                    .couplings
                    .iter()
                    .map(|(j, f, r)| format!("joint = {j}, from = {f}, ratio = {r:?}"))
                    .collect();
                format!(
                    "hint: the robot file's [[couplings]] do not explain the data ({stated} mm); \
                     these do ({fits} mm): [[couplings]] {}",
                    list.join("; ")
                )
            };
        }
        let sign = if self.ratio < 0.0 { '-' } else { '+' };
        let what = if j == 3 && f == 2 {
            "J3 looks measured from the horizontal".to_string()
        } else {
            format!("J{j} looks measured relative to J{f}")
        };
        format!(
            "hint: {what} (a coupling q{j} = J{j} {sign} J{f} explains the data: {} mm vs {} mm); add [[couplings]] joint = {j}, from = {f}, ratio = {:?}",
            sig(self.rms_mm, 3),
            sig(self.nominal_rms_mm, 3),
            self.ratio
        )
    }

    /// The JSON object of `check`'s `coupling_hint` key.
    pub fn to_json(&self) -> Value {
        json!({
            "joint": self.joint,
            "from": self.from,
            "ratio": self.ratio,
            "replaces_stated": self.replaces_stated,
            "couplings": self.couplings,
            "rms_mm": self.rms_mm,
            "nominal_rms_mm": self.nominal_rms_mm,
            "message": self.message(),
        })
    }
}

/// At most [`MAX_POSES`] poses of `data`, evenly spread over it, that a hint tries its
/// candidates on; `None` for fewer than 6 (too few to tell a candidate from the file).
pub fn sample<const N: usize>(data: &[Measurement<f64, N>]) -> Option<Vec<Measurement<f64, N>>> {
    if data.len() < 6 {
        return None;
    }
    let stride = data.len().div_ceil(MAX_POSES).max(1);
    Some(data.iter().step_by(stride).copied().collect())
}

/// RMS (mm) of `robot` on `data`, with the base fitted to the data first when `fit` is set
/// and the tool point started from them when `tool` is (an unknown tool).
pub fn rms_placed<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    fit: bool,
    tool: bool,
) -> Option<f64> {
    let mut r = robot.clone();
    crate::compute::tool_start::place(&mut r, data, fit, tool).ok()?;
    let rms = ErrorStats::of(&pose_errors(&r, data))?.rms_mm;
    rms.is_finite().then_some(rms)
}

/// The couplings that explain `data` far better than `robot` does: at most [`MAX_FRACTION`]
/// of its RMS and at least [`MIN_GAIN_MM`] better. Without couplings in `robot`, one coupling
/// (joint `j` read from `j − 1`, ratio ±1) is tried. With couplings, the candidates change the
/// stated set by one step: none at all; one stated coupling removed, its ratio negated, doubled
/// or halved, or moved to another joint pair `j ← j − 1` with its ratio; one replaced by, or one
/// added of, those single ±1 couplings; or one alone. A candidate must beat the one before it
/// by more than [`TIE_MM`] or 1 %: of two sets that fit alike (a coupling of a joint that
/// moves no measured point, as joint 6 with the reflector on its axis) the smaller change wins.
/// `fit_base` = place each model by registration (the file has no `[base]`), as `check` does;
/// `tool_unknown`: the tool point is started from the data for each candidate (the file says
/// it is unknown).
pub fn detect<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    fit_base: bool,
    tool_unknown: bool,
) -> Option<CouplingHint> {
    let sample = sample(data)?;
    let nominal = rms_placed(robot, &sample, fit_base, tool_unknown)?;
    let stated: Vec<Coupling> = robot.couplings().iter().collect();
    let mut uncoupled = robot.clone();
    uncoupled.clear_couplings();
    let mut best: Option<CouplingHint> = None;
    let mut tried: Vec<Vec<Coupling>> = Vec::new();
    for (mut set, changed) in candidate_sets::<N>(&stated) {
        set.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.cmp(&b.1)));
        if tried.contains(&set) {
            continue;
        }
        tried.push(set.clone());
        let mut r = uncoupled.clone();
        if set
            .iter()
            .any(|&(j, f, ratio)| r.set_coupling(j, f, ratio).is_err())
        {
            continue;
        }
        if !stated.is_empty() && same_couplings(&r, robot) {
            continue;
        }
        let Some(rms) = rms_placed(&r, &sample, fit_base, tool_unknown) else {
            continue;
        };
        if best
            .as_ref()
            .is_none_or(|b| rms < b.rms_mm - TIE_MM.max(0.01 * b.rms_mm))
        {
            let (j, f, ratio) = changed;
            best = Some(CouplingHint {
                joint: j + 1,
                from: f + 1,
                ratio,
                replaces_stated: !stated.is_empty(),
                couplings: set.iter().map(|&(j, f, r)| (j + 1, f + 1, r)).collect(),
                rms_mm: rms,
                nominal_rms_mm: nominal,
            });
        }
    }
    best.filter(|b| b.rms_mm <= MAX_FRACTION * nominal && nominal - b.rms_mm >= MIN_GAIN_MM)
}

/// Two candidates whose RMS differ by less than this (mm, or 1 % of the RMS) fit alike.
pub const TIE_MM: f64 = 0.01;

/// One coupling, `(joint, from, ratio)`.
type Coupling = (usize, usize, f64);

/// The coupling sets (0-based) to try against the `stated` ones, each with the coupling it
/// changes (ratio 0: removed), the smallest changes first; see [`detect`].
fn candidate_sets<const N: usize>(stated: &[Coupling]) -> Vec<(Vec<Coupling>, Coupling)> {
    let singles: Vec<Coupling> = (1..N)
        .flat_map(|j| [(j, j - 1, 1.0), (j, j - 1, -1.0)])
        .collect();
    let mut sets: Vec<(Vec<Coupling>, Coupling)> = Vec::new();
    if let Some(&(j, f, _)) = stated.first() {
        sets.push((Vec::new(), (j, f, 0.0)));
    }
    // The stated couplings but the i-th, with `c` instead (`c` returned as the change).
    let instead = |i: usize, c: Option<Coupling>| {
        let mut v: Vec<Coupling> = stated
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != i)
            .map(|(_, c)| *c)
            .collect();
        v.extend(c);
        v
    };
    for (i, &(j, f, r)) in stated.iter().enumerate() {
        sets.push((instead(i, None), (j, f, 0.0)));
        let changes = [-r, 2.0 * r, 0.5 * r]
            .map(|ratio| (j, f, ratio))
            .into_iter()
            .chain((1..N).filter(|&k| k != j).map(|k| (k, k - 1, r)));
        sets.extend(changes.map(|c| (instead(i, Some(c)), c)));
    }
    for i in 0..stated.len() {
        sets.extend(singles.iter().map(|c| (instead(i, Some(*c)), *c)));
    }
    for c in &singles {
        let mut added = stated.to_vec();
        added.push(*c);
        sets.push((added, *c));
    }
    sets.extend(singles.iter().map(|c| (vec![*c], *c)));
    sets
}

/// `a` and `b` read every joint alike (the same couplings, in any order).
fn same_couplings<const N: usize, V: kinecal::ValueStorage>(
    a: &Robot<f64, N, V>,
    b: &Robot<f64, N, V>,
) -> bool {
    let (ca, cb) = (a.couplings(), b.couplings());
    ca.len() == cb.len() && ca.iter().all(|(j, f, r)| cb.get(j) == Some((f, r)))
}
