//! Acceptance on held-out poses: a calibration is judged on poses it was not fitted to. When
//! the calibrated model predicts them worse than the model the fit started from, the result is
//! not a calibration (`held_out_worse`, exit 3); when it predicts them much worse than the
//! identification poses, a warning. Either way the likely reason is named in one line: held-out
//! poses outside the joint ranges the identification poses cover (extrapolation), or
//! parameters the data barely determine (1-σ beyond a manufacturing tolerance).

use kinecal::Measurement;
use serde::Serialize;

/// Held-out RMS above this many times the identification RMS draws a warning.
pub const MUCH_WORSE: f64 = 2.0;

/// Held-out RMS differences below this (mm, a thousandth of a micrometre) are rounding, not
/// a worse model: noise-free simulated data end at nanometres either way.
pub const NO_DIFFERENCE_MM: f64 = 1e-6;

/// The note when nothing was held out: a fit judged only on what it was fitted to can predict
/// new poses worse than the model it started from (a geometry fitted to poses that do not
/// span the workspace does) and nothing would say so.
pub const NOT_JUDGED: &str = "note: nothing was held out, so nothing checks that the model \
    predicts data it was not fitted to better than the one it started from: --holdout 0.2 \
    (or --validate FILE) judges it on unseen data";

/// A `--validate` file the calibrated model misses by more than this many times the starting
/// model's RMS on the identification poses, and by [`FOREIGN_MARGIN_MM`] more than the
/// calibrated model's there, is not of the same set-up or layout.
pub const FOREIGN_RATIO: f64 = 10.0;
/// See [`FOREIGN_RATIO`] (mm): a robot's own errors are a few millimetres anywhere in its
/// workspace; a length unit, a column order or a moved tracker costs tens to hundreds.
pub const FOREIGN_MARGIN_MM: f64 = 10.0;

/// Refuses held-out poses of a `--validate` file (`name`) that the calibrated model misses far
/// more than the robot file missed the identification poses (`before`, `after`: the starting
/// and the calibrated model's residuals on both): positions in metres read as millimetres,
/// joints in another order, or another session whose tracker stood elsewhere. Judged there,
/// any model "predicts the held-out poses better" by a hair at hundreds of millimetres, which
/// says nothing about the calibration. The calibrated model is judged, not the starting one: a
/// start placed on a few poses may miss the rest by far more (a tool guessed 60 mm off, 80
/// poses facing one way: 28.6 mm), and the calibration still predict them (0.60 mm).
pub fn refuse_foreign_held_out(
    (before, after): (
        &crate::calibration::Residuals,
        &crate::calibration::Residuals,
    ),
    name: &str,
) -> anyhow::Result<()> {
    let Some(held) = after.validation_rms_mm else {
        return Ok(());
    };
    let (start, fitted) = (before.identification_rms_mm, after.identification_rms_mm);
    refuse_foreign_rms((start, fitted, held), name)
}

/// [`refuse_foreign_held_out`] on the figures alone: the starting and the calibrated model's
/// RMS on the identification poses, the calibrated model's on the `--validate` file's (mm).
pub fn refuse_foreign_rms(
    (start, fitted, held): (f64, f64, f64),
    name: &str,
) -> anyhow::Result<()> {
    use crate::output::numfmt::sig;
    if held > FOREIGN_RATIO * start && held > fitted + FOREIGN_MARGIN_MM {
        crate::refuse!(
            "--validate {name}: the calibrated model misses its poses by {} mm RMS against {} \
             mm on the identification poses ({} mm before calibration): they are not of this \
             set-up, or in another unit or column layout (the unit flags and --map apply to \
             both files); give held-out poses of this session in the data file's layout, or \
             judge a model on another session with kinecal validate",
            sig(held, 4),
            sig(fitted, 4),
            sig(start, 4)
        );
    }
    Ok(())
}

/// The verdict on the held-out poses.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Acceptance {
    /// The calibrated model predicts the held-out poses worse than the starting model.
    pub held_out_worse: bool,
    /// Held-out RMS over identification RMS of the calibrated model.
    pub held_out_ratio: f64,
    /// The verdict and its likely reasons in one line; `None` when the result holds.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub message: Option<String>,
    /// Joints along which held-out poses lie outside the identification poses' range.
    pub outside_ranges: Vec<JointRangeGap>,
    /// Parameters the data barely determine (1-σ from the data beyond the tolerance).
    pub weak_parameters: Vec<String>,
    /// The model is not determined across the joint ranges (poses that barely move some
    /// joints: [`crate::calibration::extrapolation`]); what `held_out_worse` then says.
    #[serde(skip_serializing_if = "std::ops::Not::not")]
    pub extrapolated: bool,
}

/// A joint whose held-out readings leave the identification poses' range.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct JointRangeGap {
    /// 1-based.
    pub joint: usize,
    /// Range of the identification poses, degrees.
    pub identified_deg: [f64; 2],
    /// Range of the held-out poses, degrees.
    pub held_out_deg: [f64; 2],
    /// Share of the held-out poses outside the identification range.
    pub outside_share: f64,
}

