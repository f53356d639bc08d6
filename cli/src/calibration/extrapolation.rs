//! How well the identification poses determine a model where they were not measured.
//!
//! A fit whose poses keep some joints within a few degrees meets its poses and its held-out
//! poses (drawn from the same few degrees) well, while combinations of parameters that look
//! alike there, and differ elsewhere, take whatever values fit the noise: on simulated KR16-like
//! data measured within ±3° of one pose the model was 2.5 mm off across the joint ranges against
//! the nominal robot's 1.8 mm, and the held-out check said "predicted better than by the
//! starting model" (`cargo test -p kinecal-host --test command_line
//! holding::extrapolation`). The posterior covariance of the estimated parameters (the data's
//! information plus the prior, as identify's 1-σ column has it) carried to poses spread over the
//! joint limits says how far the model is known there; carried to the measured poses, how far
//! it is known where it was fitted.

use crate::calibration::acceptance::Acceptance;
use crate::output::numfmt::sig;
use kinecal::{ForwardKinematics, Measurement, Param, Robot};
use nalgebra::DMatrix;
use rand::{RngExt, SeedableRng};

/// Poses drawn within the joint limits to judge the model across them.
pub const WORKSPACE_POSES: usize = 256;

/// At most this many identification poses enter the information (evenly spaced, weighted up).
const MAX_POSES: usize = 2000;

/// The predicted position uncertainty of a fitted model (RMS over poses of the 1-σ distance,
/// `√trace` of the point's covariance), mm.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Determined {
    /// Over poses drawn uniformly within the joint limits.
    pub workspace_mm: f64,
    /// Over the identification poses.
    pub measured_mm: f64,
}

/// The model `robot`'s uncertainty with the parameters `params` estimated from the positions of
/// `data` (per-coordinate noise `noise_mm`; every k-th pose beyond [`MAX_POSES`]) and the prior
/// 1-σ `prior` (library units, `None`: none), at the measured poses and across the joint
/// limits. `None` when nothing is estimated or the figures are not finite.
pub fn determined<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    params: &[Param],
    prior: &[Option<f64>],
    data: &[Measurement<f64, N>],
    noise_mm: f64,
) -> Option<Determined> {
    let m = params.len();
    if m == 0 || data.is_empty() || !(noise_mm.is_finite() && noise_mm > 0.0) {
        return None;
    }
    let reach = robot.reach();
    let scale: Vec<f64> = params.iter().map(|p| p.scale(reach)).collect();
    let mut fk = ForwardKinematics::new();
    let mut rows = |q: &[f64; N]| -> Option<DMatrix<f64>> {
        fk.compute(robot, q);
        let mut g = DMatrix::zeros(3, m);
        for (k, p) in params.iter().enumerate() {
            let c = fk.column(robot, *p).ok()? / scale[k];
            g[(0, k)] = c.x;
            g[(1, k)] = c.y;
            g[(2, k)] = c.z;
        }
        Some(g)
    };
    let step = data.len().div_ceil(MAX_POSES);
    let measured: Vec<[f64; N]> = data.iter().step_by(step).map(|d| d.q).collect();
    let weight = data.len() as f64 / measured.len() as f64;
    let mut info = DMatrix::<f64>::zeros(m, m);
    let mut measured_rows = Vec::with_capacity(measured.len());
    for q in &measured {
        let g = rows(q)?;
        info += g.transpose() * &g * (weight / (noise_mm * noise_mm));
        measured_rows.push(g);
    }
    for (k, (p, s)) in params.iter().zip(prior).enumerate() {
        if let Some(s) = s {
            let v = (s * p.scale(reach)).powi(2);
            if v > 0.0 {
                info[(k, k)] += 1.0 / v;
            }
        }
    }
    // Directions no pose anywhere moves (a length confounded with another) add nothing to any
    // pose's uncertainty: the pseudo-inverse leaves them out.
    let eig = info.symmetric_eigen();
    let top = eig.eigenvalues.iter().cloned().fold(0.0f64, f64::max);
    if !(top.is_finite() && top > 0.0) {
        return None;
    }
    let mut cov = DMatrix::<f64>::zeros(m, m);
    for (i, &l) in eig.eigenvalues.iter().enumerate() {
        if l > top * 1e-12 {
            let v = eig.eigenvectors.column(i);
            cov += v * v.transpose() / l;
        }
    }
    let rms = |gs: &mut dyn Iterator<Item = DMatrix<f64>>| -> Option<f64> {
        let (mut sum, mut n) = (0.0, 0usize);
        for g in gs {
            sum += (&g * &cov * g.transpose()).trace().max(0.0);
            n += 1;
        }
        (n > 0).then(|| (sum / n as f64).sqrt())
    };
    let measured_mm = rms(&mut measured_rows.into_iter())?;
    let workspace = workspace_poses(robot);
    let mut ws = workspace.iter().filter_map(&mut rows);
    let workspace_mm = rms(&mut ws)?;
    (workspace_mm.is_finite() && measured_mm.is_finite()).then_some(Determined {
        workspace_mm,
        measured_mm,
    })
}

