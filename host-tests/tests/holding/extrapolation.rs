//! A model fitted on poses that barely move the joints, judged across the joint ranges
//! (`kinecal::calibration::extrapolation` in the command line's crate): its held-out poses lie
//! among the identified ones and cannot judge it there.

use crate::acceptance::{er20_unplaced, truth, with_limits};
use crate::common::*;

/// The truth's file with every joint kept within `half`° of one ordinary pose.
fn narrowed(t: &str, half: f64) -> String {
    let at = [34.6, -31.5, 14.1, 84.2, 118.2, -123.9];
    let limits: Vec<(usize, f64, f64)> = at
        .iter()
        .enumerate()
        .map(|(j, q)| (j + 1, q - half, q + half))
        .collect();
    with_limits(t, &limits)
}

/// 150 poses within ±3° of one pose: identify met its held-out poses (drawn from the same few
/// degrees, 0.03 mm) and wrote a model that misses the workspace by millimetres (exit 0,
/// "predicted better than by the starting model"); identify and diagnose now refuse it (exit
/// 3, nothing written), and the workspace says they are right. Poses within ±22.5° (a 45°
/// span) determine the model: accepted, and better than nominal there.
#[test]
fn a_model_from_poses_in_a_few_degrees_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let t = std::fs::read_to_string(truth(d)).unwrap();
    let robot = write(d, "robot.toml", &er20_unplaced());
    let wide = d.join("wide.csv");
    simulate(
        &write(d, "t.toml", &t),
        Some(300),
        Some(0.02),
        Some(13),
        &[],
        &wide,
    );
    for (half, refused) in [(3.0, true), (22.5, false)] {
        let data = d.join(format!("narrow{half}.csv"));
        let narrow = write(d, &format!("narrow{half}.toml"), &narrowed(&t, half));
        simulate(&narrow, Some(150), Some(0.02), Some(3), &[], &data);
        let out = d.join(format!("m{half}.toml"));
        let o = run_on(
            "identify",
            &robot,
            &data,
            &["--holdout", "0.3", "--out", s(&out)],
        );
        let err = stderr(&o);
        // What the workspace says of the same fit (its poses beyond the identified ranges
        // measure the model there, so the held-out verdict judges it, not the covariance).
        let j: serde_json::Value = serde_json::from_slice(
            &run_on(
                "identify",
                &robot,
                &data,
                &["--json", "--validate", s(&wide)],
            )
            .stdout,
        )
        .unwrap();
        let (nominal, model) = (
            j["before"]["validation_rms_mm"].as_f64().unwrap(),
            j["after"]["validation_rms_mm"].as_f64().unwrap(),
        );
        eprintln!("±{half}°: workspace {model} mm against the nominal's {nominal} mm");
        if refused {
            assert_eq!(o.status.code(), Some(3), "{err}");
            assert!(
                err.contains("not determined across the joint ranges"),
                "{err}"
            );
            assert!(!out.exists());
            // The workspace is missed by tens of times what the fit claims (on the KR16-like
            // arm of explorer 14 also by more than the nominal robot file, 2.5 against 1.8 mm).
            let fitted = j["after"]["identification_rms_mm"].as_f64().unwrap();
            assert!(model > 20.0 * fitted, "{model} vs {fitted}: {err}");
            let o = run_on("diagnose", &robot, &data, &["--holdout", "0.3"]);
            assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
            assert!(
                stderr(&o).contains("not determined across the joint ranges"),
                "{}",
                stderr(&o)
            );
        } else {
            assert_eq!(o.status.code(), Some(0), "{err}");
            assert!(!err.contains("not determined"), "{err}");
            assert!(model < nominal, "{model} vs {nominal}");
        }
    }
}
