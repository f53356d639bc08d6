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

#[cfg(test)]
mod tests {
    use super::*;

    fn row(method: &str, iterations: u32) -> MethodRow {
        let e = DemoErrors {
            identification_rms_mm: 1.0,
            validation_rms_mm: 2.0,
            validation_mean_mm: 1.5,
            validation_max_mm: 3.0,
        };
        MethodRow {
            method: method.into(),
            iterations,
            evaluations: 10,
            best_fitness: 0.0123,
            seconds: 0.5,
            before: e,
            after: e,
            iterations_to_final: None,
            iterations_to_pso_final: None,
        }
    }

    /// Every column of the table ends where its heading ends, whatever the iteration count.
    #[test]
    fn the_table_columns_line_up() {
        let r = DemoReport {
            robot: "ER20-C10 stand-in".into(),
            noise_mm: 0.01,
            n_identification: 50,
            n_validation: 50,
            factory_pso_iterations: 1000,
            drift: Drift {
                angle_deg: 0.002,
                length_mm: 0.01,
                validation_rms_mm: Some(0.07),
            },
            methods: vec![row("pso", 1000), row("lm", 4), row("pso+lm", 1004)],
            bpnn_pso_iteration_ratio: None,
            figures: Vec::new(),
        };
        let text = r.to_string();
        assert!(text.starts_with(
            "BPNN-PSO paper simulation (ER20-C10 stand-in, 50 + 50 poses, 10 µm noise)\n"
        ));
        let lines: Vec<&str> = text.lines().collect();
        let head = lines[2];
        let ends = |l: &str| -> Vec<usize> {
            let mut v = Vec::new();
            let chars: Vec<char> = l.chars().collect();
            for i in 0..chars.len() {
                if chars[i] != ' ' && chars.get(i + 1).is_none_or(|c| *c == ' ') {
                    v.push(i);
                }
            }
            v
        };
        // The heading "best fitness" has a space inside: compare the right-aligned columns by
        // their last characters, method (left-aligned) aside.
        let h = ends(head);
        for l in &lines[3..6] {
            let e = ends(l);
            assert_eq!(e.len(), 8, "{l}");
            assert_eq!(
                e[1..],
                [h[1], h[3], h[4], h[6], h[8], h[10], h[12]],
                "{l}\n{head}"
            );
        }
    }
}