/// Every joint's range (rad, lowest and highest reading) over `data`, in one pass over the
/// poses (many, each a few hundred bytes), in parts on several threads (minima and maxima do
/// not depend on the order).
pub fn joint_ranges<const N: usize>(data: &[Measurement<f64, N>]) -> [(f64, f64); N] {
    let parts = crate::compute::parallel::map_parts(data, |part| {
        part.iter()
            .fold([(f64::INFINITY, f64::NEG_INFINITY); N], |mut r, m| {
                for (r, q) in r.iter_mut().zip(&m.q) {
                    *r = (r.0.min(*q), r.1.max(*q));
                }
                r
            })
    });
    parts
        .into_iter()
        .fold([(f64::INFINITY, f64::NEG_INFINITY); N], |mut r, p| {
            for (r, q) in r.iter_mut().zip(p) {
                *r = (r.0.min(q.0), r.1.max(q.1));
            }
            r
        })
}

/// A joint that moves less than this (degrees, highest less lowest reading) in the
/// identification poses is calibrated at those readings only.
pub const NARROW_DEG: f64 = 30.0;

/// The warning for joints that barely move in the identification poses `ident` (under
/// [`NARROW_DEG`]), or `None`: the model is calibrated there only, and a later session that
/// moves them is extrapolated (a 7-joint arm identified with joint 3 at 0° is 0.49 mm off over
/// the workspace, and `validate` there says the robot changed).
pub fn narrow_joints<const N: usize>(ident: &[Measurement<f64, N>]) -> Option<String> {
    let narrow = narrow_list(ident);
    (!narrow.is_empty()).then(|| {
        format!(
            "the identification poses move {} less than {NARROW_DEG}°: the model is \
             calibrated at those readings only, and poses elsewhere are extrapolated (judged \
             there, it looks like a changed robot); measure poses across each joint's range \
             (kinecal plan)",
            narrow.join(", ")
        )
    })
}

/// The joints that move less than [`NARROW_DEG`] in `ident`, each as "joint j lo…hi°".
pub fn narrow_list<const N: usize>(ident: &[Measurement<f64, N>]) -> Vec<String> {
    if ident.is_empty() {
        return Vec::new();
    }
    joint_ranges(ident)
        .iter()
        .enumerate()
        .filter(|(_, (lo, hi))| (hi - lo).to_degrees() < NARROW_DEG)
        .map(|(j, (lo, hi))| {
            format!(
                "joint {} {:.1}…{:.1}°",
                j + 1,
                lo.to_degrees(),
                hi.to_degrees()
            )
        })
        .collect()
}

/// Joints along which more than a few held-out poses lie clearly outside the range the
/// identification poses cover (by more than 2 % of that range or 1°, whichever is more).
pub fn outside_ranges<const N: usize>(
    ident: &[Measurement<f64, N>],
    valid: &[Measurement<f64, N>],
) -> Vec<JointRangeGap> {
    let ranges = joint_ranges::<N>;
    let identified = ranges(ident);
    let margins = identified.map(|(lo, hi)| (0.02 * (hi - lo)).max(1f64.to_radians()));
    let outside = crate::compute::parallel::map_parts(valid, |part| {
        let mut outside = [0usize; N];
        for m in part {
            for (j, n) in outside.iter_mut().enumerate() {
                let (lo, hi) = identified[j];
                *n += usize::from(m.q[j] < lo - margins[j] || m.q[j] > hi + margins[j]);
            }
        }
        outside
    })
    .into_iter()
    .fold([0usize; N], |mut a, b| {
        for (a, b) in a.iter_mut().zip(b) {
            *a += b;
        }
        a
    });
    let held_out = ranges(valid);
    (0..N)
        .filter_map(|j| {
            let (lo, hi) = identified[j];
            let share = outside[j] as f64 / valid.len().max(1) as f64;
            // One stray pose is not extrapolation; a twentieth of them is.
            (outside[j] > 0 && share >= 0.05).then(|| {
                let (vlo, vhi) = held_out[j];
                JointRangeGap {
                    joint: j + 1,
                    identified_deg: [lo.to_degrees(), hi.to_degrees()],
                    held_out_deg: [vlo.to_degrees(), vhi.to_degrees()],
                    outside_share: share,
                }
            })
        })
        .collect()
}

/// The verdict's figures on poses a fit did not see: whether the calibrated model predicts them
/// worse than the starting model (NaN counts as worse), its RMS over the identification RMS,
/// and whether that is [`MUCH_WORSE`].
fn compare(start: f64, after: f64, ident_mm: f64) -> (bool, f64, bool) {
    let worse = after.is_nan() || start.is_nan() || after > start + NO_DIFFERENCE_MM;
    let ratio = after / ident_mm.max(f64::MIN_POSITIVE);
    (
        worse,
        ratio,
        ratio > MUCH_WORSE && after > ident_mm + NO_DIFFERENCE_MM,
    )
}

