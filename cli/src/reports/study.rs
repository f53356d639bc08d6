//! The report of `kinecal study`.

use super::plain_report;
use serde::Serialize;
use std::fmt;

/// `kinecal study`: the planning study's table, per-arm figures and Monte Carlo check.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct StudyReport {
    /// Manipulators studied.
    pub arms: usize,
    /// Measurement poses per design.
    pub poses: usize,
    pub noise_mm: f64,
    /// The working configuration as given (degrees, comma-separated).
    pub work_deg: String,
    /// With, then without collision avoidance.
    pub table: Vec<SettingRow>,
    pub monte_carlo: Option<MonteCarloReport>,
    pub per_arm: Vec<ArmRow>,
    pub seconds: f64,
    /// Worker threads used (text only).
    #[serde(skip)]
    pub threads: usize,
    /// The figure written (text only).
    #[serde(skip)]
    pub figure: Option<String>,
}

/// One setting (with or without collision avoidance) over all arms.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SettingRow {
    pub collision_avoidance: bool,
    pub designs: Designs,
    /// Designs planned without collision avoidance: mean share of their poses that collide in
    /// the full cell (`None` with collision avoidance).
    pub colliding_share: Option<f64>,
}

/// The three designs compared.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Designs {
    pub random: DesignStats,
    pub d_o1: DesignStats,
    pub kpi: DesignStats,
}

impl Designs {
    /// `(name, stats)` in the table's order.
    pub fn rows(&self) -> [(&'static str, &DesignStats); 3] {
        [
            ("random", &self.random),
            ("d_o1", &self.d_o1),
            ("kpi", &self.kpi),
        ]
    }
}

/// One design over all arms: its predicted TCP trace and the KPI design's improvement over it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct DesignStats {
    pub mean_kpi_trace_mm2: f64,
    pub min_kpi_trace_mm2: f64,
    pub max_kpi_trace_mm2: f64,
    /// `1 − KPI/this` (`None` for the KPI design itself).
    pub kpi_improvement_mean: Option<f64>,
    pub kpi_improvement_min: Option<f64>,
    pub kpi_improvement_max: Option<f64>,
}

/// The Monte Carlo check of the predicted covariance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct MonteCarloReport {
    pub runs: usize,
    pub predicted_trace_mm2: f64,
    pub empirical_trace_mm2: f64,
    pub ratio: f64,
    pub empirical_mse_mm2: f64,
    pub seconds: f64,
}

/// One arm's predicted TCP traces (mm²).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ArmRow {
    pub upper_arm_mm: f64,
    pub forearm_mm: f64,
    pub with: ArmDesigns,
    pub without: ArmDesignsWithout,
}

/// With collision avoidance.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ArmDesigns {
    pub random: f64,
    pub d_o1: f64,
    pub kpi: f64,
}

/// Without collision avoidance, and the share of the designs' poses that collide.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct ArmDesignsWithout {
    pub random: f64,
    pub d_o1: f64,
    pub kpi: f64,
    pub colliding_share: f64,
}

plain_report!(StudyReport);

impl fmt::Display for StudyReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(
            f,
            "{} arms × {} poses, σ = {} mm, working configuration {}°",
            self.arms, self.poses, self.noise_mm, self.work_deg
        )?;
        writeln!(f, "setting                      design   mean TCP trace (mm²)   min        max        KPI improvement mean [min, max]")?;
        for row in &self.table {
            let name = if row.collision_avoidance {
                "with collision avoidance"
            } else {
                "without collision avoidance"
            };
            for (design, s) in row.designs.rows() {
                let imp_text = match (
                    s.kpi_improvement_mean,
                    s.kpi_improvement_min,
                    s.kpi_improvement_max,
                ) {
                    (Some(im), Some(imin), Some(imax)) => format!(
                        "{:5.1} % [{:.1}, {:.1}]",
                        100.0 * im,
                        100.0 * imin,
                        100.0 * imax
                    ),
                    _ => String::new(),
                };
                let (mean, min, max) = (
                    s.mean_kpi_trace_mm2,
                    s.min_kpi_trace_mm2,
                    s.max_kpi_trace_mm2,
                );
                writeln!(
                    f,
                    "{name:28} {design:8} {mean:12.4e}          {min:.3e}  {max:.3e}  {imp_text}"
                )?;
            }
            if let Some(c) = row.colliding_share {
                writeln!(f, "  (designs planned without collision avoidance: {:.0} % of their poses collide in the full cell)", 100.0 * c)?;
            }
        }
        writeln!(
            f,
            "study: {:.1} s on {} threads",
            self.seconds, self.threads
        )?;
        if let Some(m) = &self.monte_carlo {
            writeln!(
                f,
                "Monte Carlo ({} runs of simulate + LM identify, example arm, KPI design): predicted TCP trace {:.4e} mm², \
                 sample covariance trace {:.4e} mm² (ratio {:.3}), mean squared error {:.4e} mm²; {:.1} s",
                m.runs,
                m.predicted_trace_mm2,
                m.empirical_trace_mm2,
                m.ratio,
                m.empirical_mse_mm2,
                m.seconds
            )?;
        }
        if let Some(path) = &self.figure {
            writeln!(f, "figure written to {path}")?;
        }
        Ok(())
    }
}
