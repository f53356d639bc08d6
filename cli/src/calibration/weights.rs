//! Weights of 6-D and σ-weighted observations: the stated σ plus what the model cannot explain.
//!
//! A tracker's σ describe its noise; a robot model that misses an effect (joint-angle errors
//! the geometry cannot express, say) leaves residuals many times larger, and then weighting
//! by the stated σ alone is arbitrary: a reading with a small σ pulls the fit harder although
//! its residual is mostly model error. So each group of residual rows (the points'
//! coordinates; the orientations) gets an error floor `s_g`, the effective uncertainty of a
//! row is `√(σ² + s_g²)`, and `s_g` is the smallest value for which the group's weighted
//! squares match its degrees of freedom (variance-component estimation with an additive
//! component, as geodesy combines heterogeneous observations). When the stated σ explain the
//! residuals, `s_g = 0` and the weights are the σ's; without σ columns, `s_g` is the group's
//! RMS per row, which balances millimetres against degrees by what each group scatters.
//! A few rounds of fit → floors → weights → refit (from the previous fit) settle it.

use kinecal::model::frame::orientation_error;
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::Vector3;

/// The stated 1-σ of one observation (0 where the file gives none).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stated {
    pub point_mm: Vector3<f64>,
    pub orientation_rad: f64,
}

/// The stated σ of each observation, read back from its weights (`w = 1/σ`; a unit weight
/// without σ columns is σ = 0: no stated uncertainty).
pub fn stated<const N: usize>(data: &[Measurement<f64, N>], sigma: bool) -> Vec<Stated> {
    data.iter()
        .map(|m| Stated {
            point_mm: if sigma {
                m.weight.map(|w| 1.0 / w)
            } else {
                Vector3::zeros()
            },
            orientation_rad: if sigma && m.orientation.is_some() {
                1.0 / m.orientation_weight
            } else {
                0.0
            },
        })
        .collect()
}

/// The floors found, and the χ² of the stated σ.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Floors {
    /// Error floor of a point coordinate, mm.
    pub point_mm: f64,
    /// Error floor of an orientation component, rad (0 without orientations).
    pub orientation_rad: f64,
}

/// The smallest `s² ≥ 0` with `Σ r²/(σ² + s²) ≤ dof` (bisection: the sum falls with `s²`).
fn floor_squared(r2: &[(f64, f64)], dof: f64) -> f64 {
    if r2.is_empty() || dof <= 0.0 {
        return 0.0;
    }
    let chi = |s2: f64| -> f64 {
        r2.iter()
            .map(|(r, v)| if v + s2 > 0.0 { r / (v + s2) } else { 0.0 })
            .sum()
    };
    if r2.iter().all(|(_, v)| *v > 0.0) && chi(0.0) <= dof {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0, r2.iter().map(|(r, _)| r).sum::<f64>() / dof);
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if chi(mid) > dof {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    hi
}

/// The residual rows of `data` at `robot`, grouped: each point coordinate's and each
/// orientation component's squared residual with its stated variance.
#[allow(clippy::type_complexity)]
fn rows<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    stated: &[Stated],
) -> (Vec<(f64, f64)>, Vec<(f64, f64)>) {
    let mut fk = ForwardKinematics::new();
    let (mut pos, mut rot) = (Vec::new(), Vec::new());
    for (m, s) in data.iter().zip(stated) {
        let Some(p) = fk.compute_at(robot, &m.q, m.tool as usize, m.conditions()) else {
            continue;
        };
        let r = m.point - p;
        for a in 0..3 {
            pos.push((r[a] * r[a], s.point_mm[a] * s.point_mm[a]));
        }
        if let Some(o) = &m.orientation {
            let e = orientation_error(o, &fk.tool_pose(robot));
            let v = s.orientation_rad * s.orientation_rad;
            for a in 0..3 {
                rot.push((e[a] * e[a], v));
            }
        }
    }
    (pos, rot)
}

