//! The `kinecal` binary: `simulate` reproduces the reference kinematics, `check` reports the
//! nominal error (fitting the base when unknown), and every malformed file gives a non-zero
//! exit with one line naming file, line and column.

use kinecal_cli::formats::measurements;
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_host::reference::RefRobot;
use nalgebra::Vector3;
use std::path::Path;
use std::process::Output;

use crate::common::{
    f64s, json_of, kinecal, location, run_on, s, simulate, write, ER20_TILTED_PLACED as ER20,
    LBR7_TILTED_PLACED as LBR7,
};

/// Asserts failure with exactly one stderr line that names `file:LINE:COLUMN:`; returns
/// `(line, column, line of text)`.
fn one_line_error(out: &Output, file: &Path) -> (usize, usize, String) {
    assert!(!out.status.success(), "must fail");
    let err = String::from_utf8(out.stderr.clone()).unwrap();
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "exactly one line on stderr: {err}");
    let (l, c, _) = location(lines[0], &file.display().to_string());
    (l, c, lines[0].to_string())
}

/// A failed command's stdout: nothing, or with `--json` exactly `{"error": REASON}` with the
/// reason of the `kinecal: REASON` line on stderr.
fn assert_stdout_of_failure(out: &Output, json: bool, stderr_line: &str) {
    if !json {
        assert!(out.stdout.is_empty());
        return;
    }
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let reason = stderr_line.strip_prefix("kinecal: ").unwrap();
    assert_eq!(v, serde_json::json!({ "error": reason }));
}

/// Simulates noise-free data from `robot` (with `extra` arguments) and compares every
/// measured point with `reference` evaluated at the file's joint readings.
fn simulate_matches<const N: usize>(
    dir: &Path,
    robot: &Path,
    extra: &[&str],
    reference: impl Fn(&Path) -> RefRobot,
) -> f64 {
    let out_csv = dir.join("sim.csv");
    let truth = dir.join("truth.toml");
    let mut args = vec!["--truth", s(&truth)];
    args.extend_from_slice(extra);
    simulate(robot, Some(200), Some(0.0), Some(11), &args, &out_csv);
    let ds = measurements::load::<N>(&out_csv).unwrap();
    assert_eq!(ds.len(), 200);
    let r = reference(&truth);
    let mut worst = 0f64;
    for rec in &ds.records {
        let q: Vec<f64> = rec.q_deg.iter().map(|d| d.to_radians()).collect();
        let p = r.point(&q);
        worst = worst.max((p - Vector3::from(rec.xyz_mm)).norm());
    }
    assert!(worst <= 1e-5, "simulate vs reference: {worst:e} mm");
    worst
}

#[test]
fn simulate_reproduces_the_reference_6_and_7_joints() {
    let dir = tempfile::tempdir().unwrap();
    for (text, n) in [(ER20, 6), (LBR7, 7)] {
        let robot = write(dir.path(), "robot.toml", text);
        let file = RobotFile::load(&robot).unwrap();
        let nominal = RefRobot::from_file(&file);
        let reference = |_: &Path| nominal.clone();
        if n == 6 {
            simulate_matches::<6>(dir.path(), &robot, &[], reference);
        } else {
            simulate_matches::<7>(dir.path(), &robot, &[], reference);
        }
        // The truth of an error-free simulation is the nominal model.
        let truth = RobotFile::load(&dir.path().join("truth.toml")).unwrap();
        assert_eq!(RefRobot::from_file(&truth).joints, nominal.joints);
    }
}

