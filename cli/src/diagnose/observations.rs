//! The diagnosed model fitted to everything the file observed: 6-D poses, the tracker's σ and
//! several reflectors (docs/formats.md).
//!
//! The search ([`super::diagnose`]) screens, cross-validates and tests on every observation
//! with the weights [`super::search_weights`] settles on at the geometric fit. What it names is
//! then fitted here to all observations as `identify` fits them (weights refitted with the
//! model, the orientation factor chosen by cross-validation), so that the model `diagnose`
//! writes is identify's fit of that parameter set:
//!
//! 1. the geometry's identifiability is decided again on all observations (6-D data determine
//!    what positions alone hold, theta6 against the tool point);
//! 2. weights: each residual by its stated σ plus an error floor for what the model cannot
//!    explain ([`crate::calibration::weights`]), refitted until the floors settle; with 6-D
//!    data and no `--deg-weight-mm`, the orientation weight that predicts positions best in a
//!    5-fold cross-validation over the searched poses;
//! 3. the geometry alone and the extended model (the search's parameter set, its tables
//!    penalised as in the search) are fitted with the same weights, so their errors compare.

use crate::calibration::weights::{self, weighted_fit, Weighting};
use crate::calibration::{fit_lm, Fit, Residuals};
use crate::diagnose::linear::Problem;
use crate::diagnose::refit::fit;
use crate::diagnose::{Config, Diagnosis};
use crate::formats::observations::ObservationArgs;
use crate::HostRobot;
use kinecal::identify::lm::LmConfig;
use kinecal::model::param::{Param, ParamSet};
use kinecal::Measurement;

/// What the file observed and how the user asked it to be weighed.
#[derive(Clone, Copy, Debug)]
pub struct Observations<'a> {
    /// Orientation observed.
    pub six_d: bool,
    /// The file's σ columns weight the residuals.
    pub sigma: bool,
    /// The weighting flags (`--deg-weight-mm`, `--sigma-as-stated`, …).
    pub obs: &'a ObservationArgs,
}

/// The geometry and the extended model fitted to all observations.
#[derive(Clone, Debug)]
pub struct FullFit<const N: usize> {
    /// The geometry (the nominal model's effects at their file values) on all observations.
    pub geometric: HostRobot<N>,
    /// The extended model on all observations: what `diagnose --out` writes.
    pub model: HostRobot<N>,
    /// Geometric parameters all observations cannot determine (held at nominal).
    pub unidentifiable: Vec<String>,
    /// The observations with the weights the fits used.
    pub weighted: Vec<Measurement<f64, N>>,
    /// The error floors and the orientation factor the weighting settled on.
    pub weighting: weights::Weighted,
    /// χ² per degree of freedom of the stated σ at the extended model.
    pub chi2_per_dof: Option<f64>,
}

impl<const N: usize> FullFit<N> {
    /// Errors of the geometry (`before`) and the extended model (`after`) on the searched
    /// observations and on `held` ones.
    pub fn residuals(&self, held: &[Measurement<f64, N>]) -> (Residuals, Residuals) {
        (
            Residuals::of(&self.geometric, &self.weighted, held),
            Residuals::of(&self.model, &self.weighted, held),
        )
    }
}

/// Parameters only several points or an orientation determine: the further points' offsets
/// and, with 6-D data, the tool axes.
fn observation_params<const N: usize>(robot: &HostRobot<N>, six_d: bool) -> Vec<Param> {
    let mut out = Vec::new();
    if six_d {
        out.extend([Param::ToolRx, Param::ToolRy, Param::ToolRz]);
    }
    for k in 1..robot.tool_point_count() {
        out.extend((0..3).map(|a| Param::ToolPoint(k as u8, a)));
    }
    out
}

/// Fits the geometry and `d`'s extended model to `data` (all observations of the searched
/// poses; `pose_of[i]` is the pose of observation `i`), weighted as `w` says.
/// `tool_axes_unknown`: the robot file gives no `[tool] rpy_deg`, so the tool axes are started
/// from the data (as `identify` does).
pub fn fit_all_observations<const N: usize>(
    d: &Diagnosis<N>,
    data: &[Measurement<f64, N>],
    pose_of: &[usize],
    w: Observations,
    base_known: bool,
    tool_axes_unknown: bool,
    cfg: &Config,
) -> anyhow::Result<FullFit<N>> {
    let (penalty, iterations) = (cfg.penalty, cfg.refit_iterations);
    let mut start_geo = d.baseline_model.clone();
    let mut start_ext = d.model.clone();
    if w.six_d && tool_axes_unknown {
        if let Some(axes) = crate::compute::registration::fit_tool_axes(&start_ext, data) {
            for r in [&mut start_geo, &mut start_ext] {
                r.set_tool_axes(axes)
                    .map_err(|e| anyhow::anyhow!("estimated tool orientation is invalid: {e:?}"))?;
            }
        }
    }
    let extra = observation_params(&start_ext, w.six_d);
    // 1. Which geometric parameters all observations determine.
    let mut geometric: Vec<Param> = ParamSet::<64>::full(N, !base_known)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?
        .as_slice()
        .to_vec();
    geometric.extend(d.free_tilt.iter().map(|j| Param::Beta(*j as u8)));
    geometric.extend(extra.iter().copied());
    let mut weighted = data.to_vec();
    let stated = weights::stated(&weighted, w.sigma);
    let analysis = fit_lm(&start_geo, &geometric, &weighted, LmConfig::default())?;
    let unidentifiable = analysis.unidentifiable.clone();
    geometric.retain(|p| {
        !unidentifiable
            .iter()
            .any(|n| *n == p.name(&analysis.robot).to_string())
    });
    // The extended model's parameters: that geometry plus every effect value, in the model's
    // order (a table's knots consecutive, as the search's problems have them).
    let mut params = geometric.clone();
    params.extend(
        d.params
            .iter()
            .copied()
            .filter(|p| matches!(p, Param::Effect(_))),
    );
    let problem = Problem::new(&start_ext, &params, penalty)?;
    let run = |data: &[Measurement<f64, N>]| {
        let o = fit(&start_ext, &problem, data, iterations)?;
        Ok(Fit::plain(o.robot, o.iterations, 0, Vec::new()))
    };
    // 2. Error floors and the orientation weight, as identify weighs (calibration::weights).
    let poses = pose_of.last().map_or(0, |p| p + 1);
    let how = Weighting::of(w.six_d, w.sigma, w.obs, poses, params.len());
    let (ext, weighted_how) = weighted_fit(&mut weighted, pose_of, &stated, how, run)?;
    // 3. The geometry with the same weights, for the comparison.
    let geo = fit_lm(&start_geo, &geometric, &weighted, LmConfig::default())?;
    let chi2_per_dof = if w.sigma {
        weights::chi2_per_dof(&ext.robot, &weighted, &stated, params.len())
    } else {
        None
    };
    Ok(FullFit {
        geometric: geo.robot,
        model: ext.robot,
        unidentifiable,
        weighted,
        weighting: weighted_how,
        chi2_per_dof,
    })
}
