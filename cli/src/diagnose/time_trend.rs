//! A drift of the residuals along the rows' order: a laser tracker or a base that moved while
//! the session was measured, or an arm that warmed beyond what the rows' `temp_c` records.
//! Without each row's time (`t_s`) the catalogue cannot offer `base-drift`, so the search
//! would take a drift for noise (a noise floor from held-out errors includes it). [`trend`] fits `r_i = r̄ + b·(i − ī)` per axis to a
//! model's point residuals in the order of the observations and tests `b = 0` (F test, 3 and
//! 3n − 6 − the model's effective parameters degrees of freedom, the rows taken as independent);
//! [`warning`] says so when the drift is significant and large enough to matter beside the
//! noise floor. Rows measured in order are in time order; rows shuffled show no trend.

use super::significance::f_sf;
use crate::calibration::pose_error_vectors;
use kinecal::{Measurement, Robot};
use nalgebra::Vector3;

/// The linear trend of the point residuals along the observations' order.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimeTrend {
    /// How far the residuals move from the first observation to the last (mm).
    pub drift_mm: Vector3<f64>,
    /// RMS of the trend itself over the observations (mm): what removing it would take from
    /// the residuals' mean square.
    pub rms_mm: f64,
    /// Probability of a trend at least this strong in residuals without one.
    pub p: f64,
}

/// The trend of `robot`'s point residuals (measured − model, mm) over `data` in their order,
/// for a model fitted to them with `fitted` effective parameters (taken from the test's
/// degrees of freedom); `None` with fewer than 4 observations, or residuals that are not finite.
pub fn trend<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    fitted: f64,
) -> Option<TimeTrend> {
    let n = data.len();
    if n < 4 {
        return None;
    }
    let r = pose_error_vectors(robot, data);
    let mean = r.iter().sum::<Vector3<f64>>() / n as f64;
    let mid = (n - 1) as f64 / 2.0;
    let (mut stt, mut str, mut ss) = (0.0, Vector3::zeros(), 0.0);
    for (i, ri) in r.iter().enumerate() {
        let t = i as f64 - mid;
        let e = ri - mean;
        stt += t * t;
        str += e * t;
        ss += e.norm_squared();
    }
    let b = str / stt;
    let ss_trend = b.norm_squared() * stt;
    let fitted = if fitted.is_finite() {
        fitted.max(0.0)
    } else {
        0.0
    };
    let (df1, df2) = (3.0, (3.0 * n as f64 - 6.0 - fitted).max(1.0));
    let ss_rest = (ss - ss_trend).max(0.0);
    let p = if ss_rest > 0.0 {
        f_sf((ss_trend / df1) / (ss_rest / df2), df1, df2)
    } else if ss_trend > 0.0 {
        0.0
    } else {
        1.0
    };
    let out = TimeTrend {
        drift_mm: b * (n - 1) as f64,
        rms_mm: (ss_trend / n as f64).sqrt(),
        p,
    };
    (out.drift_mm.iter().all(|x| x.is_finite()) && out.p.is_finite()).then_some(out)
}

/// Below this probability a trend is significant: one test per search, strict enough that
/// rows that are not quite independent (the F test takes them as independent) seldom raise a
/// false warning; the null tests of `evidence::a_drifting_tracker` stay far above it.
pub const TREND_P: f64 = 1e-3;

/// A trend smaller than this share of the noise floor is not worth a word: removing it would
/// lower the RMS by about 2 % or less (`1 − √(1 − 0.2²)`), the search's practical margin
/// ([`crate::diagnose::Config::min_rms_drop`]).
pub const TREND_SHARE: f64 = 0.2;

/// The warning for the residuals of `robot` (fitted with `fitted` effective parameters) over
/// `data` when they drift significantly ([`TREND_P`]) by at least [`TREND_SHARE`] of
/// `noise_floor_mm` (any size when the floor is not a finite number); `None` otherwise. `floor`
/// names the floor in the text (`diagnose`'s noise floor, or `identify`'s RMS).
pub fn warning<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    fitted: f64,
    (noise_floor_mm, floor): (f64, &str),
) -> Option<String> {
    let t = trend(robot, data, fitted)?;
    let large = !noise_floor_mm.is_finite() || t.rms_mm >= TREND_SHARE * noise_floor_mm;
    if !(t.p < TREND_P && large) {
        return None;
    }
    let d = t.drift_mm;
    let p = if t.p < 1e-16 {
        "p < 1e-16".to_string()
    } else {
        format!("p = {}", crate::output::numfmt::sig(t.p, 2))
    };
    Some(format!(
        "the residuals drift along the rows' order by {} mm from the first row to the last \
         (x {}, y {}, z {} mm; {} mm RMS beside {floor} of {} mm, {p}), which the model \
         does not explain: a tracker or a base that moved during the session, or the arm \
         warming beyond what `temp_c` records. Check the tracker's drift (re-measure its \
         reference), or split the session where it moved{}",
        crate::output::numfmt::sig(d.norm(), 3),
        crate::output::numfmt::sig(d.x, 3),
        crate::output::numfmt::sig(d.y, 3),
        crate::output::numfmt::sig(d.z, 3),
        crate::output::numfmt::sig(t.rms_mm, 3),
        crate::output::numfmt::sig(noise_floor_mm, 3),
        if data.iter().all(|m| m.time_s.is_some()) {
            ""
        } else {
            "; with each row's time in a `t_s` column, diagnose fits the drift (`base-drift`)"
        },
    ))
}
