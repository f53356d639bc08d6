//! Orientations no arm can be that far from: a 6-D fit whose positions meet the points but
//! whose orientations stay degrees from the measured ones was given orientation columns that
//! do not describe the tool frame (radians in `rx_deg`, the inverse rotation, angles swapped
//! or one row late, another frame). A calibrated arm's tool orientation is within hundredths of
//! a degree (the real UR10 6-D rows: 0.056°), an uncalibrated one's within tenths, so the fit
//! would otherwise turn the wrist and the tool's `rpy_deg` to split the difference and exit 0.

use crate::output::numfmt::sig;

/// The largest orientation RMS (degrees) a fit of real 6-D data leaves.
pub const MOST_ORIENTATION_RMS_DEG: f64 = 1.0;

/// Why a 6-D fit with position RMS `rms_mm` (within `stall_rms_mm`: the positions are met) and
/// orientation RMS `rms_deg` is no calibration, as the rest of a sentence that starts "the fit",
/// or `None` (no orientations, or within [`MOST_ORIENTATION_RMS_DEG`]).
pub fn astray(rms_mm: f64, stall_rms_mm: f64, rms_deg: Option<f64>) -> Option<String> {
    let deg = rms_deg?;
    (rms_mm <= stall_rms_mm && !(deg <= MOST_ORIENTATION_RMS_DEG)).then(|| {
        format!(
            "met the points ({} mm RMS) but left the orientations {}° RMS from the measured \
             ones, where no arm is more than {MOST_ORIENTATION_RMS_DEG}° off: the orientation \
             columns do not describe the tool frame; check their unit (degrees in rx_deg, \
             ry_deg, rz_deg; [units] orientation in a map), their order and signs, the order \
             they compose in ([units] rotation), that they give the tool in the tracker's frame \
             (not the inverse) on the same row as its point, or fit the positions alone \
             (--positions-only)",
            sig(rms_mm, 4),
            sig(deg, 3)
        )
    })
}
