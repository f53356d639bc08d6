//! A ball bar whose stated lengths are all off by one factor: when `length_mm` is a session's
//! only length (distance groups and no tracker `point` rows), the fit scales the whole arm by
//! that factor and meets every constraint to the noise, and held-out groups, measured with the
//! same bar, agree. A bar 1 % long made a model 4 times worse than the nominal robot on the true
//! robot, with exit 0; 0.2 % long threw away most of the calibration's gain. Nothing in the
//! session can tell, but a real arm's links do not all deviate from their drawing by one
//! factor, so a fit whose estimated links share a scale more than [`MOST_SCALE`] from the
//! robot file's is no calibration ([`refusal`]: exit 3; a warning alone let such a model, which
//! can be worse than the nominal robot, pass with exit 0).

use super::read::{Group, Kind};
use crate::output::numfmt::sig;
use crate::HostRobot;
use kinecal::Param;

/// The largest common change of the estimated link lengths a calibration from bar lengths alone
/// makes without a word: a link's deviation from its drawing (tenths of a millimetre on links of
/// hundreds) is not shared by all.
pub const MOST_SCALE: f64 = 0.0015;

/// Links shorter than this (mm) do not count towards the common scale (an offset of a few
/// millimetres changes by its own error, not by the bar's share).
pub const SHORTEST_LINK_MM: f64 = 50.0;

/// The common scale of the `estimated` link lengths (`a`, `d` of at least
/// [`SHORTEST_LINK_MM`], the last joint's `d` apart) of `fitted` against `nominal`:
/// `Σ f·n / Σ n²`, and `Σ n` (mm); `None` without such links.
pub fn link_scale<const N: usize>(
    nominal: &HostRobot<N>,
    fitted: &HostRobot<N>,
    estimated: &[Param],
) -> Option<(f64, f64)> {
    let (jn, jf) = (nominal.joints(), fitted.joints());
    let pairs: Vec<(f64, f64)> = estimated
        .iter()
        .filter_map(|p| match *p {
            Param::A(j) => Some((jn.get(j as usize)?.a, jf.get(j as usize)?.a)),
            // The last joint's `d` takes up a tool the file does not know (as the arm-size
            // check leaves it out): 109 mm on the UR10's 92 mm made correct bars "1.3 % long".
            Param::D(j) if j as usize + 1 == N => None,
            Param::D(j) => Some((jn.get(j as usize)?.d, jf.get(j as usize)?.d)),
            _ => None,
        })
        .filter(|(n, _)| n.abs() >= SHORTEST_LINK_MM)
        .collect();
    let nn: f64 = pairs.iter().map(|(n, _)| n * n).sum();
    (nn > 0.0).then(|| {
        (
            pairs.iter().map(|(n, f)| n * f).sum::<f64>() / nn,
            pairs.iter().map(|(n, _)| n.abs()).sum(),
        )
    })
}

/// The warning (without "warning: ") when the `estimated` links of `fitted` share a scale
/// more than [`MOST_SCALE`] from `nominal`'s and `groups`' only length is `length_mm`; `None`
/// otherwise.
pub fn warning<const N: usize>(
    nominal: &HostRobot<N>,
    (fitted, estimated): (&HostRobot<N>, &[Param]),
    groups: &[Group<N>],
) -> Option<String> {
    let has = |k: Kind| groups.iter().any(|g| g.kind == k);
    if !has(Kind::Distance) || has(Kind::Point) {
        return None;
    }
    let (scale, total) = link_scale(nominal, fitted, estimated)?;
    let change = scale - 1.0;
    (change.abs() > MOST_SCALE && change.is_finite()).then(|| {
        format!(
            "the arm's estimated links came out {} % {} than the robot file says (together \
             {} mm: {} mm {}), and the session's only length is length_mm: bar lengths off by \
             that share scale the arm alike, and held-out groups measured with the same bar \
             cannot see it; check length_mm against the bar's certificate (a real arm's links \
             do not all deviate by one factor)",
            sig(change.abs() * 100.0, 2),
            if change > 0.0 { "longer" } else { "shorter" },
            sig(total, 5),
            sig((change * total).abs(), 2),
            if change > 0.0 { "more" } else { "less" },
        )
    })
}

/// Why a fit that scaled the arm (see [`warning`]) is no calibration, after "the fit …", or
/// `None`.
pub fn refusal<const N: usize>(
    nominal: &HostRobot<N>,
    fitted: (&HostRobot<N>, &[Param]),
    groups: &[Group<N>],
) -> Option<String> {
    warning(nominal, fitted, groups).map(|w| {
        format!(
            "scaled the arm: {w}; if the certificate is right, the robot file describes another \
             arm: correct its lengths"
        )
    })
}