/// [`WORKSPACE_POSES`] poses drawn uniformly within `robot`'s joint limits (a joint that turns
/// more than a turn: over one turn from its lower limit), always the same.
pub fn workspace_poses<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
) -> Vec<[f64; N]> {
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7);
    let joints = robot.joints();
    (0..WORKSPACE_POSES)
        .map(|_| {
            std::array::from_fn(|j| {
                let lo = joints[j].lower.max(-4.0 * std::f64::consts::PI);
                let span = (joints[j].upper.min(4.0 * std::f64::consts::PI) - lo)
                    .clamp(0.0, std::f64::consts::TAU);
                lo + rng.random::<f64>() * span
            })
        })
        .collect()
}

/// The RMS distance (mm) between the points of `start` and `fit` over [`workspace_poses`]: how
/// far the calibration moves the arm across the joint ranges.
pub fn change_mm<const N: usize, V: kinecal::ValueStorage>(
    start: &Robot<f64, N, V>,
    fit: &Robot<f64, N, V>,
) -> f64 {
    let poses = workspace_poses(fit);
    let sum: f64 = poses
        .iter()
        .map(|q| {
            (kinecal::forward::point(start, q) - kinecal::forward::point(fit, q)).norm_squared()
        })
        .sum();
    (sum / poses.len().max(1) as f64).sqrt()
}

/// The refusal of a model whose 1-σ across the joint ranges exceeds the change it makes there
/// over √2: the calibrated model is then as likely as not further from the arm than the start
/// (errors of the start `e` and of the model `u` independent: the change is √(e² + u²), and
/// `u > e` where `u > change/√2`). `None`: determined enough.
pub fn undetermined(d: Determined, change_mm: f64, narrow: &str) -> Option<String> {
    (d.workspace_mm > change_mm / std::f64::consts::SQRT_2).then(|| {
        format!(
            "the model is not determined across the joint ranges: its 1-σ there is {} mm ({} mm \
             at the measured poses) against the {} mm it moves the arm by, so it may predict \
             poses elsewhere worse than the model it started from; {narrow}: measure poses \
             across each joint's range (kinecal plan), or estimate fewer parameters (--only)",
            sig(d.workspace_mm, 3),
            sig(d.measured_mm, 3),
            sig(change_mm, 3),
        )
    })
}

/// `acceptance` (the held-out verdict, if any) turned into a refusal with `message`: the model
/// predicts unseen poses worse than its start as far as anyone can tell.
pub fn refuse(acceptance: Option<Acceptance>, message: String) -> Acceptance {
    let mut a = acceptance.unwrap_or(Acceptance {
        held_out_worse: true,
        // Nothing held out: no ratio (0, as JSON has no NaN).
        held_out_ratio: 0.0,
        message: None,
        outside_ranges: Vec::new(),
        weak_parameters: Vec::new(),
        extrapolated: true,
    });
    a.held_out_worse = true;
    a.extrapolated = true;
    a.message = Some(match a.message.take() {
        Some(m) => format!("{message}; {m}"),
        None => message,
    });
    a
}

/// [`undetermined`] for a fit from `start` to `fit` of `params` (prior 1-σ `prior`) on the
/// positions of `ident` (noise `noise_mm` per coordinate), judged when some joints barely move
/// in them ([`crate::calibration::acceptance::narrow_list`]) and the held-out poses `valid`
/// stay within the identification poses' ranges: held-out poses beyond them measure the model
/// there (the held-out verdict judges it: a covariance says what may be, they what is).
pub fn check<const N: usize, V: kinecal::ValueStorage>(
    (start, fit): (&Robot<f64, N, V>, &Robot<f64, N, V>),
    (params, prior): (&[Param], &[Option<f64>]),
    (ident, valid): (&[Measurement<f64, N>], &[Measurement<f64, N>]),
    noise_mm: f64,
) -> Option<String> {
    use crate::calibration::acceptance::{narrow_list, outside_ranges, NARROW_DEG};
    let narrow = narrow_list(ident);
    if narrow.is_empty() || !outside_ranges(ident, valid).is_empty() {
        return None;
    }
    let d = determined(fit, params, prior, ident, noise_mm)?;
    undetermined(
        d,
        change_mm(start, fit),
        &format!(
            "the identification poses move {} less than {NARROW_DEG}°",
            narrow.join(", ")
        ),
    )
}
