//! Units at the door: `--length-unit mm|m` and `--angle-unit deg|rad` for every subcommand that
//! reads measurements, sweeps or targets (docs/formats.md), the conversion to the
//! millimetres and degrees used everywhere behind the door, and the plausibility check that
//! refuses a file whose numbers are evidently in other units than the ones assumed.
//!
//! # The plausibility rule
//!
//! Only a unit the user did **not** give is questioned; a unit given explicitly is never
//! second-guessed (with both given there is no check at all). The free units span up to four
//! hypotheses — positions in mm or m × joint readings in deg or rad — and each is scored by how
//! well the nominal model explains the file read that way:
//!
//! * the **fit**: RMS distance (mm) between the measured points and the model's points at the
//!   joint readings. With a known base (`[base]` in the robot file, or the model's base frame
//!   for `compensate` targets, whose seeds must nearly reach them) the points are compared as
//!   they are; without one, after the best rigid placement of the model
//!   ([`crate::compute::registration::fit_rigid`], which fails — "no evidence" — for fewer than three
//!   points or points on a line). Hypotheses are compared by the RMS *relative* to the scale
//!   of the comparison: the reach with a known base; with a fitted base the larger RMS spread
//!   of the measured and of the model points about their centroids, because two tiny clusters
//!   (metres read as millimetres, radians read as degrees) can be placed onto each other
//!   closely whatever they are;
//! * the **reach**: a hypothesis is impossible when its points lie farther from the base than
//!   1.25 × [`Robot::reach`] (known base), or spread farther than 2.5 × the reach from their
//!   centroid (unknown base): no arm of that size can have produced them.
//!
//! The file is refused (exit 2) when the best-fitting possible hypothesis differs from the
//! assumed one and each unit it changes is needed: changing the positions' unit must make the
//! relative fit at least **10×** better, and so must the whole change; changing the joint
//! readings' unit too, with two weaker margins backed by a pattern radians leave behind:
//!
//! * *P1*: every joint reading lies within ±π (or within the joint limits read as radians,
//!   ±2π for a ±360° joint), although every joint's limits span at least 25°. Then radians need
//!   to fit only **2×** better.
//! * *P2*: P1, and at least two joints span 80 % of a turn or more (≥ 1.6π) — read as degrees,
//!   several joints each sweeping more than 5° yet none ever leaving a few degrees of zero is no
//!   coincidence on an arm whose joints can turn far. Then radians must merely fit no worse,
//!   and P2 alone decides when the fit gives no evidence at all (fewer than three poses, with
//!   the base unknown).
//!
//! A claimed change must also leave the assumed units' RMS above 0.1 % of the reach (noise
//! and small model errors are never a reason). Small readings alone are never enough: a sweep of
//! ±2° around zero satisfies P1, but read as radians it becomes a sweep of ±115°, which the model
//! explains far worse than the degrees, so the file is accepted.
//!
//! Columns whose name carries a unit (`rx_deg`, `sx_mm`, `srot_deg`, …) keep that unit; the
//! joint columns `q1`…`qN`, the position `x`, `y`, `z` and the unit-less orientation of targets
//! (`rx`, `ry`, `rz`) follow the flags. Reports and robot files are always in mm and degrees.

use crate::compute::registration::fit_rigid;
use crate::formats::measurements::{Dataset, Record};
use crate::output::numfmt::sig;
use kinecal::forward::ForwardKinematics;
use kinecal::{Frame, Robot};
use nalgebra::Vector3;
use std::f64::consts::PI;

/// Unit of the positions in a file.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum LengthUnit {
    /// Millimetres (default).
    Mm,
    /// Metres.
    M,
}

impl LengthUnit {
    /// Millimetres per unit.
    pub fn mm_per_unit(self) -> f64 {
        match self {
            LengthUnit::Mm => 1.0,
            LengthUnit::M => 1000.0,
        }
    }
    /// The value of `--length-unit`.
    pub fn flag(self) -> &'static str {
        match self {
            LengthUnit::Mm => "mm",
            LengthUnit::M => "m",
        }
    }
    fn word(self) -> &'static str {
        match self {
            LengthUnit::Mm => "millimetres",
            LengthUnit::M => "metres",
        }
    }
}