/// Each `--effect` kind as documented: the expected true robot is built here from the
/// nominal file and the arguments, independently of the program.
#[test]
fn simulate_applies_effects_as_documented() {
    use kinecal_host::reference::RefEffect;
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20);
    let nominal = RefRobot::from_file(&RobotFile::load(&robot).unwrap());
    let lim2 = [(-150f64).to_radians(), 90f64.to_radians()];
    type Apply = Box<dyn Fn(&mut RefRobot)>;
    let cases: Vec<(Vec<&str>, Apply)> = vec![
        (
            vec!["--effect", "joint-scale:3:0.002"],
            Box::new(|r| r.effects.push(RefEffect::Scale { joint: 2, s: 0.002 })),
        ),
        (
            vec!["--effect", "joint-cyclic:4:1e-3,-5e-4:3"],
            Box::new(|r| {
                r.effects.push(RefEffect::Cyclic {
                    joint: 3,
                    order: 3,
                    a: 1e-3,
                    b: -5e-4,
                })
            }),
        ),
        (
            vec!["--effect", "joint-compliance:2:-3e-4"],
            Box::new(|r| r.effects.push(RefEffect::Compliance { joint: 1, k: -3e-4 })),
        ),
        (
            vec!["--effect", "joint-table:2:0.001,-0.002,0.0005,0.0"],
            Box::new(move |r| {
                r.effects.push(RefEffect::Table {
                    joint: 1,
                    start: lim2[0],
                    step: (lim2[1] - lim2[0]) / 3.0,
                    knots: vec![0.001, -0.002, 0.0005, 0.0],
                })
            }),
        ),
        (
            vec!["--effect", "axis-tilt:5:0.004"],
            Box::new(|r| r.joints[4].beta = 0.004),
        ),
    ];
    for (args, apply) in cases {
        let mut expected = nominal.clone();
        apply(&mut expected);
        simulate_matches::<6>(dir.path(), &robot, &args, |_| expected.clone());
        // The truth file carries the effect and reproduces the data too.
        simulate_matches::<6>(dir.path(), &robot, &args, |t| {
            RefRobot::from_file(&RobotFile::load(t).unwrap())
        });
    }
}

/// A joint table on a fixed angle grid (knots every 10° at a phase of 2.5°, the first one
/// below the joint's lower limit; not the even spread of `--effect`): a robot file with
/// `step_deg`/`start_deg` is the truth `simulate --robot` measures, the truth file keeps the
/// grid, and the library's `EffectArg::grid` makes the same robot.
#[test]
fn simulate_honours_a_table_on_a_fixed_angle_grid() {
    use kinecal_cli::simulation::{self, EffectArg, Simulation};
    use kinecal_host::reference::RefEffect;
    let dir = tempfile::tempdir().unwrap();
    let plain = write(dir.path(), "plain.toml", ER20);
    let file = RobotFile::load(&plain).unwrap();
    // Joint 1: limits ±170°; knots at -177.5°, -167.5°, …, 172.5° (36 knots).
    let (start_deg, step_deg) = (-177.5, 10.0);
    let knots: Vec<f64> = (0..36).map(|k| 2e-3 * (0.9 * k as f64).sin()).collect();
    let mut expected = RefRobot::from_file(&file);
    expected.effects.push(RefEffect::Table {
        joint: 0,
        start: f64::to_radians(start_deg),
        step: f64::to_radians(step_deg),
        knots: knots.clone(),
    });
    let values: Vec<String> = knots.iter().map(|v| format!("{v:e}")).collect();
    let with_table = write(
        dir.path(),
        "table.toml",
        &format!(
            "{ER20}\n[[effects]]\nkind = \"joint-table\"\njoint = 1\nstep_deg = {step_deg:?}\nstart_deg = {start_deg:?}\nvalues = [{}]\n",
            values.join(", ")
        ),
    );
    simulate_matches::<6>(dir.path(), &with_table, &[], |_| expected.clone());
    let truth = RobotFile::load(&dir.path().join("truth.toml")).unwrap();
    let table = truth
        .effects
        .iter()
        .find(|e| e.kind == "joint-table")
        .expect("the truth file keeps the table");
    assert_eq!(table.joint, 1);
    assert!(
        (table.step_deg.unwrap() - step_deg).abs() < 1e-9,
        "{table:?}"
    );
    assert!(
        (table.start_deg.unwrap() - start_deg).abs() < 1e-9,
        "{table:?}"
    );
    simulate_matches::<6>(dir.path(), &with_table, &[], |t| {
        RefRobot::from_file(&RobotFile::load(t).unwrap())
    });

    // The library: the same table as an effect with a knot grid.
    let nominal = file.to_robot::<6>().unwrap();
    let grid = EffectArg {
        kind: "joint-table".into(),
        joint: 0,
        values: knots.clone(),
        order: 1,
        grid: Some((f64::to_radians(start_deg), f64::to_radians(step_deg))),
    };
    let sim = Simulation {
        poses: 200,
        noise_mm: 0.0,
        seed: 5,
        geom_errors: None,
        effects: vec![grid.clone()],
    };
    let (_, ds) = simulation::simulate(&nominal, &sim).unwrap();
    let mut worst = 0f64;
    for rec in &ds.records {
        let q: Vec<f64> = rec.q_deg.iter().map(|d| d.to_radians()).collect();
        worst = worst.max((expected.point(&q) - Vector3::from(rec.xyz_mm)).norm());
    }
    assert!(worst <= 1e-5, "EffectArg::grid vs reference: {worst:e} mm");
    // Without a grid the same values spread over the limits: another robot.
    let spread = Simulation {
        effects: vec![EffectArg {
            grid: None,
            ..grid.clone()
        }],
        ..sim.clone()
    };
    let (_, ds2) = simulation::simulate(&nominal, &spread).unwrap();
    assert!(ds2
        .records
        .iter()
        .zip(&ds.records)
        .any(|(a, b)| { (Vector3::from(a.xyz_mm) - Vector3::from(b.xyz_mm)).norm() > 1e-3 }));
    // A grid only for tables, with a finite start and a positive step.
    let mut r = nominal.clone();
    for bad in [
        EffectArg {
            kind: "joint-scale".into(),
            values: vec![1e-4],
            ..grid.clone()
        },
        EffectArg {
            grid: Some((0.0, 0.0)),
            ..grid.clone()
        },
        EffectArg {
            grid: Some((f64::NAN, 0.1)),
            ..grid.clone()
        },
    ] {
        assert!(simulation::add_effect(&mut r, &bad).is_err(), "{bad:?}");
    }
}

