//! The figures of the human output: distinct when they differ, one fit when nothing is added.

use super::*;

/// Figures that differ print differently; equal ones alike; never `inf` or `NaN`.
#[test]
fn figures_that_differ_print_differently() {
    use kinecal_cli::diagnose::distinct_figures;
    assert_eq!(distinct_figures([0.0178, 0.0174]), ["0.0178", "0.0174"]);
    let [a, b] = distinct_figures([0.29720, 0.29724]);
    assert_ne!(a, b);
    assert_eq!((a.as_str(), b.as_str()), ("0.29720", "0.29724"));
    assert_eq!(distinct_figures([0.2972, 0.2972]), ["0.297", "0.297"]);
    let [x, y, z] = distinct_figures([f64::NAN, f64::INFINITY, 0.05]);
    assert_eq!((x.as_str(), y.as_str(), z.as_str()), ("-", "-", "0.0500"));
}

/// The numbers in `text` (tokens that parse as f64, punctuation around them trimmed).
fn numbers(text: &str) -> Vec<(String, f64)> {
    text.split(|c: char| c.is_whitespace() || c == '(' || c == ')' || c == '[' || c == ']')
        .map(|t| t.trim_end_matches([',', ';', ':', '.']))
        .filter_map(|t| t.parse::<f64>().ok().map(|v| (t.to_string(), v)))
        .collect()
}

/// `printed` shows `value` to at least three significant digits.
fn shows(printed: &(String, f64), value: f64) -> bool {
    (printed.1 - value).abs() <= 0.005 * value.abs() + 1e-15
}