/// Unit of the joint readings (and unit-less angles) in a file.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum AngleUnit {
    /// Degrees (default).
    Deg,
    /// Radians.
    Rad,
}

impl AngleUnit {
    /// A value in this unit, in degrees.
    pub fn to_deg(self, x: f64) -> f64 {
        match self {
            AngleUnit::Deg => x,
            AngleUnit::Rad => x.to_degrees(),
        }
    }
    /// A value in degrees, in this unit.
    pub fn from_deg(self, deg: f64) -> f64 {
        match self {
            AngleUnit::Deg => deg,
            AngleUnit::Rad => deg.to_radians(),
        }
    }
    /// The value of `--angle-unit`.
    pub fn flag(self) -> &'static str {
        match self {
            AngleUnit::Deg => "deg",
            AngleUnit::Rad => "rad",
        }
    }
    fn word(self) -> &'static str {
        match self {
            AngleUnit::Deg => "degrees",
            AngleUnit::Rad => "radians",
        }
    }
}

/// `--length-unit` and `--angle-unit` (flatten into a subcommand's arguments).
#[derive(clap::Args, Debug, Clone, Default, PartialEq, Eq)]
pub struct UnitArgs {
    /// Unit of the positions x, y, z in the data, sweep or target files [default: mm]. Without
    /// it, a file that looks like metres is refused (exit 2); given, it is never second-guessed.
    /// Reports and robot files are always in mm.
    #[arg(long, value_enum)]
    pub length_unit: Option<LengthUnit>,
    /// Unit of the joint columns q1…qN (and of a target file's rx, ry, rz) [default: deg].
    /// Without it, readings that look like radians are refused (exit 2); given, it is never
    /// second-guessed. Reports and robot files are always in degrees; the joint commands that
    /// `compensate --out` writes are in this unit.
    #[arg(long, value_enum)]
    pub angle_unit: Option<AngleUnit>,
    /// Read the data, sweep or target files in another layout, as the map file M.toml says
    /// (delimiter, decimal comma, header, column names, units, the order of the three angles:
    /// docs/formats.md, "Files in other layouts").
    #[arg(long, value_name = "M.toml")]
    pub map: Option<std::path::PathBuf>,
}

impl UnitArgs {
    /// Both units given explicitly.
    pub fn new(length: LengthUnit, angle: AngleUnit) -> Self {
        Self {
            length_unit: Some(length),
            angle_unit: Some(angle),
            map: None,
        }
    }
    /// The length unit in force (mm unless given).
    pub fn length(&self) -> LengthUnit {
        self.length_unit.unwrap_or(LengthUnit::Mm)
    }
    /// The angle unit in force (deg unless given).
    pub fn angle(&self) -> AngleUnit {
        self.angle_unit.unwrap_or(AngleUnit::Deg)
    }
    /// The units as a report's sources state them.
    pub fn described(&self) -> String {
        format!(
            "positions read as {}, joint readings as {}{}",
            match self.length_unit {
                Some(LengthUnit::M) => "metres (--length-unit m)",
                Some(LengthUnit::Mm) => "millimetres (--length-unit mm)",
                None => "millimetres",
            },
            match self.angle_unit {
                Some(AngleUnit::Rad) => "radians (--angle-unit rad)",
                Some(AngleUnit::Deg) => "degrees (--angle-unit deg)",
                None => "degrees",
            },
            "; the report is in millimetres and degrees"
        )
    }
}

/// What a file holds, for the wording of a refusal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    /// Measured poses (`check`, `identify`, `diagnose`).
    Measurements,
    /// Single-joint sweeps (`frames`).
    Sweeps,
    /// Target points with seed joints (`compensate`).
    Targets,
}

impl FileKind {
    fn positions(self) -> &'static str {
        match self {
            FileKind::Targets => "target points",
            _ => "positions",
        }
    }
    fn readings(self) -> &'static str {
        match self {
            FileKind::Targets => "seed joints",
            _ => "joint readings",
        }
    }
    fn fit(self) -> &'static str {
        match self {
            FileKind::Targets => "model at the seeds misses the targets by RMS",
            _ => "nominal RMS",
        }
    }
}

