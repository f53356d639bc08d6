//! Acceptance on held-out poses, the prior, `--only`/`--fix` by every printed name and group,
//! `--split` and `--residuals`: simulated truths (docs/formats.md "Held-out poses").

use crate::common::*;
use std::path::{Path, PathBuf};

/// The ER20-like 6R without `[base]` (its pose is then fitted to the data).
pub(crate) fn er20_unplaced() -> String {
    ER20_PLACED.split("[base]").next().unwrap().to_string()
}

/// `text` with joint `j`'s (1-based) limits set to `lo`…`hi` degrees.
pub(crate) fn with_limits(text: &str, limits: &[(usize, f64, f64)]) -> String {
    let mut v: toml::Table = toml::from_str(text).unwrap();
    let joints = v.get_mut("joints").unwrap().as_array_mut().unwrap();
    for &(j, lo, hi) in limits {
        joints[j - 1].as_table_mut().unwrap().insert(
            "limits_deg".into(),
            toml::Value::Array(vec![lo.into(), hi.into()]),
        );
    }
    toml::to_string(&v).unwrap()
}

/// The rows of CSV `b` appended to CSV `a` (same header) as a new file.
pub(crate) fn concat(dir: &Path, name: &str, a: &Path, b: &Path) -> PathBuf {
    let a = std::fs::read_to_string(a).unwrap();
    let b = std::fs::read_to_string(b).unwrap();
    let rows: String = b.lines().skip(1).map(|l| format!("{l}\n")).collect();
    write(dir, name, &format!("{a}{rows}"))
}

fn rms(v: &[f64]) -> f64 {
    (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt()
}

/// A true robot (the ER20 with geometric errors, placed) as a robot file.
pub(crate) fn truth(dir: &Path) -> PathBuf {
    let placed = write(dir, "placed.toml", ER20_PLACED);
    let t = dir.join("truth.toml");
    simulate(
        &placed,
        Some(20),
        Some(0.0),
        Some(7),
        &["--geom-errors", "--truth", s(&t)],
        &dir.join("unused.csv"),
    );
    t
}

/// Poses confined to a corner of the workspace (identification) and poses elsewhere (held out):
/// the identified model is asked to extrapolate.
#[test]
fn an_extrapolating_split_ends_at_exit_3_or_no_worse_than_the_start() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let t = std::fs::read_to_string(truth(d)).unwrap();
    let near = write(
        d,
        "near.toml",
        &with_limits(
            &t,
            &[
                (1, -20.0, 20.0),
                (2, -60.0, -50.0),
                (3, -10.0, 0.0),
                (5, -20.0, 20.0),
            ],
        ),
    );
    let far = write(
        d,
        "far.toml",
        &with_limits(
            &t,
            &[
                (1, 90.0, 160.0),
                (2, 20.0, 80.0),
                (3, 60.0, 120.0),
                (5, 60.0, 120.0),
            ],
        ),
    );
    let (a, b) = (d.join("a.csv"), d.join("b.csv"));
    simulate(&near, Some(60), Some(0.02), Some(1), &[], &a);
    simulate(&far, Some(60), Some(0.02), Some(2), &[], &b);
    let data = concat(d, "ab.csv", &a, &b);
    let robot = write(d, "robot.toml", &er20_unplaced());
    let out = d.join("model.toml");
    let o = run_on(
        "identify",
        &robot,
        &data,
        &["--holdout", "60", "--json", "--out", s(&out)],
    );
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let (before, after) = (
        j["before"]["validation_rms_mm"].as_f64().unwrap(),
        j["after"]["validation_rms_mm"].as_f64().unwrap(),
    );
    let worse = j["held_out_worse"].as_bool().unwrap();
    assert_eq!(worse, after > before, "{j}");
    assert_eq!(j["accepted"], o.status.success(), "{j}");
    if worse {
        assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
        assert!(stderr(&o).contains("not a calibration"), "{}", stderr(&o));
        assert!(!out.exists(), "a model worse than its start is not written");
    } else {
        assert!(o.status.success(), "{}", stderr(&o));
    }
    // However it ends, the extrapolation is named, joint by joint.
    let gaps: Vec<u64> = j["acceptance"]["outside_ranges"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g["joint"].as_u64().unwrap())
        .collect();
    for joint in [1, 2, 3, 5] {
        assert!(gaps.contains(&joint), "joint {joint} not named: {gaps:?}");
    }
    let ident = j["after"]["identification_rms_mm"].as_f64().unwrap();
    if after > 2.0 * ident {
        let m = j["acceptance"]["message"].as_str().unwrap();
        assert!(m.contains("joint 2") && m.contains("joint ranges"), "{m}");
        assert!(stderr(&o).contains("joint 2"), "{}", stderr(&o));
    }
}

