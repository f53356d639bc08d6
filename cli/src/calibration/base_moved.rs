//! A fit that held the base (the robot file's `[base]`, or, with `--only` leaving it out, the
//! base placed on the data before the fit) on a session whose tracker or robot moved since: the
//! parameters it estimates take up what the base's move explains, and the fit ends far above
//! the noise yet below `--stall-rms-mm` (a re-mastering of joints 2 and 3 on 10 poses, the
//! tracker moved (2, −1.5, 1) mm: 2.62 mm left at 0.01 mm noise, the zeros 30–45 % wrong,
//! exit 0; the full geometry held at a stated `[base]`: 1.3 mm). The same fit with the base
//! estimated too tells it, on at most [`SAMPLE`] observations: when that leaves at most a
//! third, and [`MIN_GAIN_MM`] less, the fit is no calibration and the reason says to estimate
//! the base.

use crate::calibration::Residuals;
use crate::HostRobot;
use kinecal::identify::lm::LmConfig;
use kinecal::{Measurement, Param};

/// The fit with the base leaves at most this share of the fit's RMS...
pub const EXPLAINS: f64 = 1.0 / 3.0;
/// ... and at least this much less (mm).
pub const MIN_GAIN_MM: f64 = 0.05;
/// The comparison is made on at most this many observations (every k-th).
pub const SAMPLE: usize = 2000;

/// The reason a fit of `params` (converged at `fitted`) that held the base is no calibration,
/// or `None`: it estimated the base, or the base explains little. `stated`: the base is the
/// robot file's (else it was placed on the data before the fit).
pub fn reason<const N: usize>(
    fitted: &HostRobot<N>,
    params: &[Param],
    data: &[Measurement<f64, N>],
    stated: bool,
) -> Option<String> {
    if params.iter().any(|p| p.is_base()) || data.is_empty() {
        return None;
    }
    let sample = super::every_kth(data, SAMPLE);
    let rms_mm = Residuals::of(fitted, &sample, &[]).identification_rms_mm;
    if rms_mm.is_nan() || rms_mm <= MIN_GAIN_MM {
        return None;
    }
    let with_base: Vec<Param> = params.iter().copied().chain(Param::BASE).collect();
    let refit = super::fit_lm(fitted, &with_base, &sample, LmConfig::default()).ok()?;
    let rms_base = Residuals::of(&refit.robot, &sample, &[]).identification_rms_mm;
    (rms_base <= EXPLAINS * rms_mm && rms_mm - rms_base >= MIN_GAIN_MM).then(|| {
        use crate::output::numfmt::sig;
        let (held, since) = if stated {
            ("the robot file's [base]", "since that base was measured")
        } else {
            ("the base placed before the fit", "during the session")
        };
        format!(
            "held {held} and leaves {} mm; with the base estimated too it leaves {} mm: the \
             tracker or the robot moved {since}, and the parameters estimated took up the \
             move: estimate the base too (add base to --only, leave it out of --fix, or drop \
             the robot file's [base])",
            sig(rms_mm, 4),
            sig(rms_base, 4)
        )
    })
}