/// Ratio by which a changed unit must improve the fit (the general margin).
pub const CLEAR_RATIO: f64 = 10.0;
/// The margin for radians when every reading lies within ±π (pattern P1).
pub const WITHIN_PI_RATIO: f64 = 2.0;
/// A joint "spans nearly a turn" (pattern P2) from this span of its readings, rad.
pub const NEAR_TURN_RAD: f64 = 1.6 * PI;
/// Joint limits are "wide" from this span, degrees.
pub const WIDE_LIMITS_DEG: f64 = 25.0;
/// The assumed units' fit must be worse than this fraction of the reach for any refusal.
pub const FLOOR_OF_REACH: f64 = 1e-3;
/// Most poses the unit hypotheses are scored on (evenly spaced over the file). A unit mistake
/// scales every pose, so a few thousand tell as well as a million, and a tracker streaming at
/// 1 kHz would otherwise pay seconds of forward kinematics and base fits before any work.
pub const SCORED_POSES: usize = 4096;

/// At most `most` of `items`, evenly spaced from the first (all of them when there are few).
pub(crate) fn evenly_spaced<T: Clone>(items: &[T], most: usize) -> std::borrow::Cow<'_, [T]> {
    if items.len() <= most {
        return std::borrow::Cow::Borrowed(items);
    }
    let n = items.len();
    std::borrow::Cow::Owned((0..most).map(|k| items[k * n / most].clone()).collect())
}

/// How well one hypothesis explains the file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Score {
    /// `rms_mm`: RMS distance between the points and the (placed) model; `rel`: the same
    /// relative to the scale of the comparison, which is what hypotheses are compared by —
    /// the reach with a known base, and with a fitted base the larger RMS spread of the
    /// measured and of the model points about their centroids (a rigid placement of two small
    /// clusters fits closely whatever units they are in).
    Fit { rms_mm: f64, rel: f64 },
    /// The points cannot come from an arm of the model's reach.
    Impossible,
    /// No evidence (too few points, or points on a line, for a rigid placement).
    Unknown,
}

impl Score {
    /// The RMS distance, mm, of a fit.
    pub fn rms(self) -> Option<f64> {
        match self {
            Score::Fit { rms_mm, .. } => Some(rms_mm),
            _ => None,
        }
    }
    /// The relative error of a fit; infinite for `Impossible`, `None` when unknown.
    pub fn rel(self) -> Option<f64> {
        match self {
            Score::Fit { rel, .. } => Some(rel),
            Score::Impossible => Some(f64::INFINITY),
            Score::Unknown => None,
        }
    }
}

/// A file that looks like other units than the ones assumed.
#[derive(Clone, Debug, PartialEq)]
pub struct Suspicion {
    /// The suspected length unit, when the positions are suspect.
    pub length: Option<LengthUnit>,
    /// The suspected angle unit, when the joint readings are suspect.
    pub angle: Option<AngleUnit>,
    /// The units assumed (the flags or the defaults).
    pub assumed: (LengthUnit, AngleUnit),
    /// Fit in the assumed units.
    pub assumed_score: Score,
    /// Fit in the suspected units.
    pub suspected_score: Score,
    /// Every joint reading lies within ±π (pattern P1), when it backed the angle.
    pub within_pi: bool,
    /// Joints (0-based) spanning nearly a turn (pattern P2), when that backed the angle.
    pub near_turn: Vec<usize>,
    /// Largest joint-limit magnitude, degrees (for the message).
    pub widest_limit_deg: f64,
    /// Largest magnitude of any joint reading, as written (for the message).
    pub largest_reading: f64,
    /// The base was fitted: the message gives the RMS relative to the points' spread too.
    pub base_fitted: bool,
}

impl Suspicion {
    /// The suspected units (unchanged components as assumed).
    pub fn suspected(&self) -> (LengthUnit, AngleUnit) {
        (
            self.length.unwrap_or(self.assumed.0),
            self.angle.unwrap_or(self.assumed.1),
        )
    }