/// The first six names, and "…" for more.
fn first_names(names: &[String]) -> String {
    let shown: Vec<&str> = names.iter().take(6).map(String::as_str).collect();
    let more = if names.len() > shown.len() {
        ", …"
    } else {
        ""
    };
    format!("{}{more}", shown.join(", "))
}

/// Judges a fit on its held-out poses: `start_mm` and `after_mm` are the starting and the
/// calibrated model's held-out RMS, `ident_mm` the calibrated model's identification RMS;
/// `weak` the parameters the data barely determine. `None` without held-out poses.
pub fn judge<const N: usize>(
    (start_mm, after_mm, ident_mm): (Option<f64>, Option<f64>, f64),
    ident: &[Measurement<f64, N>],
    valid: &[Measurement<f64, N>],
    weak: Vec<String>,
) -> Option<Acceptance> {
    let (start, after) = (start_mm?, after_mm?);
    let (worse, ratio, much_worse) = compare(start, after, ident_mm);
    let gaps = outside_ranges(ident, valid);
    let message = (worse || much_worse).then(|| {
        use crate::output::numfmt::sig;
        let head = if worse {
            format!(
                "the calibrated model predicts the held-out poses worse than the model it started \
                 from ({} mm against {} mm): this is not a calibration",
                sig(after, 4),
                sig(start, 4)
            )
        } else {
            format!(
                "the calibrated model predicts the held-out poses {}× worse than the poses it was \
                 fitted to ({} mm against {} mm)",
                sig(ratio, 3),
                sig(after, 4),
                sig(ident_mm, 4)
            )
        };
        let mut why = Vec::new();
        if !gaps.is_empty() {
            let joints: Vec<String> = gaps
                .iter()
                .map(|g| {
                    format!(
                        "joint {} held out {:.0}…{:.0}° against {:.0}…{:.0}° identified",
                        g.joint,
                        g.held_out_deg[0],
                        g.held_out_deg[1],
                        g.identified_deg[0],
                        g.identified_deg[1]
                    )
                })
                .collect();
            why.push(format!(
                "held-out poses outside the identification poses' joint ranges ({}): measure \
                 poses that cover the working range",
                joints.join("; ")
            ));
        }
        if !weak.is_empty() {
            why.push(format!(
                "parameters the data barely determine ({}: 1-σ beyond the tolerance): hold \
                 them (--fix) or measure poses that move them (plan --estimate)",
                first_names(&weak)
            ));
        }
        if why.is_empty() {
            why.push(
                "the held-out poses differ from the identified ones: from another session (the \
                 tracker or the tool moved: judge a model there with kinecal validate, which \
                 fits the set-up first), a drift or a collision (find the poses with --residuals)"
                    .to_string(),
            );
        }
        format!("{head}; likely: {}", why.join("; "))
    });
    Some(Acceptance {
        held_out_worse: worse,
        held_out_ratio: ratio,
        message,
        outside_ranges: gaps,
        weak_parameters: weak,
        extrapolated: false,
    })
}

/// Judges a fit that held nothing out by its cross-validation on thin data
/// ([`crate::calibration::thin_data`]): worse than the starting model on the poses left out
/// is no calibration, as on held-out poses; the reason is the data's thinness, with how many
/// poses would give the fit [`crate::calibration::thin_data::EQUATIONS_PER_PARAMETER`]
/// equations per parameter (`poses`: the fit's poses).
pub fn judge_cross_validated(
    cv: &crate::calibration::thin_data::CrossValidated,
    ident_mm: f64,
    poses: usize,
    weak: Vec<String>,
) -> Option<Acceptance> {
    use crate::output::numfmt::sig;
    let (start, after) = cv.figures()?;
    let (worse, ratio, much_worse) = compare(start, after, ident_mm);
    let params = cv.parameters;
    let enough = crate::calibration::thin_data::enough_poses(
        params,
        cv.equations as f64 / poses.max(1) as f64,
    );
    let message = (worse || much_worse).then(|| {
        let head = if worse {
            format!(
                "the calibrated model predicts poses left out of its fit worse than the model \
                 it started from ({}-fold cross-validation: {} mm against {} mm): this is not \
                 a calibration",
                cv.folds,
                sig(after, 4),
                sig(start, 4)
            )
        } else {
            format!(
                "the calibrated model predicts poses left out of its fit {}× worse than the \
                 poses it was fitted to ({}-fold cross-validation: {} mm against {} mm)",
                sig(ratio, 3),
                cv.folds,
                sig(after, 4),
                sig(ident_mm, 4)
            )
        };
        let mut why = format!(
            "{poses} poses ({} equations) are thin data for {params} parameters: measure about \
             {enough} poses spread over the working range, or hold parameters with --fix{}",
            cv.equations,
            if worse {
                "; or the model it started from is already as good as these data can tell"
            } else {
                ""
            }
        );
        if !weak.is_empty() {
            why.push_str(&format!(" (barely determined: {})", first_names(&weak)));
        }
        format!("{head}; likely: {why}")
    });
    Some(Acceptance {
        held_out_worse: worse,
        held_out_ratio: ratio,
        message,
        outside_ranges: Vec::new(),
        weak_parameters: weak,
        extrapolated: false,
    })
}
