//! Options from Python: the keyword arguments of the `kinecal` functions (a dict that
//! `python/kinecal/__init__.py` fills, `None` for a default) into the application's option
//! structs (`application::identify::Options`, `diagnose::workflow::Options`, compensation
//! `Settings`, the plan and simulation `Request`s) and the loading options (`UnitArgs`,
//! `ObservationArgs`).
//! Values arrive typed (numbers as numbers); a word the command line would refuse (a method, a
//! unit, a split, an effect) is refused in the command line's terms, naming the flag it
//! stands for; the defaults are the application's (`Options::default()`).

use crate::refused;
use clap::ValueEnum;
use kinecal_cli::application::identify::Options as IdentifyOptions;
use kinecal_cli::calibration::inputs::HoldoutArgs;
use kinecal_cli::calibration::SplitKind;
use kinecal_cli::compensation::Settings;
use kinecal_cli::diagnose::workflow::Options as DiagnoseOptions;
use kinecal_cli::formats::observations::ObservationArgs;
use kinecal_cli::formats::units::UnitArgs;
use kinecal_cli::plan::request::Request as PlanRequest;
use kinecal_cli::simulation::request::Request as SimulateRequest;
use pyo3::prelude::*;
use std::fmt::Display;
use std::str::FromStr;

/// The word `s` among the command line's choices for `flag`.
pub fn choice<T: ValueEnum>(flag: &str, s: &str) -> PyResult<T> {
    T::from_str(s, false).map_err(|_| {
        let words: Vec<String> = T::value_variants()
            .iter()
            .filter_map(|v| v.to_possible_value())
            .map(|p| p.get_name().to_string())
            .collect();
        refused(format!("{flag} {s}: give one of {}", words.join(", ")))
    })
}

/// `s` read as the command line reads a value of `flag`; the reason names the flag.
pub fn read<T: FromStr>(flag: &str, s: &str) -> PyResult<T>
where
    T::Err: Display,
{
    s.parse().map_err(|e: T::Err| {
        let why = e.to_string();
        refused(if why.starts_with(flag) {
            why
        } else {
            format!("{flag} {s}: {why}")
        })
    })
}

/// The keyword arguments as one typed struct (`kind` names the function in the reason of a
/// value of the wrong type).
pub fn extract<'py, T>(kind: &str, kw: &Bound<'py, PyAny>) -> PyResult<T>
where
    T: for<'a> FromPyObject<'a, 'py, Error = PyErr>,
{
    kw.extract::<T>().map_err(|e| {
        // PyO3 says which field ("failed to extract field Identify.seed") and, as the cause,
        // why ("'str' object cannot be interpreted as an integer").
        let py = kw.py();
        let text = e.value(py).to_string();
        let field = text.rsplit('.').next().unwrap_or(&text).to_string();
        match e.cause(py) {
            Some(c) => refused(format!("{kind}: {field}: {}", c.value(py))),
            None => refused(format!("{kind}: {text}")),
        }
    })
}

/// `length_unit` and `angle_unit`.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct Units {
    pub length_unit: Option<String>,
    pub angle_unit: Option<String>,
}

impl Units {
    pub fn args(&self) -> PyResult<UnitArgs> {
        Ok(UnitArgs {
            length_unit: self
                .length_unit
                .as_deref()
                .map(|s| choice("--length-unit", s))
                .transpose()?,
            angle_unit: self
                .angle_unit
                .as_deref()
                .map(|s| choice("--angle-unit", s))
                .transpose()?,
            map: None,
        })
    }
}

/// How orientation and σ columns are used.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct Observations {
    pub deg_weight_mm: Option<f64>,
    pub sigma_as_stated: bool,
    pub positions_only: bool,
    pub ignore_sigma: bool,
}

impl Observations {
    pub fn args(&self) -> ObservationArgs {
        ObservationArgs {
            deg_weight_mm: self.deg_weight_mm,
            sigma_as_stated: self.sigma_as_stated,
            positions_only: self.positions_only,
            ignore_sigma: self.ignore_sigma,
        }
    }
}

/// `holdout` (a fraction or a count) and `split` (`last`, `random`, `every:K`).
fn holdout(holdout: Option<f64>, split: Option<&str>) -> PyResult<HoldoutArgs> {
    Ok(HoldoutArgs {
        holdout,
        split: split
            .map(|s| read::<SplitKind>("--split", s))
            .transpose()?
            .unwrap_or_default(),
    })
}

/// `kinecal.identify`'s options.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct Identify {
    pub method: Option<String>,
    pub holdout: Option<f64>,
    pub split: Option<String>,
    pub effects: Vec<String>,
    pub seed: Option<u64>,
    pub fix: Vec<String>,
    pub free: Vec<String>,
    pub only: Vec<String>,
    pub prior: Vec<String>,
    pub tolerance_mm: Option<f64>,
    pub tolerance_deg: Option<f64>,
    pub stall_rms_mm: Option<f64>,
}