    /// The one-line reason: file, suspected unit, evidence, flag to pass.
    pub fn message(&self, origin: &str, kind: FileKind) -> String {
        type Hyp = fn(LengthUnit, AngleUnit) -> String;
        let (what, hyp): (String, Hyp) = match (self.length, self.angle) {
            (Some(l), Some(a)) => (
                format!(
                    "{} look like {} and {} like {}",
                    kind.positions(),
                    l.word(),
                    kind.readings(),
                    a.word()
                ),
                |l: LengthUnit, a: AngleUnit| format!("{} and {}", l.word(), a.word()),
            ),
            (Some(l), None) => (
                format!("{} look like {}", kind.positions(), l.word()),
                |l: LengthUnit, _: AngleUnit| l.word().to_string(),
            ),
            (None, Some(a)) => (
                format!("{} look like {}", kind.readings(), a.word()),
                |_: LengthUnit, a: AngleUnit| a.word().to_string(),
            ),
            (None, None) => return format!("{origin}: units look plausible"),
        };
        let (sl, sa) = self.suspected();
        let (al, aa) = self.assumed;
        let mut evidence = Vec::new();
        // With a fitted base the relative figure is the evidence: "12 mm = 98 % of the spread".
        let mut of_spread = " of the spread";
        let mut fig = |s: Score| match (s, self.base_fitted) {
            (Score::Fit { rms_mm, rel }, true) => {
                let t = format!(
                    "{} mm = {} %{of_spread}",
                    sig(rms_mm, 2),
                    sig(100.0 * rel, 2)
                );
                of_spread = "";
                t
            }
            (s, _) => format!("{} mm", sig(s.rms().unwrap_or(f64::NAN), 2)),
        };
        if let (Some(_), Some(_)) = (self.assumed_score.rms(), self.suspected_score.rms()) {
            evidence.push(format!(
                "{} {} as {}, {} as {}",
                kind.fit(),
                fig(self.assumed_score),
                hyp(al, aa),
                fig(self.suspected_score),
                hyp(sl, sa)
            ));
        } else if self.suspected_score.rms().is_some() {
            evidence.push(format!(
                "{} {} as {}, no fit possible as {}",
                kind.fit(),
                fig(self.suspected_score),
                hyp(sl, sa),
                hyp(al, aa)
            ));
        }
        if self.within_pi {
            let bound = if self.largest_reading <= PI * (1.0 + 1e-12) {
                "±π".to_string()
            } else {
                format!("±{}", sig(self.largest_reading, 3))
            };
            let mut s = format!(
                "every reading lies within {bound} although the limits allow ±{}°",
                sig(self.widest_limit_deg, 3)
            );
            if !self.near_turn.is_empty() {
                let j: Vec<String> = self
                    .near_turn
                    .iter()
                    .map(|j| format!("q{}", j + 1))
                    .collect();
                s.push_str(&format!(", and {} each span most of a turn", j.join(", ")));
            }
            evidence.push(s);
        }
        let mut pass = Vec::new();
        let mut keep = Vec::new();
        if let Some(l) = self.length {
            pass.push(format!("--length-unit {}", l.flag()));
            keep.push(format!("--length-unit {}", al.flag()));
        }
        if let Some(a) = self.angle {
            pass.push(format!("--angle-unit {}", a.flag()));
            keep.push(format!("--angle-unit {}", aa.flag()));
        }
        format!(
            "{origin}: {what} ({}): pass {} (or {} to keep them)",
            evidence.join("; "),
            pass.join(" "),
            keep.join(" ")
        )
    }
}

/// Scores of every hypothesis the free units allow.
struct Scores {
    list: Vec<((LengthUnit, AngleUnit), Score)>,
}

impl Scores {
    fn get(&self, l: LengthUnit, a: AngleUnit) -> Score {
        self.list
            .iter()
            .find(|(h, _)| *h == (l, a))
            .map_or(Score::Unknown, |(_, s)| *s)
    }
}

/// RMS distance of points from their centroid.
fn spread(pts: &[Vector3<f64>]) -> f64 {
    let c = pts.iter().sum::<Vector3<f64>>() / pts.len() as f64;
    (pts.iter().map(|p| (p - c).norm_squared()).sum::<f64>() / pts.len() as f64).sqrt()
}

