//! `kinecal report`'s verdict is the calibration's: a model whose held-out poses identify
//! refuses, or whose other session fails `validate`, is not badged "calibrated" with exit 0;
//! a validate or diagnose JSON of another model or data file is refused; and identify names
//! held-out rows that miss the model as held out, not as readings that pulled the fit.

use crate::common::{data_file, kinecal, run_on, s, simulate, stderr, write};
use kinecal_cli::formats::robot_file::RobotFile;
use std::path::{Path, PathBuf};

/// 60 poses of an ER20 with geometric errors (`a.csv`, truth `ta.toml`), and the same 60 and
/// 30 more after joint 2 was re-mastered by −0.08° (`s.csv`), as the outside tester built them.
fn remastered(d: &Path) -> (PathBuf, PathBuf) {
    let robot = data_file("er20.toml");
    let (a, truth) = (d.join("a.csv"), d.join("ta.toml"));
    let t = s(&truth);
    simulate(
        &robot,
        Some(60),
        Some(0.02),
        Some(51),
        &["--geom-errors", "--truth", t],
        &a,
    );
    let mut f = RobotFile::load(&truth).unwrap();
    f.joints[1].theta_deg -= 0.08;
    let tb = d.join("tb.toml");
    f.save(&tb).unwrap();
    let b = d.join("b.csv");
    simulate(&tb, Some(30), Some(0.02), Some(52), &[], &b);
    let (ta, tb) = (
        std::fs::read_to_string(&a).unwrap(),
        std::fs::read_to_string(&b).unwrap(),
    );
    let rows: Vec<&str> = tb.lines().filter(|l| !l.starts_with('#')).skip(1).collect();
    let both = format!("{}{}\n", ta, rows.join("\n"));
    (a, write(d, "s.csv", &both))
}

fn report(model: &Path, data: &Path, extra: &[&str], out: &Path) -> std::process::Output {
    let robot = data_file("er20.toml");
    let mut args = vec![
        "--json",
        "report",
        "--robot",
        s(&robot),
        "--model",
        s(model),
        "--data",
        s(data),
        "--out",
        s(out),
    ];
    args.extend_from_slice(extra);
    kinecal(&args)
}

/// The page's verdict badge.
fn verdict(page: &Path) -> String {
    let html = std::fs::read_to_string(page).unwrap();
    let doc = scraper::Html::parse_document(&html);
    let sel = scraper::Selector::parse("#verdict").unwrap();
    doc.select(&sel).next().unwrap().text().collect()
}

/// identify exits 3 on the re-mastered file with its last 30 poses held out; the report of
/// the model of the first 60 on the same split said "calibrated" with exit 0. It is no
/// calibration there now (exit 3, `accepted: false`, the badge says why), and the same report
/// on the first 60 poses alone, 20 held out, stays "calibrated".
#[test]
fn report_judges_the_held_out_poses_as_identify_does() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (a, both) = remastered(d);
    let robot = data_file("er20.toml");
    let model = d.join("m.toml");
    let out = run_on("identify", &robot, &a, &["--out", s(&model)]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let page = d.join("r.html");
    let r = report(&model, &both, &["--holdout", "30"], &page);
    assert_eq!(r.status.code(), Some(3), "{}", stderr(&r));
    let j: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
    assert_eq!(j["accepted"], false, "{j}");
    assert!(
        verdict(&page).starts_with("not a calibration"),
        "{}",
        verdict(&page)
    );
    let html = std::fs::read_to_string(&page).unwrap();
    assert!(
        html.contains("held-out point(s) far") && html.contains("× worse"),
        "{html}"
    );
    // Should not fire: the first 60 poses, 20 of them held out.
    let r = report(&model, &a, &["--holdout", "20"], &page);
    assert_eq!(r.status.code(), Some(0), "{}", stderr(&r));
    assert_eq!(verdict(&page), "calibrated");
}

/// identify on the re-mastered file, its last 30 poses held out: 19 of them far from the model
/// fitted to the others were named as wrong readings that "pull every parameter; delete those
/// rows" (held-out rows pull nothing). They are named as held-out rows now, with the change of
/// set-up or robot as a cause and no advice to delete them.
#[test]
fn held_out_rows_far_from_the_model_are_not_told_to_be_deleted() {
    let dir = tempfile::tempdir().unwrap();
    let (_, both) = remastered(dir.path());
    let out = run_on(
        "identify",
        &data_file("er20.toml"),
        &both,
        &["--holdout", "30"],
    );
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("held-out point(s) far") && !err.contains("delete those rows"),
        "{err}"
    );
}

