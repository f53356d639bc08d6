//! The noise floor against the held-out errors, on few poses and on many.

use super::*;

/// `diagnose` of `arm`'s nominal model on `ident`, with the default configuration.
fn diagnose_arm(arm: &Arm, ident: &[Measurement<f64, 6>]) -> kinecal_cli::diagnose::Diagnosis<6> {
    kinecal_cli::diagnose::diagnose(
        &arm.nominal,
        arm.base_known,
        &[],
        ident,
        &Default::default(),
    )
    .unwrap()
}

fn rms_of(sq: &[f64]) -> f64 {
    (sq.iter().sum::<f64>() / sq.len() as f64).sqrt()
}

/// On 24 poses (5 folds of ~19 identification poses for ~25 parameters) the held-out errors
/// carry much more than the noise: the floor must not exceed what held-out poses reach, and
/// still be of the noise's size. Nothing is hidden: nothing is named, and the final model is
/// the baseline's own fit.
#[test]
fn noise_floor_never_exceeds_the_held_out_rms_on_few_poses() {
    let sigma = 0.02;
    let truth = 3f64.sqrt() * sigma;
    for arm in arms() {
        for seed in [1u64, 2, 3] {
            let (ident, held) = nothing_hidden(&arm, 24, 100, sigma, seed);
            let d = diagnose_arm(&arm, &ident);
            let unseen = rms_of(&squared_errors(&d.model, &held));
            let line = format!(
                "{} seed {seed}: floor {:.4} [{:.4}, {:.4}] (true {truth:.4}), cross-validated {:.4}, unseen poses {unseen:.4}, found {}",
                arm.name,
                d.noise_floor_mm,
                d.noise_floor_interval_mm[0],
                d.noise_floor_interval_mm[1],
                d.final_validation_rms_mm,
                d.found.len()
            );
            eprintln!("{line}");
            assert_eq!(d.noise_source, kinecal_cli::diagnose::NoiseSource::HeldOut);
            assert!(
                d.noise_floor_mm.is_finite() && d.noise_floor_mm > 0.0,
                "{line}"
            );
            assert!(d.noise_floor_mm <= d.final_validation_rms_mm, "{line}");
            // Of the noise's size (the estimate has ~45 degrees of freedom here).
            assert!((0.7..1.4).contains(&(d.noise_floor_mm / truth)), "{line}");
            let [lo, hi] = d.noise_floor_interval_mm;
            assert!(lo < d.noise_floor_mm && d.noise_floor_mm < hi, "{line}");
            // Nothing hidden: nothing named, and the final model is the baseline's fit.
            assert!(d.found.is_empty(), "{line}");
            assert_eq!(d.final_validation_rms_mm, d.baseline_validation_rms_mm);
            assert_eq!(
                squared_errors(&d.model, &held),
                squared_errors(&d.baseline_model, &held),
                "{line}: the final model is a different fit than the baseline's"
            );
        }
    }
}

/// On many poses the fold fits add little, and the floor is an honest estimate of √3 σ.
#[test]
fn noise_floor_is_the_noise_level_on_many_poses() {
    let sigma = 0.02;
    let truth = 3f64.sqrt() * sigma;
    for arm in arms() {
        for seed in [5u64, 6] {
            let (ident, _) = nothing_hidden(&arm, 200, 0, sigma, seed);
            let d = diagnose_arm(&arm, &ident);
            let line = format!(
                "{} seed {seed}: floor {:.4} [{:.4}, {:.4}] / true {truth:.4} = {:.3}, cross-validated {:.4}",
                arm.name,
                d.noise_floor_mm,
                d.noise_floor_interval_mm[0],
                d.noise_floor_interval_mm[1],
                d.noise_floor_mm / truth,
                d.final_validation_rms_mm
            );
            eprintln!("{line}");
            assert!((0.8..1.25).contains(&(d.noise_floor_mm / truth)), "{line}");
            assert!(d.noise_floor_mm <= d.final_validation_rms_mm, "{line}");
            let [lo, hi] = d.noise_floor_interval_mm;
            assert!(
                lo < truth && truth < hi,
                "{line}: interval misses the truth"
            );
            assert!(hi / lo < 1.3, "{line}: interval too wide for 200 poses");
        }
    }
}