/// How well `nominal` explains `records` (raw file values) read as `(l, a)`.
fn score<const N: usize, V: kinecal::ValueStorage>(
    records: &[Record<N>],
    placed: &Robot<f64, N, V>,
    base_known: bool,
    model: &[Vector3<f64>],
    l: LengthUnit,
) -> Score {
    let k = l.mm_per_unit();
    let pts: Vec<Vector3<f64>> = records
        .iter()
        .map(|r| Vector3::from(r.xyz_mm) * k)
        .collect();
    if pts.iter().any(|p| !p.iter().all(|c| c.is_finite())) {
        return Score::Unknown;
    }
    let reach = placed.reach();
    if base_known {
        let o = placed.base().o;
        let far = pts.iter().map(|p| (p - o).norm()).fold(0.0, f64::max);
        if far > 1.25 * reach + 1.0 {
            return Score::Impossible;
        }
        let ss: f64 = pts
            .iter()
            .zip(model)
            .map(|(p, m)| (p - m).norm_squared())
            .sum();
        let rms_mm = (ss / pts.len() as f64).sqrt();
        return Score::Fit {
            rms_mm,
            rel: rms_mm / reach,
        };
    }
    let c = pts.iter().sum::<Vector3<f64>>() / pts.len() as f64;
    let far = pts.iter().map(|p| (p - c).norm()).fold(0.0, f64::max);
    if far > 2.5 * reach + 1.0 {
        return Score::Impossible;
    }
    match fit_rigid(model, &pts) {
        Ok(f) => {
            let ss: f64 = pts
                .iter()
                .zip(model)
                .map(|(p, m)| (f.point(m) - p).norm_squared())
                .sum();
            let rms_mm = (ss / pts.len() as f64).sqrt();
            let scale = spread(&pts).max(spread(model));
            if scale > 0.0 {
                Score::Fit {
                    rms_mm,
                    rel: rms_mm / scale,
                }
            } else {
                Score::Unknown
            }
        }
        Err(_) => Score::Unknown,
    }
}