#[test]
fn geometric_errors_stay_within_their_bounds_and_match_the_truth_file() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", LBR7);
    simulate_matches::<7>(dir.path(), &robot, &["--geom-errors"], |t| {
        RefRobot::from_file(&RobotFile::load(t).unwrap())
    });
    let nominal = RobotFile::load(&robot).unwrap();
    let truth = RobotFile::load(&dir.path().join("truth.toml")).unwrap();
    let mut moved = 0;
    for (a, b) in nominal.joints.iter().zip(&truth.joints) {
        for (x, y, w) in [
            (a.alpha_deg, b.alpha_deg, 0.1),
            (a.theta_deg, b.theta_deg, 0.1),
            (a.a_mm, b.a_mm, 0.8),
            (a.d_mm, b.d_mm, 0.8),
        ] {
            assert!((x - y).abs() <= w + 1e-12, "{x} vs {y}");
            moved += ((x - y).abs() > 1e-6) as usize;
        }
        assert_eq!(a.beta_deg, b.beta_deg);
    }
    for (x, y) in nominal.tool.xyz_mm.iter().zip(truth.tool.xyz_mm) {
        assert!((x - y).abs() <= 0.5 + 1e-12);
    }
    assert!(
        moved >= 20,
        "errors were applied ({moved} of 28 parameters moved)"
    );
}

