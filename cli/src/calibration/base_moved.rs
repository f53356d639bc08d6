//! A fit that held the robot file's `[base]` (`--only` or `--fix` left it out) on a session
//! whose tracker or robot moved since that base was measured: the parameters it estimates take
//! up what the base's move explains, and the fit ends far above the noise yet below
//! `--stall-rms-mm` (a re-mastering of joints 2 and 3 on 10 poses, the tracker moved
//! (2, −1.5, 1) mm: 2.62 mm left at 0.01 mm noise, the zeros 30–45 % wrong, exit 0). The same
//! fit with the base estimated too tells it: when that leaves at most a third, and
//! [`MIN_GAIN_MM`] less, the fit is no calibration and the reason says to estimate the base.

use crate::calibration::Residuals;
use crate::HostRobot;
use kinecal::identify::lm::LmConfig;
use kinecal::{Measurement, Param};

/// The fit with the base leaves at most this share of the fit's RMS...
pub const EXPLAINS: f64 = 1.0 / 3.0;
/// ... and at least this much less (mm).
pub const MIN_GAIN_MM: f64 = 0.05;

const BASE: [Param; 6] = [
    Param::BaseX,
    Param::BaseY,
    Param::BaseZ,
    Param::BaseRx,
    Param::BaseRy,
    Param::BaseRz,
];

/// The reason a fit of `params` (converged at `fitted`, leaving `rms_mm` on `data`) that held
/// the base is no calibration, or `None`: it estimated the base, or the base explains little.
pub fn reason<const N: usize>(
    fitted: &HostRobot<N>,
    params: &[Param],
    data: &[Measurement<f64, N>],
    rms_mm: f64,
) -> Option<String> {
    if params.iter().any(|p| p.is_base()) || rms_mm.is_nan() || rms_mm <= MIN_GAIN_MM {
        return None;
    }
    let with_base: Vec<Param> = params.iter().copied().chain(BASE).collect();
    let refit = super::fit_lm(fitted, &with_base, data, LmConfig::default()).ok()?;
    let rms_base = Residuals::of(&refit.robot, data, &[]).identification_rms_mm;
    (rms_base <= EXPLAINS * rms_mm && rms_mm - rms_base >= MIN_GAIN_MM).then(|| {
        use crate::output::numfmt::sig;
        format!(
            "held the robot file's [base] and leaves {} mm; with the base estimated too \
             it leaves {} mm: the tracker or the robot moved since that base was measured, and \
             the parameters estimated took up the move: add base to --only (or leave it out of \
             --fix)",
            sig(rms_mm, 4),
            sig(rms_base, 4)
        )
    })
}
