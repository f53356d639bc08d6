//! `kinecal diagnose` end to end: stages in order, the effect named, model and plots, refusals.

use super::*;

/// The progress callback sees the stages in the order they run: the geometry, the baseline,
/// then per round a screen of the candidates and a refit of the best families, as many rounds
/// as the result reports; the result equals that of `diagnose`.
#[test]
fn progress_reports_every_stage_in_order() {
    use kinecal_cli::diagnose::{diagnose_with_progress, Progress};
    let (_, d) = simulated(vec![effect("joint-compliance", 2, &[3e-4], 1)], 0.01, 7, 80);
    let mut seen = Vec::new();
    let r = diagnose_with_progress(&er20(), true, &[], &d, &Default::default(), &mut |p| {
        seen.push(p)
    })
    .unwrap();
    assert_eq!(seen[..2], [Progress::Geometry, Progress::Baseline]);
    let mut round = 0;
    for pair in seen[2..].chunks(2) {
        round += 1;
        match pair {
            [Progress::Screen {
                round: a,
                candidates,
            }, Progress::Refit { round: b, families }] => {
                assert_eq!((*a, *b), (round, round));
                assert!(*candidates > 0 && *families > 0 && families <= candidates);
            }
            [Progress::Screen { round: a, .. }] => assert_eq!(*a, round),
            other => panic!("unexpected stages {other:?}"),
        }
    }
    assert!(round >= r.found.len().max(1), "{seen:?}");
    let plain =
        kinecal_cli::diagnose::diagnose(&er20(), true, &[], &d, &Default::default()).unwrap();
    assert_eq!(plain.final_validation_rms_mm, r.final_validation_rms_mm);
}

#[test]
fn diagnose_command_names_the_effect_writes_the_model_and_plots() {
    let tmp = tempfile::tempdir().unwrap();
    let (robot, data) = write_case(
        tmp.path(),
        vec![effect("joint-compliance", 2, &[2e-4], 1)],
        4,
    );
    let mut a = args(robot, data.clone());
    a.out = Some(tmp.path().join("m.toml"));
    a.plots = Some(tmp.path().join("plots"));
    let r = run(&a).unwrap().to_value();
    for key in [
        "baseline_validation_rms_mm",
        "found",
        "final_validation_rms_mm",
        "noise_floor_mm",
    ] {
        assert!(r.get(key).is_some(), "missing {key}");
    }
    let found = r["found"].as_array().unwrap();
    assert_eq!(found.len(), 1, "{r:#}");
    assert_eq!(found[0]["effect"], "joint-compliance");
    assert_eq!(found[0]["joint"], 2);
    let k = found[0]["values"][0].as_f64().unwrap();
    assert!((k - 2e-4).abs() < 2e-5, "compliance {k}");
    let base = r["baseline_validation_rms_mm"].as_f64().unwrap();
    let fin = r["final_validation_rms_mm"].as_f64().unwrap();
    let floor = r["noise_floor_mm"].as_f64().unwrap();
    assert_eq!(found[0]["validation_rms_mm"].as_f64().unwrap(), fin);
    assert!(
        base > 3.0 * floor && fin < 1.25 * floor,
        "{base} → {fin}, floor {floor}"
    );
    assert!(
        (floor / (3f64.sqrt() * 0.02) - 1.0).abs() < 0.25,
        "floor {floor}"
    );
    assert!(found[0]["sentence"]
        .as_str()
        .unwrap()
        .starts_with("joint 2 deflects under load"));
    // The extended model reads back with its effect, and reproduces the data as well.
    let model = RobotFile::load(&tmp.path().join("m.toml")).unwrap();
    assert!(model.base.is_some());
    assert_eq!(model.effects.len(), 1);
    assert_eq!(model.effects[0].kind, "joint-compliance");
    assert_eq!(model.effects[0].joint, 2);
    let robot = model.to_robot::<6>().unwrap();
    let d = kinecal_cli::formats::measurements::load::<6>(&data)
        .unwrap()
        .measurements::<f64>();
    let fit_rms = (squared_errors(&robot, &d).iter().sum::<f64>() / d.len() as f64).sqrt();
    assert!(fit_rms < floor, "model file fit {fit_rms}");
    // Plots: per-pose errors and one per named effect, valid SVG.
    let plots: Vec<String> = r["plots"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| p.as_str().unwrap().to_string())
        .collect();
    assert_eq!(plots.len(), 2);
    for p in plots {
        let text = std::fs::read_to_string(&p).unwrap();
        assert!(text.contains("<svg") && text.contains("</svg>"), "{p}");
    }
}

#[test]
fn diagnose_command_names_nothing_when_nothing_is_missing() {
    let tmp = tempfile::tempdir().unwrap();
    let (robot, data) = write_case(tmp.path(), Vec::new(), 8);
    let r = run(&args(robot, data)).unwrap().to_value();
    assert_eq!(r["found"].as_array().unwrap().len(), 0, "{r:#}");
    let base = r["baseline_validation_rms_mm"].as_f64().unwrap();
    assert_eq!(base, r["final_validation_rms_mm"].as_f64().unwrap());
    assert!(base < 1.25 * r["noise_floor_mm"].as_f64().unwrap());
    assert!(r["summary"]
        .as_str()
        .unwrap()
        .starts_with("Nothing significant is missing from the model"));
}

#[test]
fn diagnose_command_refuses_bad_input_with_a_reason() {
    let tmp = tempfile::tempdir().unwrap();
    let s = Simulation {
        poses: 6,
        noise_mm: 0.02,
        seed: 1,
        geom_errors: None,
        effects: Vec::new(),
    };
    let (_, ds) = simulate(&er20(), &s).unwrap();
    let data = tmp.path().join("few.csv");
    measurements::write(&data, &ds).unwrap();
    let e = run(&args(data_dir().join("er20.toml"), data))
        .unwrap_err()
        .to_string();
    assert!(e.contains("too few"), "{e}");
    let mut a = args(data_dir().join("er20.toml"), tmp.path().join("missing.csv"));
    a.folds = 5;
    let e = run(&a).unwrap_err().to_string();
    assert!(e.contains("missing.csv"), "{e}");
}