/// The floors at `robot` for `params` estimated parameters (shared among the groups by
/// their number of rows).
pub fn floors<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    stated: &[Stated],
    params: usize,
) -> Floors {
    let (pos, rot) = rows(robot, data, stated);
    let total = (pos.len() + rot.len()) as f64;
    let dof = |n: usize| n as f64 - params as f64 * n as f64 / total;
    Floors {
        point_mm: floor_squared(&pos, dof(pos.len())).sqrt(),
        orientation_rad: floor_squared(&rot, dof(rot.len())).sqrt(),
    }
}

/// Sets every observation's weights to `1/√(σ² + s²)` for the floors `f`.
pub fn apply<const N: usize>(data: &mut [Measurement<f64, N>], stated: &[Stated], f: &Floors) {
    for (m, s) in data.iter_mut().zip(stated) {
        m.weight = s
            .point_mm
            .map(|sd| 1.0 / (sd * sd + f.point_mm * f.point_mm).sqrt());
        if m.orientation.is_some() {
            let v = s.orientation_rad * s.orientation_rad + f.orientation_rad * f.orientation_rad;
            m.orientation_weight = 1.0 / v.sqrt();
        }
        if !m.weight.iter().all(|w| w.is_finite()) {
            m.weight = Vector3::repeat(1.0);
        }
        if !m.orientation_weight.is_finite() {
            m.orientation_weight = 0.0;
        }
    }
}

/// χ² per degree of freedom of the stated σ at `robot` (`None` without σ).
pub fn chi2_per_dof<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    data: &[Measurement<f64, N>],
    stated: &[Stated],
    params: usize,
) -> Option<f64> {
    let (pos, rot) = rows(robot, data, stated);
    let all: Vec<(f64, f64)> = pos.into_iter().chain(rot).collect();
    if all.iter().any(|(_, v)| *v <= 0.0) || all.len() <= params {
        return None;
    }
    let chi: f64 = all.iter().map(|(r, v)| r / v).sum();
    Some(chi / (all.len() - params) as f64)
}

/// Multiplies the orientation weight of every 6-D observation by `c`.
pub fn scale_orientation<const N: usize>(data: &mut [Measurement<f64, N>], c: f64) {
    for m in data.iter_mut().filter(|m| m.orientation.is_some()) {
        m.orientation_weight *= c;
    }
}

/// Factors of the balanced orientation weight that [`choose_orientation_factor`] compares.
pub const ORIENTATION_FACTORS: [f64; 3] = [1.0, 0.25, 0.0625];

/// The factor of the balanced orientation weight under which the fit predicts *positions* best
/// in a `folds`-fold cross-validation over the identification poses (`pose_of[i]`: the pose
/// of observation `i`; each fold is a contiguous run of poses, held out whole), with the
/// cross-validated position RMS of each factor.
///
/// Why: a model that misses an effect (joint-angle errors, say) shows it in positions and
/// orientations differently, and then the variance balance can pull the shared parameters
/// away from what predicts positions, which is what compensation serves. The held-out poses
/// are never used: only the identification poses are cut into folds. An exact tie goes to the
/// larger factor (more weight on what the probe measured).
pub fn choose_orientation_factor<const N: usize, V: kinecal::ValueStorage, F>(
    data: &[Measurement<f64, N>],
    pose_of: &[usize],
    folds: usize,
    mut fit: F,
) -> anyhow::Result<(f64, Vec<(f64, f64)>)>
where
    F: FnMut(&[Measurement<f64, N>]) -> anyhow::Result<Robot<f64, N, V>>,
{
    let poses = pose_of.last().map_or(0, |p| p + 1);
    let folds = folds.min(poses);
    let mut scores = Vec::new();
    for &c in &ORIENTATION_FACTORS {
        let mut scaled = data.to_vec();
        scale_orientation(&mut scaled, c);
        let (mut ss, mut n) = (0.0, 0usize);
        for k in 0..folds {
            let (lo, hi) = (k * poses / folds, (k + 1) * poses / folds);
            let held = |i: usize| (lo..hi).contains(&pose_of[i]);
            let train: Vec<Measurement<f64, N>> = scaled
                .iter()
                .enumerate()
                .filter(|(i, _)| !held(*i))
                .map(|(_, m)| *m)
                .collect();
            let test: Vec<Measurement<f64, N>> = scaled
                .iter()
                .enumerate()
                .filter(|(i, _)| held(*i))
                .map(|(_, m)| *m)
                .collect();
            let robot = fit(&train)?;
            for e in crate::calibration::pose_errors(&robot, &test) {
                ss += e * e;
                n += 1;
            }
        }
        scores.push((c, (ss / n.max(1) as f64).sqrt()));
    }
    let best = scores.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    let c = scores
        .iter()
        .find(|s| s.1 <= best * (1.0 + 1e-9))
        .map_or(1.0, |s| s.0);
    Ok((c, scores))
}

