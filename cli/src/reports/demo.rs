//! The report of `kinecal demo`.

use super::plain_report;
use crate::calibration::ErrorStats;
use serde::Serialize;
use std::fmt;

/// `kinecal demo`: the BPNN-PSO paper's simulation, one row per method.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DemoReport {
    /// The simulated robot.
    pub robot: String,
    /// Tracker noise, standard deviation per axis (mm).
    pub noise_mm: f64,
    pub n_identification: usize,
    pub n_validation: usize,
    /// Iterations of the factory identification that trained the BP network.
    pub factory_pso_iterations: u32,
    pub drift: Drift,
    pub methods: Vec<MethodRow>,
    /// BPNN-PSO's iterations to PSO's final fitness over PSO's (null: never reached).
    pub bpnn_pso_iteration_ratio: Option<f64>,
    /// SVG files written.
    pub figures: Vec<String>,
}

/// How far the robot drifted between the two identifications.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Drift {
    pub angle_deg: f64,
    pub length_mm: f64,
    /// The factory model's RMS error on the validation poses (mm).
    pub validation_rms_mm: Option<f64>,
}

/// Errors before or after an identification (mm), as `identify` reports them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DemoErrors {
    pub identification_rms_mm: f64,
    pub validation_rms_mm: f64,
    pub validation_mean_mm: f64,
    pub validation_max_mm: f64,
}

impl DemoErrors {
    /// From the statistics on the identification and on the validation poses.
    pub fn of(identification: &ErrorStats, validation: &ErrorStats) -> Self {
        Self {
            identification_rms_mm: identification.rms_mm,
            validation_rms_mm: validation.rms_mm,
            validation_mean_mm: validation.mean_mm,
            validation_max_mm: validation.max_mm,
        }
    }
}

/// One identification method of the comparison.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MethodRow {
    /// `pso`, `bpnn-pso`, `lm` or `pso+lm`.
    pub method: String,
    pub iterations: u32,
    pub evaluations: u64,
    /// Sum of squared errors on the identification poses (mm²).
    pub best_fitness: f64,
    pub seconds: f64,
    pub before: DemoErrors,
    pub after: DemoErrors,
    /// PSO only: the iteration its final fitness was first reached.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iterations_to_final: Option<usize>,
    /// BPNN-PSO only: the iteration it reached PSO's final fitness (inner `None`: never).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub iterations_to_pso_final: Option<Option<usize>>,
}

plain_report!(DemoReport);

impl fmt::Display for DemoReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "BPNN-PSO paper simulation ({}, {} + {} poses, {} µm noise)",
            self.robot,
            self.n_identification,
            self.n_validation,
            (1e9 * self.noise_mm).round() / 1e6
        )?;
        writeln!(
            f,
            "drift since the factory identification: ±{}°, ±{} mm ({:.3} mm RMS at the tool)",
            self.drift.angle_deg,
            self.drift.length_mm,
            self.drift.validation_rms_mm.unwrap_or(f64::NAN)
        )?;
        writeln!(
            f,
            "{:<9} {:>6} {:>13} {:>9} {:>12} {:>12} {:>12} {:>12}",
            "method",
            "iter",
            "best fitness",
            "seconds",
            "before RMS",
            "after RMS",
            "after mean",
            "after max"
        )?;
        for m in &self.methods {
            writeln!(
                f,
                "{:<9} {:>6} {:>13.4e} {:>9.3} {:>12.4} {:>12.4} {:>12.4} {:>12.4}",
                m.method,
                m.iterations,
                m.best_fitness,
                m.seconds,
                m.before.validation_rms_mm,
                m.after.validation_rms_mm,
                m.after.validation_mean_mm,
                m.after.validation_max_mm,
            )?;
        }
        match self.bpnn_pso_iteration_ratio {
            Some(x) => writeln!(
                f,
                "BPNN-PSO reached PSO's final fitness in {:.0} % of PSO's iterations (paper: 71 / 404 = 18 %)",
                100.0 * x
            )?,
            None => writeln!(f, "BPNN-PSO did not reach PSO's final fitness")?,
        }
        for fig in &self.figures {
            writeln!(f, "figure: {fig}")?;
        }
        Ok(())
    }
}