/// A model calibrated on one robot and judged on poses of another (here the nominal robot
/// itself): worse than the start, exit 3, `held_out_worse`, nothing written.
#[test]
fn a_model_worse_than_its_start_on_held_out_poses_exits_3() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let placed = write(d, "placed.toml", ER20_PLACED);
    let (s1, s2) = (d.join("s1.csv"), d.join("s2.csv"));
    simulate(
        &placed,
        Some(80),
        Some(0.02),
        Some(3),
        &["--geom-errors"],
        &s1,
    );
    simulate(&placed, Some(40), Some(0.02), Some(4), &[], &s2);
    let robot = write(d, "robot.toml", &er20_unplaced());
    let out = d.join("m.toml");
    let o = run_on(
        "identify",
        &robot,
        &s1,
        &["--validate", s(&s2), "--json", "--out", s(&out)],
    );
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["held_out_worse"], true);
    assert_eq!(j["converged"], true, "the fit itself converged");
    // `accepted` says what the exit status says, for scripts that read `converged`.
    assert_eq!(j["accepted"], false, "{j}");
    assert!(
        j["after"]["validation_rms_mm"].as_f64().unwrap()
            > j["before"]["validation_rms_mm"].as_f64().unwrap()
    );
    let err = stderr(&o);
    assert!(
        err.contains("worse than the model it started from"),
        "{err}"
    );
    assert!(!out.exists());
    // diagnose judges its final model the same way, against the nominal robot.
    let o = run_on(
        "diagnose",
        &robot,
        &s1,
        &["--validate", s(&s2), "--json", "--out", s(&out)],
    );
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["held_out_worse"], true);
    assert_eq!(j["accepted"], false, "{j}");
    assert!(
        j["holdout"]["final_rms_mm"].as_f64().unwrap()
            > j["holdout"]["start_rms_mm"].as_f64().unwrap()
    );
    assert!(!out.exists());
    // The same robot on both sessions: accepted.
    let s3 = d.join("s3.csv");
    simulate(
        &placed,
        Some(40),
        Some(0.02),
        Some(5),
        &["--geom-errors"],
        &s3,
    );
    let o = run_on("identify", &robot, &s1, &["--validate", s(&s3), "--json"]);
    let j = json_of(&o);
    assert_eq!(j["held_out_worse"], false);
}

/// A row of the residuals file: set, pose, line, error_mm, start_mm.
type ResidualRow = (String, u64, u64, f64, f64);