/// How [`weighted_fit`] weighs the observations (what the caller decided from its flags).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Weighting {
    /// Error floors for what the model cannot explain (6-D or σ-weighted data, the weighting
    /// left to the data), refitted until they settle.
    pub balance: bool,
    /// Choose the orientation factor by cross-validation (6-D, no `--deg-weight-mm`, ≥ 20
    /// poses).
    pub orientation_cv: bool,
    /// Parameters the caller estimates (the floors' degrees of freedom).
    pub params: usize,
}

impl Weighting {
    /// The weighting `identify` uses for `poses` identification poses of 6-D and/or
    /// σ-weighted rows under the observation flags `obs`, estimating `params` parameters.
    pub fn of(
        six_d: bool,
        sigma: bool,
        obs: &crate::formats::observations::ObservationArgs,
        poses: usize,
        params: usize,
    ) -> Self {
        Self {
            balance: (six_d && obs.deg_weight_mm.is_none() && !sigma)
                || (sigma && !obs.sigma_as_stated),
            orientation_cv: six_d && obs.deg_weight_mm.is_none() && poses >= 20,
            params,
        }
    }
}

/// What [`weighted_fit`] settled on.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Weighted {
    pub floors: Option<Floors>,
    /// The orientation factor chosen and the cross-validated position RMS of each factor.
    pub orientation_cv: Option<(f64, Vec<(f64, f64)>)>,
}

/// The fit `run` makes of `data` with the weighting of `how`: a first fit, then (balance) the
/// error floors at the fit applied and refitted until they settle (at most four rounds), then
/// (orientation_cv) the orientation factor of [`choose_orientation_factor`] applied and
/// refitted. `data`'s weights are left as the final fit used them. `identify` fits from the
/// file's model; `report` runs the same from the identified model to read its covariance.
pub fn weighted_fit<const N: usize, V: kinecal::ValueStorage, F>(
    data: &mut [Measurement<f64, N>],
    pose_of: &[usize],
    stated: &[Stated],
    how: Weighting,
    run: F,
) -> anyhow::Result<(crate::calibration::Fit<N, V>, Weighted)>
where
    F: Fn(&[Measurement<f64, N>]) -> anyhow::Result<crate::calibration::Fit<N, V>>,
{
    let mut fit = run(data)?;
    let mut out = Weighted::default();
    if how.balance {
        for _ in 0..4 {
            let estimated = how.params.saturating_sub(fit.unidentifiable.len());
            let f = floors(&fit.robot, data, stated, estimated);
            let settled = out.floors.is_some_and(|o| {
                let close = |a: f64, b: f64| (a - b).abs() <= 0.01 * a.abs().max(b.abs());
                close(o.point_mm, f.point_mm) && close(o.orientation_rad, f.orientation_rad)
            });
            out.floors = Some(f);
            if settled {
                break;
            }
            apply(data, stated, &f);
            fit = run(data)?;
        }
    }
    if how.orientation_cv {
        let (c, scores) = choose_orientation_factor(data, pose_of, 5, |d| Ok(run(d)?.robot))?;
        if c != 1.0 {
            scale_orientation(data, c);
            fit = run(data)?;
        }
        out.orientation_cv = Some((c, scores));
    }
    Ok((fit, out))
}
