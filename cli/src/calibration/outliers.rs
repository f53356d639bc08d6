//! Gross outliers: a row whose measured point lies far beyond the fitted model's typical error
//! (a reflector the tracker lost and found on something else, a row in another unit, joint
//! readings of another pose). One such row among hundreds pulls every parameter of a
//! least-squares fit: 600 UR10 rows with one `x` 100 mm off "calibrated" to 4.1 mm RMS with
//! exit 0, and `diagnose` took the 4.1 mm for the noise floor and named nothing. `identify`
//! and `diagnose` report such a fit as no calibration (exit 3), naming the rows to delete or
//! measure again.
//!
//! A point is a gross outlier when it lies more than [`MEDIAN_FACTOR`] times the median
//! distance from the fitted model, and more than [`MIN_MM`]. On the real UR10 series (geometric
//! fit, `kinecal identify --residuals`) the largest distance is 3.1–5.4 times the median
//! (series A, B, C, D); for Gaussian noise alone it is about 3.5 times the median in 10,000
//! points.
//!
//! A point as far beyond the median but under [`MIN_MM`] (and over [`STRAY_MIN_MM`]) is a
//! *stray*: three rows 0.8 mm off among 300 with a median of 0.03 mm (40 σ of the tracker)
//! passed without a word and doubled the noise floor `diagnose` reported. A few strays are warned about, naming their lines
//! ([`Outliers::strays`]); the fit stands, since a point under a millimetre may also be a
//! local effect the model lacks.
//!
//! Constraint sessions ([`crate::constraints::outliers`]) apply the same rule to each row's
//! error against its socket or plane and to each distance group's length error.

use crate::formats::observations::Pose;
use crate::output::numfmt::sig;
use kinecal::{ForwardKinematics, Measurement, Robot, ValueStorage};

/// How many times the median distance a point must lie from the model to be a gross outlier.
pub const MEDIAN_FACTOR: f64 = 10.0;
/// How far (mm) a point must lie from the model at least to be a gross outlier (data with
/// micrometre errors are not searched for millimetre-sized faults).
pub const MIN_MM: f64 = 1.0;
/// How far (mm) a stray must lie from the model at least: closer, a point's error is no
/// misreading a user could find in the file (and simulated data without noise are not searched).
pub const STRAY_MIN_MM: f64 = 0.1;

/// A point far from the model: its line in the data file and its distance (mm).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Outlier {
    pub line: u32,
    pub distance_mm: f64,
    /// The distance in units of the rows' typical σ: `distance_mm` times the median weight
    /// over the point's (equal to it for rows of equal weight). A row whose stated σ is large
    /// is judged by it.
    #[serde(skip)]
    pub scaled_mm: f64,
}

/// The gross outliers of a fit: one pass over its points, then read by the callers in the
/// order their reasons come ([`Outliers::few`] first, [`Outliers::reason`] last).
#[derive(Clone, Debug, PartialEq)]
pub struct Outliers {
    /// Farthest first, one per row.
    pub far: Vec<Outlier>,
    /// Beyond [`MEDIAN_FACTOR`] times the median but under [`MIN_MM`], farthest first.
    pub stray: Vec<Outlier>,
    /// The median distance over every point (mm).
    pub median_mm: f64,
    /// Rows searched.
    pub rows: usize,
    /// What such a point may be, as the end of "a wrong reading (…)".
    pub causes: String,
}

/// The causes of a wrong tracker reading.
pub const TRACKER_CAUSES: &str = "a lost reflector, a row in another unit or of another pose";

/// A few strays of a fit ([`Outliers::strays`]): JSON `stray_points`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Strays {
    /// Farthest first.
    pub rows: Vec<Outlier>,
    /// The median distance over every point (mm).
    pub median_mm: f64,
    /// What such a point may be ([`Outliers::causes`]).
    #[serde(skip)]
    pub causes: String,
}

impl Strays {
    /// The warning, without a leading "warning: ".
    pub fn warning(&self) -> String {
        let causes = &self.causes;
        format!(
            "{} point(s) lie far from the model against the others ({}; the median is {} mm), \
             though under the {MIN_MM} mm that refuses a fit: wrong readings ({causes}), or an \
             effect the model misses near those poses (kinecal diagnose); check those rows, and \
             delete or measure them again if they are wrong",
            self.rows.len(),
            named(&self.rows, self.median_mm),
            sig(self.median_mm, 3)
        )
    }
}

/// The first three of `rows` with their distances, and how many more, in words.
fn named(rows: &[Outlier], median_mm: f64) -> String {
    let first: Vec<String> = rows
        .iter()
        .take(3)
        .map(|o| {
            format!(
                "line {} {} mm, {}× the median",
                o.line,
                sig(o.distance_mm, 3),
                sig(o.scaled_mm / median_mm.max(f64::MIN_POSITIVE), 2)
            )
        })
        .collect();
    match rows.len() {
        n if n > first.len() => format!("{}, {} more", first.join("; "), n - first.len()),
        _ => first.join("; "),
    }
}

