//! Orientations no arm can be that far from: a 6-D fit whose positions meet the points but
//! whose orientations stay degrees from the measured ones was given orientation columns that
//! do not describe the tool frame (radians in `rx_deg`, the inverse rotation, angles swapped
//! or one row late, another frame). A calibrated arm's tool orientation is within hundredths of
//! a degree (the real UR10 6-D rows: 0.056°), an uncalibrated one's within tenths, so the fit
//! would otherwise turn the wrist and the tool's `rpy_deg` to split the difference and exit 0.

use crate::output::numfmt::sig;

/// The largest orientation RMS (degrees) a fit of real 6-D data leaves.
pub const MOST_ORIENTATION_RMS_DEG: f64 = 1.0;

/// Why a 6-D fit with position RMS `rms_mm` (within `stall_rms_mm`: the positions are met)
/// and per-row orientation errors `errors_deg` is no calibration, as the rest of a sentence that
/// starts "the fit", or `None` (no orientations, or the median row within the limit). The
/// median, since a mix-up of the columns puts every row off while a few bad rows leave it
/// alone; the limit is [`MOST_ORIENTATION_RMS_DEG`], or three times the rows' median stated
/// angular σ (`stated_deg`, `srot_deg`: about the error's expected size over three axes,
/// `σ√3`) when that is more: a probe that states its angles to 0.6° is not refused for them.
pub fn astray(
    rms_mm: f64,
    stall_rms_mm: f64,
    errors_deg: &[f64],
    stated_deg: &[f64],
) -> Option<String> {
    let deg = median(errors_deg)?;
    let limit = limit_deg(stated_deg);
    (rms_mm <= stall_rms_mm && deg > limit).then(|| {
        format!(
            "met the points ({} mm RMS) but left the orientations {}° off in the median row, \
             where no arm is more than {}° off: the orientation columns do not describe the tool \
             frame; check their unit (degrees in rx_deg, ry_deg, rz_deg; [units] orientation in \
             a map), their order and signs, the order they compose in ([units] rotation), that \
             they give the tool in the tracker's frame (not the inverse) on the same row as its \
             point, or fit the positions alone (--positions-only)",
            sig(rms_mm, 4),
            sig(deg, 3),
            sig(limit, 3)
        )
    })
}

/// The median of the finite values of `v` ([`crate::calibration::stats::quantile`]); `None`
/// for none.
pub fn median(v: &[f64]) -> Option<f64> {
    let v: Vec<f64> = v.iter().copied().filter(|x| x.is_finite()).collect();
    (!v.is_empty()).then(|| crate::calibration::stats::quantile(&v, 0.5))
}

/// How far (degrees) the median row's orientation may be from a model of the tool frame:
/// [`MOST_ORIENTATION_RMS_DEG`], or three times the rows' median stated angular σ
/// (`stated_deg`; zeros state none) over three axes when that is more.
pub fn limit_deg(stated_deg: &[f64]) -> f64 {
    let stated: Vec<f64> = stated_deg.iter().copied().filter(|s| *s > 0.0).collect();
    MOST_ORIENTATION_RMS_DEG.max(median(&stated).map_or(0.0, |s| 3.0 * s * 3f64.sqrt()))
}