#[test]
fn without_base_simulate_uses_identity_and_check_fits_it() {
    let dir = tempfile::tempdir().unwrap();
    let placed = write(dir.path(), "placed.toml", ER20);
    let unplaced_text: String = ER20.split("[base]").next().unwrap().to_string();
    let unplaced = write(dir.path(), "unplaced.toml", &unplaced_text);

    // Simulating the unplaced robot: identity base, said on stderr, truth has an identity base.
    let csv = dir.path().join("d.csv");
    let truth = dir.path().join("t.toml");
    let out = simulate(
        &unplaced,
        Some(30),
        None,
        None,
        &["--truth", s(&truth)],
        &csv,
    );
    assert!(String::from_utf8_lossy(&out.stderr).contains("identity"));
    let t = RobotFile::load(&truth).unwrap();
    let b = t.base.expect("truth has a base");
    assert_eq!((b.xyz_mm, b.rpy_deg), ([0.0; 3], [0.0; 3]));

    // Data of the placed robot, checked against the unplaced file: the base is recovered. (A
    // micrometre of noise: points that are the file's own model to nanometres are refused as
    // computed, not measured.)
    simulate(&placed, Some(60), Some(0.001), Some(5), &[], &csv);
    let v = json_of(&run_on("check", &unplaced, &csv, &["--json"]));
    assert_eq!(v["poses"], 60);
    assert_eq!(v["base_fitted"], true);
    assert!(v["nominal_rms_mm"].as_f64().unwrap() < 0.003, "{v}");
    let xyz = f64s(&v["base"]["xyz_mm"]);
    let rpy = f64s(&v["base"]["rpy_deg"]);
    for (a, b) in xyz.iter().zip([2500.0, -1200.0, -300.0]) {
        assert!((a - b).abs() < 1e-3, "{xyz:?}");
    }
    for (a, b) in rpy.iter().zip([0.7, -1.3, 155.0]) {
        assert!((a - b).abs() < 1e-5, "{rpy:?}");
    }
}

#[test]
fn check_reports_noise_level_and_ranges() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20);
    let csv = dir.path().join("d.csv");
    let v = json_of(&simulate(
        &robot,
        Some(2000),
        Some(0.05),
        Some(2),
        &["--json"],
        &csv,
    ));
    assert_eq!(
        (v["poses"].as_u64(), v["seed"].as_u64()),
        (Some(2000), Some(2))
    );
    assert_eq!(v["out"], s(&csv));
    let v = json_of(&run_on("check", &robot, &csv, &["--json"]));
    assert_eq!(v["poses"], 2000);
    assert_eq!(v["base_fitted"], false);
    // RMS of 3-D Gaussian noise of σ per axis is √3·σ.
    let rms = v["nominal_rms_mm"].as_f64().unwrap();
    assert!((rms / (3f64.sqrt() * 0.05) - 1.0).abs() < 0.05, "{rms}");
    // Ranges within the limits and nearly covering them (2000 uniform poses).
    let ranges = v["joint_ranges_deg"].as_array().unwrap();
    let limits = [
        [-170.0, 170.0],
        [-150.0, 90.0],
        [-180.0, 180.0],
        [-180.0, 180.0],
        [-125.0, 125.0],
        [-180.0, 180.0],
    ];
    for (r, l) in ranges.iter().zip(limits) {
        let (lo, hi) = (r[0].as_f64().unwrap(), r[1].as_f64().unwrap());
        assert!(
            lo >= l[0] && hi <= l[1] && lo < l[0] + 2.0 && hi > l[1] - 2.0,
            "{lo}..{hi} vs {l:?}"
        );
    }
    // Without --json: human text, no JSON.
    let out = kinecal(&["check", "--robot", s(&robot), "--data", s(&csv)]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(
        text.contains("RMS") && !text.trim_start().starts_with('{'),
        "{text}"
    );
}

#[test]
fn same_seed_same_files() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", LBR7);
    let run = |seed: u64, name: &str| -> (Vec<u8>, Vec<u8>) {
        let csv = dir.path().join(format!("{name}.csv"));
        let truth = dir.path().join(format!("{name}.toml"));
        simulate(
            &robot,
            Some(40),
            Some(0.02),
            Some(seed),
            &[
                "--geom-errors",
                "--effect",
                "joint-cyclic:2:1e-4,2e-4",
                "--truth",
                s(&truth),
            ],
            &csv,
        );
        (std::fs::read(csv).unwrap(), std::fs::read(truth).unwrap())
    };
    let a = run(42, "a");
    let b = run(42, "b");
    let c = run(43, "c");
    assert_eq!(a, b);
    assert_ne!(a.0, c.0);
    assert_ne!(a.1, c.1);
}

#[test]
fn the_noise_level_does_not_move_the_poses() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20);
    let read = |noise: f64, geom: bool| {
        let csv = dir.path().join("d.csv");
        let extra: &[&str] = if geom { &["--geom-errors"] } else { &[] };
        simulate(&robot, Some(20), Some(noise), Some(9), extra, &csv);
        measurements::load::<6>(&csv).unwrap()
    };
    let (a, b, c) = (read(0.0, false), read(0.1, false), read(0.0, true));
    for ((x, y), z) in a.records.iter().zip(&b.records).zip(&c.records) {
        assert_eq!(x.q_deg, y.q_deg);
        assert_eq!(x.q_deg, z.q_deg);
        assert_ne!(x.xyz_mm, y.xyz_mm);
    }
}