/// `--split last|random|every:K` choose the held-out poses; `--residuals` lists every pose's
/// residual with its line, and its held-out RMS is the report's.
#[test]
fn splits_and_the_residuals_file() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let placed = write(d, "placed.toml", ER20_PLACED);
    let data = d.join("d.csv");
    simulate(
        &placed,
        Some(50),
        Some(0.02),
        Some(9),
        &["--geom-errors"],
        &data,
    );
    let robot = write(d, "robot.toml", &er20_unplaced());
    let held_lines = |extra: &[&str]| -> (serde_json::Value, Vec<ResidualRow>) {
        let res = d.join("r.csv");
        let mut a = vec!["--json", "--residuals", s(&res)];
        a.extend_from_slice(extra);
        let j = json_of(&run_on("identify", &robot, &data, &a));
        let text = std::fs::read_to_string(&res).unwrap();
        let mut lines = text.lines();
        assert_eq!(
            lines.next().unwrap(),
            "set,pose,line,point,dx_mm,dy_mm,dz_mm,error_mm,start_mm"
        );
        let rows = lines
            .map(|l| {
                let c: Vec<&str> = l.split(',').collect();
                (
                    c[0].to_string(),
                    c[1].parse().unwrap(),
                    c[2].parse().unwrap(),
                    c[7].parse().unwrap(),
                    c[8].parse().unwrap(),
                )
            })
            .collect();
        (j, rows)
    };
    // every:5: poses 5, 10, … (lines 6, 11, … after the header).
    let (j, rows) = held_lines(&["--split", "every:5"]);
    assert_eq!(j["n_validation"], 10);
    let held: Vec<_> = rows.iter().filter(|r| r.0 == "held-out").collect();
    assert_eq!(
        held.iter().map(|r| r.1).collect::<Vec<_>>(),
        [5, 10, 15, 20, 25, 30, 35, 40, 45, 50]
    );
    assert!(held.iter().all(|r| r.2 == r.1 + 1));
    assert_eq!(rows.len(), 50);
    let after: Vec<f64> = held.iter().map(|r| r.3).collect();
    let start: Vec<f64> = held.iter().map(|r| r.4).collect();
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-5 * b.max(1e-3);
    assert!(close(
        rms(&after),
        j["after"]["validation_rms_mm"].as_f64().unwrap()
    ));
    assert!(close(
        rms(&start),
        j["before"]["validation_rms_mm"].as_f64().unwrap()
    ));
    let ident: Vec<f64> = rows
        .iter()
        .filter(|r| r.0 == "identification")
        .map(|r| r.3)
        .collect();
    assert!(close(
        rms(&ident),
        j["after"]["identification_rms_mm"].as_f64().unwrap()
    ));
    // last: the last 10 poses.
    let (_, rows) = held_lines(&["--holdout", "10"]);
    let held: Vec<u64> = rows
        .iter()
        .filter(|r| r.0 == "held-out")
        .map(|r| r.1)
        .collect();
    assert_eq!(held, (41..=50).collect::<Vec<u64>>());
    // random: 10 poses, the same for the same seed, others for another.
    let pick = |seed: &str| -> Vec<u64> {
        let (_, rows) = held_lines(&["--holdout", "0.2", "--split", "random", "--seed", seed]);
        rows.iter()
            .filter(|r| r.0 == "held-out")
            .map(|r| r.1)
            .collect()
    };
    let (a, b, c) = (pick("1"), pick("1"), pick("2"));
    assert_eq!(a.len(), 10);
    assert_eq!(a, b);
    assert_ne!(a, c);
    assert_ne!(a, (41..=50).collect::<Vec<u64>>());
    // Refused: a K that holds nothing out, an unknown split.
    for bad in [
        ["--split", "every:99"],
        ["--split", "middle"],
        ["--split", "every:1"],
    ] {
        let o = run_on("identify", &robot, &data, &bad);
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {}", stderr(&o));
    }
}

