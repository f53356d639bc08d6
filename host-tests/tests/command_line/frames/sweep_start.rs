//! `identify` started from the sweeps' base converges as well as from registration.

use super::*;

/// The sweeps' last promise: `identify` started from the base the sweeps give converges as well
/// as from point-set registration. The true robot has geometric errors (so the nominal rows
/// the sweeps are interpreted with are off by up to 0.8 mm and 0.1°); both runs fit the 24 MDH
/// parameters and the tool, the registration run the base as well.
#[test]
fn identify_from_the_sweep_base_converges_as_well_as_from_registration() {
    use kinecal_cli::simulation::{
        dataset, measure, perturb_geometry, random_configurations, GeomErrors, Streams,
    };
    let dir = tempfile::tempdir().unwrap();
    let robot_path = write_robot(dir.path(), &ER20, ER20_TOOL);
    for seed in [1u64, 2] {
        let mut streams = Streams::new(seed);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed + 40);
        let nominal: Robot<f64, 6, kinecal::Inline<0>> =
            robot(&ER20, ER20_TOOL, random_base(&mut rng));
        let truth = perturb_geometry(&nominal, &GeomErrors::default(), &mut streams.errors);
        let sigma = 0.015;
        // Sweeps on the true robot, interpreted with the nominal rows.
        let sweeps = sweep_data(
            &truth,
            &default_rest(&truth),
            &[1, 2, 5, 6],
            24,
            360.0,
            sigma,
            seed,
        )
        .unwrap();
        let sweep_csv = dir.path().join("sweeps.csv");
        measurements::write(&sweep_csv, &sweeps).unwrap();
        let with_base = dir.path().join("with_base.toml");
        find_frames(&robot_path, &sweep_csv, Some(&with_base)).unwrap();
        // 50 identification and 50 validation poses.
        let write = |name: &str, n: usize, streams: &mut Streams| {
            let q = random_configurations(&truth, n, &mut streams.configs);
            let p = measure(&truth, &q, sigma, &mut streams.noise);
            let path = dir.path().join(name);
            measurements::write(&path, &dataset(&q, &p)).unwrap();
            path
        };
        let ident = write("ident.csv", 50, &mut streams);
        let valid = write("valid.csv", 50, &mut streams);
        let fit = |robot: &std::path::Path| {
            // `kinecal identify` end to end, so options added to it keep their defaults.
            let out = std::process::Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
                .args([
                    "identify",
                    "--robot",
                    robot.to_str().unwrap(),
                    "--data",
                    ident.to_str().unwrap(),
                    "--method",
                    "lm",
                    "--validate",
                    valid.to_str().unwrap(),
                    "--seed",
                    "1",
                    "--json",
                ])
                .output()
                .unwrap();
            assert!(
                out.status.success(),
                "{}",
                String::from_utf8_lossy(&out.stderr)
            );
            let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
            (
                v["after"]["validation_rms_mm"].as_f64().unwrap(),
                v["before"]["validation_rms_mm"].as_f64().unwrap(),
            )
        };
        let (from_sweeps, before_sweeps) = fit(&with_base);
        let (from_registration, before_registration) = fit(&robot_path);
        let floor = 3f64.sqrt() * sigma;
        println!(
            "seed {seed}: validation RMS before {before_sweeps:.3} (sweep base) / {before_registration:.3} (registration) mm; after {from_sweeps:.4} / {from_registration:.4} mm; noise floor {floor:.4} mm"
        );
        assert!(
            from_sweeps < 1.3 * floor,
            "from the sweep base: {from_sweeps} mm"
        );
        assert!(
            from_sweeps < 1.1 * from_registration + 0.002,
            "sweeps {from_sweeps} vs registration {from_registration}"
        );
    }
}
