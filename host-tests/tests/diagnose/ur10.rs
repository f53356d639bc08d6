//! The discrepancy workflow on the real UR10 laser-tracker data (data/ur10).
//!
//!     cargo test -p kinecal-host --test diagnose ur10:: -- --ignored --nocapture
//!
//! The first 1,000 poses of the file identify (the search and its 5-fold cross-validation run on
//! them only), the remaining 1,773 are held out. The independent study found 0.49 mm held-out
//! RMS for the best geometric fit and 0.12 mm with 3.6° joint tables on all six joints; the
//! first goal was at most 0.45× the geometric fit's, the second no worse than the
//! 0.122 mm the search reached before the table's pitch and phase were chosen by the data.
//!
//! `diagnose_own_split_on_subsets` runs `diagnose` with its own 5-fold split on the whole
//! series and on subsets of it (smaller series of the same robot) and prints the final
//! cross-validated held-out RMS as a fraction of the geometric model's, with the pitch and
//! knot origin chosen per joint.

use kinecal_cli::diagnose::candidates::CandidateKind;
use kinecal_cli::diagnose::linear::squared_errors;
use kinecal_cli::diagnose::{diagnose, Config};
use kinecal_cli::formats::measurements;
use kinecal_cli::formats::robot_file::load_robot;
use std::path::PathBuf;

fn ur10_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/ur10")
}

fn rms(sq: &[f64]) -> f64 {
    (sq.iter().sum::<f64>() / sq.len() as f64).sqrt()
}

#[test]
#[ignore = "minutes on real data: cargo test -p kinecal-host --test diagnose ur10:: -- --ignored --nocapture"]
fn ur10_tables_cut_the_held_out_error_below_045_of_the_geometric_fit() {
    let dir = ur10_dir();
    let (file, nominal) = load_robot::<6>(&dir.join("robot.toml")).unwrap();
    let all = measurements::load::<6>(&dir.join("ur10_random_poses.csv"))
        .unwrap()
        .measurements::<f64>();
    let (ident, held) = all.split_at(1000);
    // KINECAL_TABLE_RIDGE / KINECAL_TABLE_SMOOTHNESS override the table penalty.
    let mut cfg = Config::default();
    let env = |k: &str| std::env::var(k).ok().and_then(|v| v.parse::<f64>().ok());
    if let Some(r) = env("KINECAL_TABLE_RIDGE") {
        cfg.penalty.ridge = r;
    }
    if let Some(s) = env("KINECAL_TABLE_SMOOTHNESS") {
        cfg.penalty.smoothness = s;
    }
    let d = diagnose(
        &nominal,
        file.base_known(),
        &file.tilt_joints(),
        ident,
        &cfg,
    )
    .unwrap();
    let geo = rms(&squared_errors(&d.geometric, held));
    let fin = rms(&squared_errors(&d.model, held));
    let report = kinecal_cli::reports::diagnose::DiagnoseReport::of(&d).to_value();
    eprintln!(
        "{}",
        serde_json::to_string_pretty(&report["rounds"]).unwrap()
    );
    for f in &d.found {
        eprintln!("{}", f.sentence(&d.model, d.noise_floor_mm));
    }
    eprintln!("chosen grids: {}", grids(&d));
    eprintln!(
            "UR10: cross-validated {:.4} → {:.4} mm on 1000 poses; held-out ({} poses) {geo:.4} → {fin:.4} mm = {:.3}×; noise floor {:.4} mm; {:.1} s",
            d.baseline_validation_rms_mm,
            d.final_validation_rms_mm,
            held.len(),
            fin / geo,
            d.noise_floor_mm,
            d.seconds
        );
    // The geometric fit is where the independent study put it…
    assert!((0.40..0.60).contains(&geo), "geometric held-out {geo}");
    // …and the named effects cut it to at most 0.45× on poses the search never saw.
    assert!(fin <= 0.45 * geo, "held-out {geo} → {fin}");
    // Not worse than before the data chose the tables' pitch and phase (0.1225 mm).
    assert!(fin <= 0.1225, "held-out {fin} mm");
    // What cuts it is joint tables (the study's finding), on several joints.
    let tables = d
        .found
        .iter()
        .filter(|f| matches!(f.candidate.kind, CandidateKind::Table { .. }))
        .count();
    assert!(tables >= 3, "{tables} tables named");
}