#[test]
fn malformed_files_fail_with_one_located_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = write(d, "robot.toml", ER20);
    let good_csv = d.join("good.csv");
    simulate(&robot, Some(5), None, None, &[], &good_csv);
    let good = std::fs::read_to_string(&good_csv).unwrap();
    let head = "q1,q2,q3,q4,q5,q6,x,y,z";

    // Robot files: the text and the line the error must name (a syntax or type error's own
    // line; for a bad value or a missing key, the header of the table holding it).
    let line_of =
        |text: &str, needle: &str| text[..text.find(needle).unwrap()].matches('\n').count() + 1;
    let effect = |kind: &str, joint: usize| {
        format!("{ER20}[[effects]]\nkind = \"{kind}\"\njoint = {joint}\nvalues = [1.0]\n")
    };
    let joint4 = ER20.match_indices("[[joints]]").nth(3).unwrap().0;
    let joint5 = ER20.match_indices("[[joints]]").nth(4).unwrap().0;
    let toml_cases = [
        (
            ER20.replacen("d_mm = 504.0", "d_mm = = 504.0", 1),
            line_of(ER20, "d_mm = 504.0"),
        ),
        (
            ER20.replacen("a_mm = 780.0", "a_mm = \"780\"", 1),
            line_of(ER20, "a_mm = 780.0"),
        ),
        (
            ER20.replacen("d_mm = 760.0\n", "", 1),
            ER20[..joint4].matches('\n').count() + 1,
        ),
        (
            effect("joint-gravity", 2),
            line_of(&effect("x", 2), "[[effects]]"),
        ),
        (
            effect("joint-scale", 9),
            line_of(&effect("x", 2), "[[effects]]"),
        ),
        (
            ER20.replacen(
                "limits_deg = [-125.0, 125.0]",
                "limits_deg = [125.0, -125.0]",
                1,
            ),
            ER20[..joint5].matches('\n').count() + 1,
        ),
    ];
    for (i, (text, line)) in toml_cases.iter().enumerate() {
        let bad = write(d, &format!("bad{i}.toml"), text);
        for args in [
            vec!["check", "--robot", s(&bad), "--data", s(&good_csv)],
            vec!["simulate", "--robot", s(&bad), "--out", s(&d.join("x.csv"))],
            vec![
                "--json",
                "check",
                "--robot",
                s(&bad),
                "--data",
                s(&good_csv),
            ],
        ] {
            let out = kinecal(&args);
            let (l, _, msg) = one_line_error(&out, &bad);
            assert_eq!(l, *line, "{msg}");
            assert_stdout_of_failure(&out, args[0] == "--json", &msg);
        }
    }

    // Measurement files: (text, line, column).
    let data_line = good.lines().nth(1).unwrap();
    let mut cells: Vec<&str> = data_line.split(',').collect();
    cells[2] = "abc";
    let text_cell = cells.join(",");
    cells[2] = "nan";
    let nan_cell = cells.join(",");
    let csv_cases = [
        (format!("q1,q2,q3,q4,q5,x,y,z\n{data_line}\n"), 1, 1),
        (format!("{good}{text_cell}\n"), 7, 3),
        (format!("{good}{nan_cell}\n"), 7, 3),
        (format!("{good}1,2,3,4\n"), 7, 5),
        (format!("q1,q2,q3,q4,q5,q6,q7,x,y,z\n{data_line}\n"), 1, 7),
        (
            format!("{head}\n{data_line}{}\n", " ".repeat(5000)),
            2,
            measurements::LINE_CAPACITY + 1,
        ),
        (String::new(), 1, 1),
    ];
    for (i, (text, line, col)) in csv_cases.iter().enumerate() {
        let bad = write(d, &format!("bad{i}.csv"), text);
        let (l, c, msg) = one_line_error(
            &kinecal(&["check", "--robot", s(&robot), "--data", s(&bad)]),
            &bad,
        );
        assert_eq!((l, c), (*line, *col), "{msg}");
    }
}