/// `--only base,tool` is the same fit as fixing everything else; printed effect names and
/// groups are accepted by `--fix`.
#[test]
fn only_and_fix_by_printed_names_and_groups() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let placed = write(d, "placed.toml", ER20_PLACED);
    let data = d.join("d.csv");
    // Enough poses that re-fitting an identified model on them is not thin data
    // (calibration::thin_data: its cross-validation would find nothing to gain, exit 3).
    simulate(
        &placed,
        Some(340),
        Some(0.02),
        Some(11),
        &["--geom-errors"],
        &data,
    );
    let robot = write(d, "robot.toml", &er20_unplaced());
    // Held geometry must describe the arm (a nominal robot's does not: no calibration, exit 3,
    // `held_geometry_that_no_longer_describes_the_arm_is_no_calibration`): a model of it.
    // Its [base] left out, as the nominal robot's: both fits below estimate it.
    let placed_model = d.join("placed_model.toml");
    let o = run_on("identify", &robot, &data, &["--out", s(&placed_model)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let mut in_base = false;
    let unplaced: String = std::fs::read_to_string(&placed_model)
        .unwrap()
        .lines()
        .filter(|l| {
            if l.starts_with('[') {
                in_base = *l == "[base]";
            }
            !in_base
        })
        .map(|l| format!("{l}\n"))
        .collect();
    let model = write(d, "model.toml", &unplaced);
    let params = |extra: &[&str]| {
        let mut a = vec!["--json"];
        a.extend_from_slice(extra);
        json_of(&run_on("identify", &model, &data, &a))
    };
    let only = params(&["--only", "base,tool"]);
    let fixed = params(&["--fix", "geometry"]);
    let names = |j: &serde_json::Value| -> Vec<String> {
        j["changes"].as_object().unwrap().keys().cloned().collect()
    };
    assert_eq!(names(&only), names(&fixed));
    assert!(names(&only)
        .iter()
        .all(|n| n.starts_with("base.") || n.starts_with("tool.")));
    for (k, v) in only["parameters"].as_object().unwrap() {
        let w = fixed["parameters"][k].as_f64().unwrap();
        assert!(
            (v.as_f64().unwrap() - w).abs() <= 1e-9 * w.abs().max(1.0),
            "{k}"
        );
    }
    // A model with a joint table: its knots by printed name and as a group.
    let table = d.join("table.toml");
    let o = run_on(
        "identify",
        &robot,
        &data,
        &["--effect", "joint-table:2:10", "--out", s(&table), "--json"],
    );
    let j = json_of(&o);
    let knots: Vec<String> = j["changes"]
        .as_object()
        .unwrap()
        .keys()
        .filter(|k| k.starts_with("joint-table2["))
        .cloned()
        .collect();
    assert!(knots.len() >= 3, "{knots:?}");
    // Re-fitting the model on the same data: the table held as a group, one knot by name.
    let j = json_of(&run_on(
        "identify",
        &table,
        &data,
        &["--json", "--fix", "joint-table2"],
    ));
    assert!(j["changes"]
        .as_object()
        .unwrap()
        .keys()
        .all(|k| !k.starts_with("joint-table")));
    let j = json_of(&run_on(
        "identify",
        &table,
        &data,
        &["--json", "--fix", &knots[0]],
    ));
    let c = j["changes"].as_object().unwrap();
    assert!(!c.contains_key(&knots[0]) && c.contains_key(&knots[1]));
    let j = json_of(&run_on(
        "identify",
        &table,
        &data,
        &["--json", "--only", "effects"],
    ));
    assert!(j["changes"]
        .as_object()
        .unwrap()
        .keys()
        .all(|k| k.starts_with("joint-table2[")));
    let o = run_on("identify", &table, &data, &["--fix", "joint-table3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("joint-table3"), "{}", stderr(&o));
}

/// The prior: a parameter the data barely see stays near its file value (and says the prior
/// set it); parameters the data determine are where they were without it.
#[test]
fn the_prior_holds_what_the_data_barely_determine_and_leaves_the_rest() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let t = std::fs::read_to_string(truth(d)).unwrap();
    // Joint 5 barely moves and joint 2 and 3 move a little: some directions are nearly
    // unobserved.
    let narrow = write(
        d,
        "narrow.toml",
        &with_limits(&t, &[(2, -50.0, -45.0), (3, -5.0, 0.0), (5, 30.0, 31.0)]),
    );
    let data = d.join("narrow.csv");
    simulate(&narrow, Some(40), Some(0.02), Some(12), &[], &data);
    // The whole workspace of the same robot, to judge the models on.
    let wide = d.join("wide.csv");
    simulate(
        &write(d, "t.toml", &t),
        Some(300),
        Some(0.02),
        Some(13),
        &[],
        &wide,
    );
    let robot = write(d, "robot.toml", &er20_unplaced());
    let run = |prior: &str| {
        json_of(&run_on(
            "identify",
            &robot,
            &data,
            &["--json", "--prior", prior, "--validate", s(&wide)],
        ))
    };
    let (off, on) = (run("off"), run("length_mm=1,angle_deg=0.1"));
    let changes = |j: &serde_json::Value| j["changes"].as_object().unwrap().clone();
    let (c_off, c_on) = (changes(&off), changes(&on));
    let mut weak = 0;
    for (k, v) in &c_on {
        let Some(share) = v["data_share"].as_f64() else {
            continue;
        };
        assert!((0.0..=1.0).contains(&share), "{k}: {share}");
        let prior = v["prior_sigma"].as_f64().unwrap();
        let was = c_off[k]["change"].as_f64().unwrap();
        let now = v["change"].as_f64().unwrap();
        let data_sigma = v["data_sigma"].as_f64().unwrap_or(f64::INFINITY);
        if data_sigma > 3.0 * prior {
            // The data alone barely determine it: the prior keeps it near its file value
            // (within 3 prior σ, and closer than without the prior), and says so.
            weak += 1;
            assert!(share < 0.9, "{k}: {share}");
            assert!(now.abs() <= 3.0 * prior, "{k}: {now} (prior {prior})");
            assert!(now.abs() <= was.abs() + 1e-9, "{k}: {now} vs {was}");
        }
    }
    assert!(weak >= 1, "no weakly determined parameter: {c_on:?}");
    // The fit to the data is no worse than a few percent, and the robot's whole workspace is
    // predicted better than without the prior.
    let r = |j: &serde_json::Value, k: &str| j["after"][k].as_f64().unwrap();
    let (fit_on, fit_off) = (
        r(&on, "identification_rms_mm"),
        r(&off, "identification_rms_mm"),
    );
    assert!(fit_on <= 1.05 * fit_off, "{fit_on} vs {fit_off}");
    let (wide_on, wide_off) = (r(&on, "validation_rms_mm"), r(&off, "validation_rms_mm"));
    eprintln!("whole workspace: prior {wide_on} mm, none {wide_off} mm");
    assert!(wide_on < wide_off, "{wide_on} vs {wide_off}");
    // A bad --prior and a bad [prior] are refused.
    let o = run_on("identify", &robot, &data, &["--prior", "lengths=1"]);
    assert_eq!(o.status.code(), Some(2));
    let bad = write(
        d,
        "bad.toml",
        &format!("{}\n[prior]\nlength_mm = -1\n", er20_unplaced()),
    );
    let o = run_on("identify", &bad, &data, &[]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(stderr(&o).contains("length_mm"), "{}", stderr(&o));
}

/// On well-determined data the prior changes nothing that matters: the held-out RMS with the
/// defaults is within 1 % of the fit without a prior (UR10 series C, 1,000 poses identified).
#[test]
fn ur10_the_prior_leaves_a_well_determined_calibration_alone() {
    let dir = ur10_dir();
    let data = dir.join("ur10_random_poses.csv");
    let robot = dir.join("robot.toml");
    let run = |extra: &[&str]| {
        let mut a = vec!["--holdout", "1773", "--json"];
        a.extend_from_slice(extra);
        json_of(&run_on("identify", &robot, &data, &a))
    };
    let (on, off) = (run(&[]), run(&["--prior", "off"]));
    let v = |j: &serde_json::Value| j["after"]["validation_rms_mm"].as_f64().unwrap();
    eprintln!(
        "UR10 held-out: prior {} mm, no prior {} mm",
        v(&on),
        v(&off)
    );
    assert!((v(&on) / v(&off) - 1.0).abs() < 0.01);
    assert_eq!(on["held_out_worse"], false);
    assert!(v(&on) < 0.5);
}

/// Re-fitting only the set-up (`--only base,tool`) of a model of another UR10 of the same type:
/// the fit converged and its held-out poses were "predicted better than by the starting model"
/// at 4.19 mm (0.02 mm noise), where the nominal robot leaves 2.02 mm (exit 0). Judged as
/// `validate` judges a model (`cli/src/calibration/held_geometry.rs`), it is no calibration
/// (exit 3, no `--out`); the arm's own model re-fitted the same way is, and so is not a nominal
/// robot whose geometry `--fix geometry` holds.
#[test]
fn held_geometry_that_no_longer_describes_the_arm_is_no_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = ur10_dir().join("robot.toml");
    let (a, b, truth_a) = (d.join("a.csv"), d.join("b.csv"), d.join("truth_a.toml"));
    let mut with_truth = vec!["--geom-errors", "--truth"];
    with_truth.push(s(&truth_a));
    simulate(&robot, Some(200), Some(0.02), Some(11), &with_truth, &a);
    simulate(
        &robot,
        Some(200),
        Some(0.02),
        Some(12),
        &["--geom-errors"],
        &b,
    );
    let (model_a, model_b) = (d.join("model_a.toml"), d.join("model_b.toml"));
    for (data, model) in [(&a, &model_a), (&b, &model_b)] {
        let o = run_on("identify", &robot, data, &["--out", s(model)]);
        assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    }
    // Robot A's next session.
    let next = d.join("next.csv");
    simulate(&truth_a, Some(300), Some(0.02), Some(55), &[], &next);
    let out = d.join("refit.toml");
    let refit = |model: &Path, extra: &[&str]| {
        let mut args = extra.to_vec();
        args.extend(["--holdout", "0.2", "--out", s(&out)]);
        run_on("identify", model, &next, &args)
    };
    let o = refit(&model_b, &["--only", "base,tool"]);
    let err = stderr(&o);
    assert_eq!(o.status.code(), Some(3), "{err}");
    assert!(
        err.contains("no longer describes this arm") && err.contains("add geometry to --only"),
        "{err}"
    );
    assert!(!out.exists());
    let o = refit(&robot, &["--fix", "geometry"]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let o = refit(&model_a, &["--only", "base,tool"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(out.exists());
}