impl Identify {
    pub fn options(&self, obs: &Observations) -> PyResult<IdentifyOptions> {
        let d = IdentifyOptions::default();
        Ok(IdentifyOptions {
            method: match &self.method {
                Some(m) => choice("--method", m)?,
                None => d.method,
            },
            holdout: holdout(self.holdout, self.split.as_deref())?,
            effects: self
                .effects
                .iter()
                .map(|e| read("--effect", e))
                .collect::<PyResult<_>>()?,
            seed: self.seed.unwrap_or(d.seed),
            fix: self.fix.clone(),
            free: self.free.clone(),
            only: self.only.clone(),
            prior: self.prior.clone(),
            residuals: false,
            tolerance_mm: self.tolerance_mm.unwrap_or(d.tolerance_mm),
            tolerance_deg: self.tolerance_deg.unwrap_or(d.tolerance_deg),
            stall_rms_mm: self.stall_rms_mm.unwrap_or(d.stall_rms_mm),
            obs: obs.args(),
        })
    }
}

/// `kinecal.diagnose`'s options.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct Diagnose {
    pub holdout: Option<f64>,
    pub split: Option<String>,
    pub seed: Option<u64>,
    pub folds: Option<usize>,
    pub alpha: Option<f64>,
    pub max_order: Option<u16>,
    pub max_effects: Option<usize>,
    pub stall_rms_mm: Option<f64>,
    pub plots: Option<std::path::PathBuf>,
}

impl Diagnose {
    pub fn options(&self, obs: &Observations) -> PyResult<DiagnoseOptions> {
        let d = DiagnoseOptions::default();
        Ok(DiagnoseOptions {
            seed: self.seed.unwrap_or(d.seed),
            holdout: holdout(self.holdout, self.split.as_deref())?,
            folds: self.folds.unwrap_or(d.folds),
            alpha: self.alpha.unwrap_or(d.alpha),
            max_order: self.max_order.unwrap_or(d.max_order),
            max_effects: self.max_effects.unwrap_or(d.max_effects),
            stall_rms_mm: self.stall_rms_mm.unwrap_or(d.stall_rms_mm),
            obs: obs.args(),
        })
    }
}

/// `kinecal.compensate`'s solver settings.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct Compensate {
    pub iterations: Option<u8>,
    pub max_step_deg: Option<f64>,
    pub accept_mm: Option<f64>,
    pub stream: bool,
    pub f32: bool,
    /// The reflector the targets are for (`--tool`).
    pub tool: Option<String>,
}

impl Compensate {
    pub fn settings(&self) -> Settings {
        let d = Settings::default();
        Settings {
            iterations: self.iterations.unwrap_or(d.iterations),
            max_step_deg: self.max_step_deg.unwrap_or(d.max_step_deg),
            accept_mm: self.accept_mm.unwrap_or(d.accept_mm),
            stream: self.stream,
            f32: self.f32,
        }
    }
}

/// `kinecal.plan`'s options (the scene is read by the caller).
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct Plan {
    pub poses: usize,
    pub criterion: String,
    /// Working configurations, degrees.
    pub work: Vec<Vec<f64>>,
    pub seed: Option<u64>,
    pub noise_mm: Option<f64>,
    pub pool: Option<usize>,
    pub passes: Option<u32>,
    pub no_collisions: bool,
    pub no_refine: bool,
}

impl Plan {
    pub fn request(&self) -> PyResult<PlanRequest> {
        // The request holds the configurations as the command line's `--work` gives them.
        let work = self
            .work
            .iter()
            .map(|w| {
                w.iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(",")
            })
            .collect();
        let mut r = PlanRequest::new(self.poses, choice("--criterion", &self.criterion)?, work);
        r.seed = self.seed.unwrap_or(r.seed);
        r.noise_mm = self.noise_mm.unwrap_or(r.noise_mm);
        r.pool = self.pool.unwrap_or(r.pool);
        r.passes = self.passes.unwrap_or(r.passes);
        r.collisions = !self.no_collisions;
        r.refine = !self.no_refine;
        Ok(r)
    }
}

/// `kinecal.simulate`'s options.
#[derive(FromPyObject)]
#[pyo3(from_item_all)]
pub struct Simulate {
    pub poses: Option<usize>,
    pub noise_mm: Option<f64>,
    pub seed: Option<u64>,
    pub geom_errors: bool,
    pub effects: Vec<String>,
    /// The arm warms (or cools) linearly from the first to the second temperature (°C).
    pub temperature: Option<(f64, f64)>,
    /// The poses are taken evenly over this many seconds (a `t_s` column).
    pub session_s: Option<f64>,
    pub sweeps: Vec<usize>,
    pub sweep_points: Option<usize>,
    pub sweep_span_deg: Option<f64>,
}

impl Simulate {
    pub fn request(&self) -> PyResult<SimulateRequest> {
        let d = SimulateRequest::default();
        // Checked as the command line checks `--temperature A:B`.
        let temperature = self
            .temperature
            .map(|(a, b)| {
                kinecal_cli::simulation::request::parse_temperature(&format!("{a}:{b}"))
                    .map_err(refused)
            })
            .transpose()?;
        Ok(SimulateRequest {
            poses: self.poses.unwrap_or(d.poses),
            noise_mm: self.noise_mm.unwrap_or(d.noise_mm),
            seed: self.seed.unwrap_or(d.seed),
            geom_errors: self.geom_errors,
            effects: self.effects.clone(),
            temperature,
            session_s: self.session_s,
            sweeps: self.sweeps.clone(),
            sweep_points: self.sweep_points.unwrap_or(d.sweep_points),
            sweep_span_deg: self.sweep_span_deg.unwrap_or(d.sweep_span_deg),
            ..d
        })
    }
}