fn kinecal(argv: &[&str]) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
        .args(argv)
        .output()
        .unwrap();
    let stdout = String::from_utf8(out.stdout).unwrap();
    assert!(
        out.status.success(),
        "kinecal {argv:?}: {}\n{stdout}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

/// The user's case, simulated: 24 poses searched, 6 held out, nothing hidden. The JSON's
/// starting and extended figures are one fit (equal exactly), the floor is below both held-out
/// figures, and the human output says it once, with no `inf`/`NaN`.
#[test]
fn nothing_added_reports_one_fit_and_a_floor_below_the_held_out_errors() {
    let tmp = tempfile::tempdir().unwrap();
    let arms = arms();
    for (arm, seed) in [(&arms[0], 11u64), (&arms[1], 12)] {
        let (mut ident, held) = nothing_hidden(arm, 24, 6, 0.02, seed);
        ident.extend(held);
        let path = tmp.path().join(format!("{}.csv", arm.name));
        let mut points = Vec::new();
        let mut configs = Vec::new();
        for m in &ident {
            configs.push(m.q);
            points.push(m.point);
        }
        measurements::write(&path, &kinecal_cli::simulation::dataset(&configs, &points)).unwrap();
        let robot = data_dir().join(format!("{}.toml", arm.name));
        let argv = [
            "diagnose",
            "--robot",
            robot.to_str().unwrap(),
            "--data",
            path.to_str().unwrap(),
            "--holdout",
            "6",
        ];
        let r = run(&parse_args(&argv[1..])).unwrap().to_value();
        assert_eq!(r["poses"], 24);
        assert_eq!(r["found"].as_array().unwrap().len(), 0, "{r:#}");
        let base = r["baseline_validation_rms_mm"].as_f64().unwrap();
        let fin = r["final_validation_rms_mm"].as_f64().unwrap();
        let floor = r["noise_floor_mm"].as_f64().unwrap();
        let h = &r["holdout"];
        let (hg, hf) = (
            h["geometric_rms_mm"].as_f64().unwrap(),
            h["final_rms_mm"].as_f64().unwrap(),
        );
        eprintln!(
            "{}: cross-validated {base:.5} → {fin:.5}, floor {floor:.5}, held-out {hg:.5} → {hf:.5}",
            arm.name
        );
        assert_eq!(base, fin);
        assert_eq!(hg, hf, "refitted and extended are different fits");
        assert!(
            floor <= fin && floor <= hf,
            "floor {floor} above {fin} / {hf}"
        );
        let iv = r["noise_floor_interval_mm"].as_array().unwrap();
        assert!(iv[0].as_f64().unwrap() <= floor && floor <= iv[1].as_f64().unwrap());
        // Human output: one held-out figure, shown to three significant digits or more.
        let text = kinecal(&argv);
        eprintln!("{text}");
        for bad in ["NaN", "inf", " → -"] {
            assert!(!text.contains(bad), "{bad} in:\n{text}");
        }
        let line = text
            .lines()
            .find(|l| l.starts_with("held-out poses (6)"))
            .unwrap_or_else(|| panic!("no held-out line in:\n{text}"));
        assert!(
            !line.contains('→') && line.contains("nothing added"),
            "{line}"
        );
        let nums = numbers(line);
        assert_eq!(nums.len(), 2, "{line}"); // "(6)" and the figure
        assert!(shows(&nums[1], hf), "{line} vs {hf}");
        let summary = text.lines().nth(1).unwrap();
        let nums = numbers(summary);
        assert!(shows(&nums[0], base) && shows(&nums[1], floor), "{summary}");
    }
}

/// Something found: every figure of the headline, the sentence and the held-out line is shown
/// to at least three significant digits, and figures that differ print differently (without
/// held-out poses the final cross-validated RMS and the floor differ by a few % only).
#[test]
fn human_output_shows_small_differences() {
    let tmp = tempfile::tempdir().unwrap();
    let (robot, data) = write_case(
        tmp.path(),
        vec![effect("joint-compliance", 2, &[2e-4], 1)],
        4,
    );
    let argv = [
        "diagnose",
        "--robot",
        robot.to_str().unwrap(),
        "--data",
        data.to_str().unwrap(),
    ];
    let r = run(&parse_args(&argv[1..])).unwrap().to_value();
    assert_eq!(r["found"].as_array().unwrap().len(), 1, "{r:#}");
    let base = r["baseline_validation_rms_mm"].as_f64().unwrap();
    let fin = r["final_validation_rms_mm"].as_f64().unwrap();
    let floor = r["noise_floor_mm"].as_f64().unwrap();
    assert!(floor < fin && fin < 1.1 * floor, "{fin} vs {floor}");
    let text = kinecal(&argv);
    eprintln!("{text}");
    for bad in ["NaN", "inf"] {
        assert!(!text.contains(bad), "{bad} in:\n{text}");
    }
    // "1 effect(s) missing from the model: held-out RMS A → B mm, noise floor C mm."
    let summary = text.lines().nth(1).unwrap();
    let nums = numbers(summary);
    assert_eq!(nums.len(), 4, "{summary}");
    for (n, v) in nums[1..].iter().zip([base, fin, floor]) {
        assert!(shows(n, v), "{summary}: {} shows {v}", n.0);
    }
    assert_ne!(
        nums[2].0, nums[3].0,
        "{summary}: final and floor print alike"
    );
    // The sentence of the effect (under its explanation): the same figures.
    assert!(text
        .lines()
        .any(|l| l.starts_with("  1. Joint 2 deflects under load")));
    let sentence = text
        .lines()
        .find(|l| l.starts_with("     The search: "))
        .unwrap();
    assert!(
        sentence.contains(&format!("{} → {} mm", nums[1].0, nums[2].0)),
        "{sentence}"
    );
    // With held-out poses: "held-out poses (20): starting model refitted X mm → extended
    // model Y mm".
    let argv = [&argv[..], &["--holdout", "20"]].concat();
    let r = run(&parse_args(&argv[1..])).unwrap().to_value();
    let hg = r["holdout"]["geometric_rms_mm"].as_f64().unwrap();
    let hf = r["holdout"]["final_rms_mm"].as_f64().unwrap();
    assert!(r["noise_floor_mm"].as_f64().unwrap() <= hf);
    let text = kinecal(&argv);
    eprintln!("{text}");
    let line = text
        .lines()
        .find(|l| l.starts_with("held-out poses (20)"))
        .unwrap();
    let nums = numbers(line);
    assert_eq!(nums.len(), 3, "{line}");
    assert!(shows(&nums[1], hg) && shows(&nums[2], hf), "{line}");
    assert_ne!(nums[1].0, nums[2].0, "{line}");
}
