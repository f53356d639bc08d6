//! The plan's predicted covariance against a Monte Carlo of simulate + identify: a true robot
//! with geometric errors is measured at the planned poses with Gaussian noise, identified by
//! Levenberg–Marquardt from the nominal model (full parameter set, base unknown) hundreds of
//! times, and the spread of the identified tool point at the working configurations is
//! compared with the linear-error-propagation prediction σ²·trace Σ_s C_s (within
//! 15 %). Checked for the KPI design and for random feasible poses (a different geometry of
//! the information matrix), on the example cell.

use kinecal_cli::plan::design::CriterionArg;
use kinecal_cli::plan::study::{arm, cell, monte_carlo};

fn run(criterion: CriterionArg, runs: usize, seed: u64) -> (f64, f64, f64) {
    let robot = arm(780.0, 760.0).unwrap();
    let scene = cell(780.0, 760.0).unwrap();
    let work = [
        [0.0f64, 30.0, 10.0, 0.0, -40.0, 0.0].map(f64::to_radians),
        [-20.0f64, 30.0, 30.0, 0.0, -60.0, 0.0].map(f64::to_radians),
    ];
    let m = monte_carlo(&robot, &scene, criterion, &work, 60, 1500, 0.01, runs, seed).unwrap();
    (
        m.predicted_trace_mm2,
        m.empirical_trace_mm2,
        m.empirical_mse_mm2,
    )
}

#[test]
fn predicted_tcp_covariance_agrees_with_monte_carlo_of_simulate_and_identify() {
    for (criterion, seed) in [(CriterionArg::Kpi, 21), (CriterionArg::Random, 22)] {
        let (predicted, empirical, mse) = run(criterion, 1000, seed);
        let ratio = empirical / predicted;
        eprintln!("{criterion:?}: predicted {predicted:.4e} mm², Monte Carlo {empirical:.4e} mm² (ratio {ratio:.3}), MSE {mse:.4e} mm²");
        assert!(
            (ratio - 1.0).abs() <= 0.15,
            "{criterion:?}: Monte Carlo / predicted = {ratio}"
        );
        // The estimate is unbiased at the tool: mean squared error ≈ variance.
        assert!(
            (mse / empirical - 1.0).abs() <= 0.1,
            "{criterion:?}: MSE {mse} vs variance {empirical}"
        );
    }
}