/// The gross outliers among the observations of `sets` (each its poses and the observation list
/// they index) by `model`.
pub fn find<const N: usize, V: ValueStorage>(
    model: &Robot<f64, N, V>,
    sets: &[(&[Pose], &[Measurement<f64, N>])],
) -> Outliers {
    let mut fk = ForwardKinematics::new();
    let mut all: Vec<Outlier> = Vec::new();
    for (poses, obs) in sets {
        // A set's weights are of one kind (stated σ, error floors or none): each point is
        // judged against the set's median weight.
        let weights: Vec<f64> = obs.iter().map(|m| m.weight.mean()).collect();
        let typical = crate::calibration::stats::quantile(&weights, 0.5);
        for p in poses.iter() {
            for m in p.of(obs) {
                let Some(q) = fk.compute_at(model, &m.q, m.tool as usize, m.conditions()) else {
                    continue;
                };
                let e = m.point - q;
                let d = e.norm();
                let scaled = if typical > 0.0 && typical.is_finite() {
                    e.component_mul(&m.weight).norm() / typical
                } else {
                    d
                };
                if d.is_finite() && scaled.is_finite() {
                    all.push(Outlier {
                        line: p.line,
                        distance_mm: d,
                        scaled_mm: scaled,
                    });
                }
            }
        }
    }
    let rows = sets.iter().map(|(p, _)| p.len()).sum();
    of_distances(all, rows, TRACKER_CAUSES.to_string())
}

/// The gross outliers and strays among the points `all` (each its row's line and its distance
/// from the model, mm, as it is and scaled by its σ) of `rows` rows: beyond [`MEDIAN_FACTOR`]
/// times the median in scaled distance, then sorted by their distance in mm.
pub fn of_distances(all: Vec<Outlier>, rows: usize, causes: String) -> Outliers {
    let mut d: Vec<f64> = all.iter().map(|o| o.scaled_mm).collect();
    if d.is_empty() {
        return Outliers {
            far: Vec::new(),
            stray: Vec::new(),
            median_mm: 0.0,
            rows,
            causes,
        };
    }
    let mid = d.len() / 2;
    let (_, &mut median_mm, _) = d.select_nth_unstable_by(mid, f64::total_cmp);
    let limit = MEDIAN_FACTOR * median_mm;
    let mut beyond: Vec<Outlier> = all.into_iter().filter(|o| o.scaled_mm > limit).collect();
    beyond.sort_by(|a, b| b.distance_mm.total_cmp(&a.distance_mm));
    // One row of several reflectors is one wrong reading: named once, at its farthest.
    let mut seen = std::collections::HashSet::new();
    beyond.retain(|o| seen.insert(o.line));
    let (far, mut stray): (Vec<Outlier>, Vec<Outlier>) =
        beyond.into_iter().partition(|o| o.distance_mm > MIN_MM);
    stray.retain(|o| o.distance_mm > STRAY_MIN_MM);
    Outliers {
        far,
        stray,
        median_mm,
        rows,
        causes,
    }
}

/// How many outliers are "a few": at most this share of the points (and at least 3). More
/// than that is no stray reading but a file the robot file does not describe, which the
/// convention and unit checks name better ([`crate::calibration::arm_size`]).
pub const FEW: f64 = 0.02;

impl Outliers {
    /// [`Self::reason`] when the outliers are a few ([`FEW`]), else `None`.
    pub fn few(&self) -> Option<String> {
        if !self.is_few(self.far.len()) {
            return None;
        }
        self.reason()
    }

    /// [`Self::few`] with the rows held out of the fit (`held_out`: their lines) told apart.
    pub fn few_given(&self, held_out: &[u32]) -> Option<String> {
        if !self.is_few(self.far.len()) {
            return None;
        }
        self.reason_given(held_out)
    }

    /// [`Self::reason`], unless every far point is on a row held out of the fit (`held_out`:
    /// their lines): such rows pulled no parameter, so deleting them is no fix; they are wrong
    /// readings or poses measured after something changed, and are named so.
    pub fn reason_given(&self, held_out: &[u32]) -> Option<String> {
        if self.far.is_empty() || !self.far.iter().all(|o| held_out.contains(&o.line)) {
            return self.reason();
        }
        Some(format!(
            "leaves {} held-out point(s) far from the model fitted to the other poses ({}; the \
             median {} mm): wrong readings, or poses measured after the set-up or the robot \
             changed (their rows together, from one line on); check those rows against the \
             identified ones (--residuals) before deleting any",
            self.far.len(),
            named(&self.far, self.median_mm),
            sig(self.median_mm, 3),
        ))
    }

    /// Whether `n` points are "a few" of [`Self::rows`] ([`FEW`]).
    fn is_few(&self, n: usize) -> bool {
        n as f64 <= (FEW * self.rows as f64).max(3.0)
    }

    /// The strays when there are a few of them and no gross outlier (which refuses the fit
    /// first); many are no stray readings but a model that misses something, which the
    /// fit's figures and `diagnose` show.
    pub fn strays(&self) -> Option<Strays> {
        (self.far.is_empty() && !self.stray.is_empty() && self.is_few(self.stray.len())).then(
            || Strays {
                rows: self.stray.clone(),
                median_mm: self.median_mm,
                causes: self.causes.clone(),
            },
        )
    }

    /// The gross outliers named: the first three lines with their distances (and how many
    /// times the median), and how many more.
    pub fn far_named(&self) -> String {
        named(&self.far, self.median_mm)
    }

    /// Why the fit is no calibration because of gross outliers, as the rest of a sentence
    /// that starts "the fit", or `None` when there are none.
    pub fn reason(&self) -> Option<String> {
        let first = self.far.first()?;
        let more = match self.far.len() {
            n if n > 3 => format!(", {} more", n - 3),
            _ => String::new(),
        };
        let named: Vec<String> = self
            .far
            .iter()
            .take(3)
            .map(|o| format!("line {} {} mm", o.line, sig(o.distance_mm, 3)))
            .collect();
        Some(format!(
            "leaves {} point(s) far from the model ({}{more}; {}× the median {} mm): a wrong \
             reading ({}) pulls every parameter; delete those rows or measure them again",
            self.far.len(),
            named.join(", "),
            sig(first.scaled_mm / self.median_mm.max(f64::MIN_POSITIVE), 2),
            sig(self.median_mm, 3),
            self.causes
        ))
    }
}