/// "joint 2: 3.6° from −189.225°, …" for the tables of a diagnosis.
fn grids<const N: usize>(d: &kinecal_cli::diagnose::Diagnosis<N>) -> String {
    d.found
        .iter()
        .filter_map(|f| match f.candidate.kind {
            CandidateKind::Table { start, step, knots } => Some(format!(
                "joint {}: {}° from {}° ({knots} knots)",
                f.candidate.joint + 1,
                kinecal_cli::formats::robot_file::deg_short(step),
                kinecal_cli::formats::robot_file::deg_short(start)
            )),
            _ => None,
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// `diagnose` with its own split (5-fold cross-validation over all the poses it is given), as
/// the outside checks run it on other series of this robot: the whole series and three
/// subsets of it. With fixed pitches and chosen phases the ratios were 0.229 (all
/// 2,773 poses), 0.258 (every 3rd pose), 0.311 (every 5th) and 0.356 (the first 500); each
/// must now be lower.
#[test]
#[ignore = "a minute on real data: cargo test -p kinecal-host --test diagnose ur10:: -- --ignored --nocapture"]
fn diagnose_own_split_on_subsets() {
    let dir = ur10_dir();
    let (file, nominal) = load_robot::<6>(&dir.join("robot.toml")).unwrap();
    let all = measurements::load::<6>(&dir.join("ur10_random_poses.csv"))
        .unwrap()
        .measurements::<f64>();
    // Every k-th pose from pose `first` (0-based).
    let every = |k: usize, first: usize| {
        all.iter()
            .skip(first)
            .step_by(k)
            .copied()
            .collect::<Vec<_>>()
    };
    let cases = [
        ("all 2,773 poses", all.clone(), 0.229),
        ("every 3rd pose from the 3rd", every(3, 2), 0.258),
        ("every 5th pose from the 1st", every(5, 0), 0.311),
        ("the first 500", all[..500].to_vec(), 0.356),
    ];
    let mut failures = Vec::new();
    for (name, data, before) in cases {
        let d = diagnose(
            &nominal,
            file.base_known(),
            &file.tilt_joints(),
            &data,
            &Config::default(),
        )
        .unwrap();
        let ratio = d.final_validation_rms_mm / d.baseline_validation_rms_mm;
        let line = format!(
                "{name} ({} poses): cross-validated {:.4} → {:.4} mm = {ratio:.3}× (before knots chosen by the data {before}×); {}; {:.1} s",
                data.len(),
                d.baseline_validation_rms_mm,
                d.final_validation_rms_mm,
                grids(&d),
                d.seconds
            );
        eprintln!("{line}");
        if ratio >= before {
            failures.push(line);
        }
    }
    assert!(
        failures.is_empty(),
        "not better than before:\n{}",
        failures.join("\n")
    );
}

/// The arithmetic of the search's screens on the whole series (2,773 poses, its own 5-fold
/// split): per round, the multiply-adds of every screened candidate's fold solves, each by the
/// cheaper of the two eliminations (`Elimination`: `p²m + pm² + m³/3` with the model's
/// parameters first, `p²m + p³/3` with a table's knots first, per fold), for `p` model
/// parameters and `m` candidate values. The phase shifts and the refits are not counted. On
/// 2026-11-29 this came to 12.0 G multiply-adds, growing with `p` as the tables the rounds
/// add (50–95 knots each) join the model: two cores at a few G multiply-adds per second each
/// need more than 1 s for it alone.
#[test]
#[ignore = "a minute on real data: cargo test -p kinecal-host --test diagnose ur10::screen_arithmetic -- --ignored --nocapture"]
fn screen_arithmetic_on_the_whole_series() {
    let dir = ur10_dir();
    let (file, nominal) = load_robot::<6>(&dir.join("robot.toml")).unwrap();
    let all = measurements::load::<6>(&dir.join("ur10_random_poses.csv"))
        .unwrap()
        .measurements::<f64>();
    let cfg = Config::default();
    let d = diagnose(&nominal, file.base_known(), &file.tilt_joints(), &all, &cfg).unwrap();
    let values = |c: &kinecal_cli::diagnose::candidates::Candidate| {
        c.add_to(&mut d.geometric.clone()).map_or(0, |v| v.len())
    };
    let added: Vec<usize> = d.found.iter().map(|f| values(&f.candidate)).collect();
    let mut p = d.params.len() - added.iter().sum::<usize>();
    let folds = cfg.folds as f64;
    let (mut total, mut next) = (0.0, 0);
    for (r, round) in d.rounds.iter().enumerate() {
        let pf = p as f64;
        let work: f64 = round
            .screened
            .iter()
            .map(|s| {
                let m = values(&s.candidate) as f64;
                let model_first = pf * pf * m + pf * m * m + m * m * m / 3.0;
                let knots_first = pf * pf * m + pf * pf * pf / 3.0;
                folds * model_first.min(knots_first)
            })
            .sum();
        total += work;
        eprintln!(
            "round {}: p = {p}, {} screened, {:.2} G multiply-adds, {:.2} s",
            r + 1,
            round.screened.len(),
            work / 1e9,
            round.seconds
        );
        // A round that chose a candidate and did not refuse it added the next finding.
        if round.chosen.is_some() && round.refused.is_none() {
            p += added.get(next).copied().unwrap_or(0);
            next += 1;
        }
    }
    eprintln!("total: {:.1} G multiply-adds", total / 1e9);
    assert_eq!(next, d.found.len(), "one finding per round that added one");
    assert_eq!(p, d.params.len());
    let joints: Vec<usize> = d.found.iter().map(|f| f.candidate.joint + 1).collect();
    assert!(
        d.found
            .iter()
            .all(|f| matches!(f.candidate.kind, CandidateKind::Table { .. })),
        "{joints:?}"
    );
}