/// Decides whether `records` (raw file values: `q_deg` and `xyz_mm` hold the numbers as
/// written) look like other units than the ones `units` assumes, for the model `nominal`
/// (its base used when `base_known`, otherwise fitted). `None` = plausible, or no free unit.
/// The rule is in the module documentation.
pub fn suspect<const N: usize, V: kinecal::ValueStorage>(
    records: &[Record<N>],
    units: &UnitArgs,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
) -> Option<Suspicion> {
    use AngleUnit::{Deg, Rad};
    use LengthUnit::{Mm, M};
    let lengths: Vec<LengthUnit> = units.length_unit.map_or(vec![Mm, M], |u| vec![u]);
    let angles: Vec<AngleUnit> = units.angle_unit.map_or(vec![Deg, Rad], |u| vec![u]);
    if (lengths.len() == 1 && angles.len() == 1) || records.is_empty() {
        return None;
    }
    let assumed = (units.length(), units.angle());
    let mut placed = nominal.clone();
    if !base_known {
        placed.set_base(Frame::identity()).ok()?;
    }
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut list = Vec::new();
    let scored = evenly_spaced(records, SCORED_POSES);
    for &a in &angles {
        let model: Vec<Vector3<f64>> = scored
            .iter()
            .map(|r| fk.compute(&placed, &r.q_deg.map(|x| a.to_deg(x).to_radians())))
            .collect();
        let model_ok = model.iter().all(|p| p.iter().all(|c| c.is_finite()));
        for &l in &lengths {
            let s = if model_ok {
                score(&scored, &placed, base_known, &model, l)
            } else {
                Score::Unknown
            };
            list.push(((l, a), s));
        }
    }
    let scores = Scores { list };

    // The radian patterns (only when the angle unit is free).
    let joints = nominal.joints();
    let widest_limit_deg = joints
        .iter()
        .map(|j| j.lower.abs().max(j.upper.abs()).to_degrees())
        .fold(0.0, f64::max);
    let p1 = angles.len() == 2
        && joints
            .iter()
            .all(|j| (j.upper - j.lower).to_degrees() >= WIDE_LIMITS_DEG)
        && records.iter().all(|r| {
            r.q_deg
                .iter()
                .zip(joints)
                .all(|(q, j)| q.abs() <= PI * (1.0 + 1e-12) || (*q >= j.lower && *q <= j.upper))
        });
    let near_turn: Vec<usize> = if p1 {
        (0..N)
            .filter(|&j| {
                let (lo, hi) = records
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |m, r| {
                        (m.0.min(r.q_deg[j]), m.1.max(r.q_deg[j]))
                    });
                hi - lo >= NEAR_TURN_RAD
            })
            .collect()
    } else {
        Vec::new()
    };
    let p2 = p1 && near_turn.len() >= 2;

    // Radians clearly better than degrees at length `l`.
    let rad_clear = |l: LengthUnit| -> bool {
        match (scores.get(l, Rad), scores.get(l, Deg)) {
            (Score::Fit { rel: rr, .. }, d) => match d.rel() {
                Some(rd) => {
                    rr * CLEAR_RATIO <= rd || (p1 && rr * WITHIN_PI_RATIO <= rd) || (p2 && rr <= rd)
                }
                None => p2,
            },
            (Score::Unknown, Score::Unknown) => p2,
            _ => false,
        }
    };
    // Metres clearly better than millimetres at angle `a`.
    let m_clear = |a: AngleUnit| -> bool {
        match (scores.get(M, a).rel(), scores.get(Mm, a).rel()) {
            (Some(rm), Some(rmm)) => rm * CLEAR_RATIO <= rmm,
            _ => false,
        }
    };

    // The best hypothesis with evidence; without any, the patterns alone (angles only).
    let best = scores
        .list
        .iter()
        .filter_map(|(h, s)| match s {
            Score::Fit { rel, .. } => Some((*h, *rel)),
            _ => None,
        })
        .min_by(|x, y| x.1.total_cmp(&y.1))
        .map(|(h, _)| h)
        .unwrap_or((assumed.0, if p2 { Rad } else { assumed.1 }));
    let length = (best.0 != assumed.0 && best.0 == M && m_clear(best.1)).then_some(M);
    // The angle is judged at the length that will be claimed.
    let angle = (best.1 != assumed.1 && best.1 == Rad && rad_clear(length.unwrap_or(assumed.0)))
        .then_some(Rad);
    let mut s = Suspicion {
        length,
        angle,
        assumed,
        assumed_score: scores.get(assumed.0, assumed.1),
        suspected_score: Score::Unknown,
        within_pi: false,
        near_turn: Vec::new(),
        widest_limit_deg,
        largest_reading: records
            .iter()
            .flat_map(|r| r.q_deg)
            .fold(0.0, |m: f64, q| m.max(q.abs())),
        base_fitted: !base_known,
    };
    let claimed = s.suspected();
    if claimed == assumed {
        return None;
    }
    s.suspected_score = scores.get(claimed.0, claimed.1);
    // The claimed units must beat the assumed ones as a whole, by the margin of what changed.
    let margin = if length.is_some() {
        CLEAR_RATIO
    } else if p2 {
        1.0
    } else if p1 {
        WITHIN_PI_RATIO
    } else {
        CLEAR_RATIO
    };
    match (s.assumed_score.rel(), s.suspected_score.rel()) {
        (Some(r0), Some(r1)) => {
            let floor = FLOOR_OF_REACH * nominal.reach();
            let abs0 = s.assumed_score.rms().unwrap_or(f64::INFINITY);
            if r1 * margin > r0 || abs0 < floor {
                return None;
            }
        }
        (_, None) if length.is_some() => return None,
        _ => {}
    }
    if angle.is_some() && p1 {
        s.within_pi = true;
        if p2 {
            s.near_turn = near_turn;
        }
    }
    Some(s)
}