/// Point-set registration recovers a known rigid motion, never returns a reflection, and
/// refuses points on a line.
#[test]
fn registration_recovers_a_rigid_motion() {
    use kinecal::Frame;
    use kinecal_cli::compute::registration::fit_rigid;
    let truth = Frame::from_xyz_rpy([1500.0, -2500.0, 400.0], [0.3, -0.2, 2.5]);
    let a: Vec<Vector3<f64>> = (0..20)
        .map(|i| {
            let t = i as f64;
            Vector3::new(
                800.0 * (0.7 * t).sin(),
                600.0 * (1.3 * t).cos(),
                50.0 * t - 400.0,
            )
        })
        .collect();
    let b: Vec<Vector3<f64>> = a.iter().map(|p| truth.point(p)).collect();
    let f = fit_rigid(&a, &b).unwrap();
    assert!((f.o - truth.o).norm() < 1e-9);
    assert!((f.rotation() - truth.rotation()).norm() < 1e-12);
    assert!(f.rotation().determinant() > 0.0);
    // Mirror images: the best proper rotation, not the reflection.
    let mirrored: Vec<Vector3<f64>> = b.iter().map(|p| Vector3::new(-p.x, p.y, p.z)).collect();
    assert!((fit_rigid(&a, &mirrored).unwrap().rotation().determinant() - 1.0).abs() < 1e-12);
    let line: Vec<Vector3<f64>> = (0..10)
        .map(|i| Vector3::new(i as f64, 2.0 * i as f64, 0.0))
        .collect();
    assert!(fit_rigid(&line, &line).is_err());
    assert!(fit_rigid(&a[..2], &b[..2]).is_err());
}

#[test]
fn effect_arguments() {
    use kinecal_cli::simulation::EffectArg;
    let e: EffectArg = "joint-cyclic:3:1e-4,-2e-4:2".parse().unwrap();
    assert_eq!(
        (e.kind.as_str(), e.joint, e.values.clone(), e.order),
        ("joint-cyclic", 2, vec![1e-4, -2e-4], 2)
    );
    let e: EffectArg = "joint-table:1:0,1e-4,-1e-4".parse().unwrap();
    assert_eq!(e.values.len(), 3);
    for bad in [
        "joint-scale:2",
        "joint-scale:0:1e-3",
        "joint-scale:x:1e-3",
        "joint-scale:2:abc",
        "joint-scale:2:nan",
        "joint-scale:2:1,2",
        "joint-cyclic:2:1",
        "joint-cyclic:2:1,2:0",
        "joint-scale:2:1:2",
        "joint-table:2:1",
        "joint-backlash:2:1",
    ] {
        assert!(bad.parse::<EffectArg>().is_err(), "{bad}");
    }
    // Through the binary: one line, non-zero exit.
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20);
    let out = kinecal(&[
        "simulate",
        "--robot",
        s(&robot),
        "--effect",
        "joint-scale:7:1e-3",
        "--out",
        s(&dir.path().join("d.csv")),
    ]);
    assert!(!out.status.success());
    assert_eq!(String::from_utf8_lossy(&out.stderr).lines().count(), 1);
}

/// Random configurations are uniform within the limits and written without loss.
#[test]
fn configurations_within_limits() {
    use kinecal_cli::simulation::{random_configurations, Streams};
    let file = RobotFile::parse(ER20, "er20").unwrap();
    let r = file.to_robot::<6>().unwrap();
    let qs = random_configurations(&r, 5000, &mut Streams::new(1).configs);
    for q in &qs {
        assert!(r.within_limits(q));
        for x in q {
            assert_eq!(measurements::quantize_deg(x.to_degrees()).to_radians(), *x);
        }
    }
    // Mean of joint 2 (limits −150..90) near −30°.
    let mean = qs.iter().map(|q| q[1].to_degrees()).sum::<f64>() / qs.len() as f64;
    assert!((mean + 30.0).abs() < 3.0, "{mean}");
}