/// A validate JSON of another model, and a diagnose JSON of a larger data file, were shown as
/// this calibration's (exit 0): refused (exit 2) naming the file; the JSON of this very model
/// is taken. A failing validate JSON makes the page's verdict fail too (exit 3).
#[test]
fn report_refuses_another_models_json_and_repeats_a_failing_validation() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (a, _) = remastered(d);
    let robot = data_file("er20.toml");
    let model = d.join("m.toml");
    assert!(run_on("identify", &robot, &a, &["--out", s(&model)])
        .status
        .success());
    // Another session of the re-mastered robot (joint 2 off by 0.08°: the model is worse).
    let session = d.join("b.csv");
    let v = kinecal(&[
        "validate",
        "--robot",
        s(&robot),
        "--model",
        s(&model),
        "--data",
        s(&session),
        "--json",
    ]);
    let v_json = write(d, "v.json", &String::from_utf8_lossy(&v.stdout));
    let page = d.join("r.html");
    let r = report(&model, &a, &["--validate-json", s(&v_json)], &page);
    let validate_failed = v.status.code() == Some(3);
    assert_eq!(
        r.status.code(),
        Some(if validate_failed { 3 } else { 0 }),
        "{}",
        stderr(&r)
    );
    assert_eq!(verdict(&page) == "calibrated", !validate_failed);
    // The same JSON with another model: refused.
    let other = d.join("other.toml");
    std::fs::copy(&model, &other).unwrap();
    let r = report(&other, &a, &["--validate-json", s(&v_json)], &page);
    let err = stderr(&r);
    assert_eq!(r.status.code(), Some(2), "{err}");
    assert!(
        err.contains("v.json") && err.contains("other.toml"),
        "{err}"
    );
    // A diagnose JSON of 200 poses for a 60-pose file: refused.
    let big = d.join("big.csv");
    simulate(
        &robot,
        Some(200),
        Some(0.02),
        Some(3),
        &["--geom-errors"],
        &big,
    );
    let dj = run_on("diagnose", &robot, &big, &["--json"]);
    let dj = write(d, "d.json", &String::from_utf8_lossy(&dj.stdout));
    let r = report(&model, &a, &["--diagnose", s(&dj)], &page);
    let err = stderr(&r);
    assert_eq!(r.status.code(), Some(2), "{err}");
    assert!(err.contains("d.json") && err.contains("200 poses"), "{err}");
}

/// A joint that never moves in the identification poses (joint 3 at 0° in every row, as a
/// 7-joint arm's redundant joint held fixed): identify was accepted without a word. It warns
/// now, naming the joint and its range; a session over the whole workspace draws no warning.
#[test]
fn a_joint_that_barely_moves_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = data_file("er20.toml");
    let all = d.join("all.csv");
    simulate(
        &robot,
        Some(80),
        Some(0.01),
        Some(7),
        &["--geom-errors"],
        &all,
    );
    let out = run_on("identify", &robot, &all, &["--holdout", "0.2"]);
    assert!(
        !stderr(&out).contains("the identification poses move"),
        "{}",
        stderr(&out)
    );
    // The same readings with joint 3 at 0°, measured on the true robot (0.01 mm noise).
    let truth = d.join("truth.toml");
    let t = s(&truth);
    simulate(
        &robot,
        Some(2),
        Some(0.0),
        Some(7),
        &["--geom-errors", "--truth", t],
        &d.join("x.csv"),
    );
    let truth = RobotFile::load(&truth).unwrap().to_robot::<6>().unwrap();
    let text = std::fs::read_to_string(&all).unwrap();
    let mut fixed = String::from("q1,q2,q3,q4,q5,q6,x,y,z\n");
    let mut fk = kinecal::ForwardKinematics::<f64, 6>::new();
    for (k, line) in text
        .lines()
        .filter(|l| !l.starts_with('#'))
        .skip(1)
        .enumerate()
    {
        let mut q: Vec<f64> = line
            .split(',')
            .take(6)
            .map(|v| v.parse().unwrap())
            .collect();
        q[2] = 0.0;
        let qr: [f64; 6] = std::array::from_fn(|i| q[i].to_radians());
        let p = fk.compute(&truth, &qr);
        let e = |a: usize| 0.01 * ((k * 7 + a * 13) as f64).sin();
        let q: Vec<String> = q.iter().map(|v| format!("{v:.6}")).collect();
        fixed += &format!(
            "{},{:.6},{:.6},{:.6}\n",
            q.join(","),
            p.x + e(0),
            p.y + e(1),
            p.z + e(2)
        );
    }
    let fixed = write(d, "fixed.csv", &fixed);
    let out = run_on("identify", &robot, &fixed, &["--holdout", "0.2"]);
    let err = stderr(&out);
    assert!(
        err.contains("the identification poses move joint 3 0.0…0.0°"),
        "{err}"
    );
}