/// What the scale `s` of measured points against a robot's (measured ≈ s × model) says about
/// their length unit, as the rest of a sentence: a unit slip named when `s` lies within 10 % of
/// its factor (inches, centimetres or metres read as millimetres, millimetres read as metres),
/// else a robot file of another size.
pub fn scale_cause(s: f64) -> String {
    let slips: [(f64, &str); 4] = [
        (
            1.0 / 25.4,
            "the points look given in inches (× 25.4 gives millimetres): convert x, y, z to \
             millimetres",
        ),
        (
            0.1,
            "the points look given in centimetres (× 10 gives millimetres): convert x, y, z to \
             millimetres",
        ),
        (
            0.001,
            "the points look given in metres: give --length-unit m, or length = \"m\" in the \
             --map file",
        ),
        (
            1000.0,
            "the points look given in millimetres but read as metres: drop --length-unit m (or \
             the --map file's length = \"m\")",
        ),
    ];
    slips
        .iter()
        .find(|(f, _)| (s / f - 1.0).abs() <= 0.1)
        .map(|(_, why)| why.to_string())
        .unwrap_or_else(|| {
            "no length unit explains that scale: the robot file may describe another robot \
             (check its link lengths) or the points are not the tool's"
                .to_string()
        })
}

/// Millimetres of a length in metres by moving the decimal point of its shortest decimal
/// text: `0.38397123` m is exactly the number `383.97123` would be, so a file in metres gives
/// the very numbers of the same file in millimetres (`x * 1000.0` can be one ulp off).
pub fn mm_of_m(x: f64) -> f64 {
    if !x.is_finite() || x == 0.0 {
        return x * 1000.0;
    }
    let text = format!("{x:e}");
    text.split_once('e')
        .and_then(|(mantissa, e)| {
            let e: i32 = e.parse().ok()?;
            format!("{mantissa}e{}", e + 3).parse().ok()
        })
        .unwrap_or(x * 1000.0)
}

/// Degrees of an angle in radians that convert back to exactly the same radians
/// ([`crate::formats::robot_file::deg_exact`]): the model sees the very values of the file.
pub fn deg_of_rad(x: f64) -> f64 {
    if x.is_finite() {
        crate::formats::robot_file::deg_exact(x)
    } else {
        x.to_degrees()
    }
}

/// Converts raw file values (in `units`) to millimetres and degrees, in place.
pub fn convert<const N: usize>(ds: &mut Dataset<N>, units: &UnitArgs) {
    let (l, a) = (units.length(), units.angle());
    if l != LengthUnit::M && a != AngleUnit::Rad {
        // Already millimetres and degrees: nothing to visit.
        return;
    }
    // Several reflectors' points (`x_NAME`…) are positions like `x`, `y`, `z`; columns named
    // with their unit (`sx_mm`, `rx_deg`) are always in it.
    let named: Vec<usize> = ds
        .extra_names
        .iter()
        .enumerate()
        .filter(|(_, n)| ["x_", "y_", "z_"].iter().any(|p| n.starts_with(p)))
        .map(|(k, _)| k)
        .collect();
    for r in &mut ds.records {
        if l == LengthUnit::M {
            for &k in &named {
                if let Some(v) = r.extra.get_mut(k) {
                    *v = mm_of_m(*v);
                }
            }
        }
        if a == AngleUnit::Rad {
            r.q_deg = r.q_deg.map(deg_of_rad);
        }
        if l == LengthUnit::M {
            r.xyz_mm = r.xyz_mm.map(mm_of_m);
        }
    }
}

/// The plausibility check and conversion of [`crate::formats::loading::load_as`] for records
/// already read (or made in memory, e.g. from arrays): refused (exit 2) naming `origin` when
/// the units look wrong; the records come back in millimetres and degrees.
pub fn accept<const N: usize, V: kinecal::ValueStorage>(
    mut ds: Dataset<N>,
    origin: &str,
    units: &UnitArgs,
    nominal: &Robot<f64, N, V>,
    base_known: bool,
    kind: FileKind,
) -> anyhow::Result<Dataset<N>> {
    if let Some(s) = suspect(&ds.records, units, nominal, base_known) {
        return Err(crate::refused(s.message(origin, kind)));
    }
    convert(&mut ds, units);
    Ok(ds)
}
