//! Named reflectors (`[[tools]]`) outside identification: `simulate` writes each one's
//! columns, and `compensate` names the reflector its targets are points of and says why
//! targets were not reached when they belong to another reflector or another frame.

use super::observations_cli::three_reflector_robot;
use crate::common::{json_of, kinecal, kinecal_ok, run_on, s, stderr, write};
use kinecal::forward::ForwardKinematics;
use kinecal_cli::formats::robot_file::RobotFile;
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};

/// `compensate` with a model of three reflectors took every target as a point of the first,
/// silently: reflector B's targets came back `limited` (exit 3) with no word of which
/// reflector they were taken for. Now `--tool NAME` names it (the commands then reach B's
/// targets to the solver's tolerance), the first is taken with a warning, an unknown name is
/// refused with the list, and a targets file with `x_B…` instead of `x, y, z` is told so.
#[test]
fn compensate_names_the_reflector_the_targets_are_for() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "model.toml", &three_reflector_robot().0);
    // The file states no base: the targets are in the robot's base frame.
    let model = RobotFile::load(&robot).unwrap().to_robot::<6>().unwrap();
    let mut rng = rand::rngs::StdRng::seed_from_u64(45);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let (mut targets, mut named) = (
        String::from("q1,q2,q3,q4,q5,q6,x,y,z\n"),
        String::from("q1,q2,q3,q4,q5,q6,x_B,y_B,z_B\n"),
    );
    let mut truth = Vec::new();
    for _ in 0..20 {
        let q: [f64; 6] = std::array::from_fn(|_| rng.random_range(-120.0f64..120.0));
        let p = fk
            .compute_point(&model, &q.map(f64::to_radians), 1)
            .unwrap();
        let seed = q.map(|v| format!("{:.6}", v + 0.3)).join(",");
        let row = format!("{seed},{:.6},{:.6},{:.6}\n", p.x, p.y, p.z);
        targets += &row;
        named += &row;
        truth.push(q);
    }
    let targets = write(dir.path(), "targets.csv", &targets);
    let named = write(dir.path(), "named.csv", &named);
    let out = dir.path().join("q.csv");
    let run = |t: &std::path::Path, extra: &[&str]| {
        let mut args = vec!["compensate", "--model", s(&robot), "--targets", s(t)];
        args.extend(["--out", s(&out)]);
        args.extend(extra);
        kinecal(&args)
    };
    let b = run(&targets, &["--tool", "B"]);
    assert_eq!(b.status.code(), Some(0), "{}", stderr(&b));
    assert!(!stderr(&b).contains("warning"), "{}", stderr(&b));
    let commands = std::fs::read_to_string(&out).unwrap();
    for (line, q) in commands.lines().skip(1).zip(&truth) {
        let c: [f64; 6] = std::array::from_fn(|j| {
            line.split(',')
                .nth(j)
                .unwrap()
                .parse::<f64>()
                .unwrap()
                .to_radians()
        });
        assert!(line.contains(",ok,"), "{line}");
        let mut at = |q: &[f64; 6], k| fk.compute_point(&model, q, k).unwrap();
        let miss = (at(&c, 1) - at(&q.map(f64::to_radians), 1)).norm();
        assert!(miss < 0.01, "reflector B {miss} mm from its target");
    }
    let v = json_of(&run(&targets, &["--tool", "B", "--json"]));
    assert_eq!(v["reflector"], "B", "{v}");
    assert!(v["hint"].is_null(), "{v}");
    let first = run(&targets, &[]);
    assert!(
        stderr(&first).contains("3 reflectors (\"A\", \"B\", \"C\")")
            && stderr(&first).contains("--tool NAME"),
        "{}",
        stderr(&first)
    );
    // A controller that keeps one TCP: its model is taken as it is, and the targets are B's.
    let single = write(
        dir.path(),
        "controller.toml",
        &(three_reflector_robot()
            .0
            .split("[[tools]]")
            .next()
            .unwrap()
            .to_string()
            + "[tool]\nxyz_mm = [-30, 52, 120]\n"),
    );
    let cartesian = run(
        &targets,
        &["--tool", "B", "--cartesian", "--robot", s(&single)],
    );
    assert_eq!(cartesian.status.code(), Some(0), "{}", stderr(&cartesian));
    let a = run(&targets, &["--tool", "A"]);
    assert_eq!(a.status.code(), Some(3), "{}", stderr(&a));
    let unknown = run(&targets, &["--tool", "D"]);
    assert_eq!(unknown.status.code(), Some(2));
    assert!(
        stderr(&unknown).contains("\"A\", \"B\", \"C\""),
        "{}",
        stderr(&unknown)
    );
    let columns = run(&named, &["--tool", "B"]);
    assert_eq!(columns.status.code(), Some(2));
    assert!(
        stderr(&columns).contains("missing required columns x, y, z")
            && stderr(&columns).contains("rename them x, y, z"),
        "{}",
        stderr(&columns)
    );
}

/// `simulate` from a robot file with three `[[tools]]` wrote only `x, y, z` of the first
/// reflector and named the reflectors `p1, p2, p3` in the truth file. It now writes every
/// reflector's columns, moves each point with `--geom-errors`, and keeps the names; each
/// reflector's readings are the true robot's point (checked here with the library's forward
/// kinematics of the truth file), and `identify` fits the session to its noise.
#[test]
fn simulate_writes_every_named_reflector() {
    let dir = tempfile::tempdir().unwrap();
    let (text, nominal) = three_reflector_robot();
    let robot = write(dir.path(), "robot.toml", &text);
    let (data, truth) = (dir.path().join("d.csv"), dir.path().join("t.toml"));
    let args = [
        "--poses",
        "150",
        "--noise-mm",
        "0",
        "--geom-errors",
        "--seed",
        "4",
    ];
    let mut cmd = vec![
        "simulate",
        "--robot",
        s(&robot),
        "--out",
        s(&data),
        "--truth",
        s(&truth),
    ];
    cmd.extend(args);
    kinecal_ok(&cmd);
    let csv = std::fs::read_to_string(&data).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    assert_eq!(
        header[6..],
        ["x_A", "y_A", "z_A", "x_B", "y_B", "z_B", "x_C", "y_C", "z_C"],
        "{header:?}"
    );
    let file = RobotFile::load(&truth).unwrap();
    assert_eq!(file.tool_names(), ["A", "B", "C"]);
    let model = file.to_robot::<6>().unwrap();
    let mut fk = ForwardKinematics::<f64, 6>::new();
    for k in 0..3 {
        let moved = model.tool_point(k).unwrap() - nominal.tool_point(k).unwrap();
        assert!(
            moved.norm() > 1e-3 && moved.amax() <= 0.5 + 1e-9,
            "{k}: {moved}"
        );
    }
    for line in csv.lines().skip(1).take(20) {
        let v: Vec<f64> = line.split(',').map(|c| c.parse().unwrap()).collect();
        let q: [f64; 6] = std::array::from_fn(|i| v[i].to_radians());
        for k in 0..3 {
            let p = fk.compute_point(&model, &q, k).unwrap();
            let read = Vector3::new(v[6 + 3 * k], v[7 + 3 * k], v[8 + 3 * k]);
            assert!(
                (p - read).norm() < 1e-4,
                "{line}: reflector {k} {p} vs {read}"
            );
        }
    }
    let v = json_of(&run_on("identify", &robot, &data, &["--json"]));
    assert!(
        v["after"]["identification_rms_mm"].as_f64().unwrap() < 1e-3,
        "{v}"
    );
    // Sweeps and constraint sessions follow one point: refused with the reason.
    for session in [["--sweeps", "1,2"], ["--constraints", "socket:4x10"]] {
        let mut args = vec!["simulate", "--robot", s(&robot), "--out", s(&data)];
        args.extend(session);
        let out = kinecal(&args);
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        assert!(stderr(&out).contains("one [tool]"), "{}", stderr(&out));
    }
}

/// Targets in the robot base frame given to a model with a `[base]` (the tracker's frame)
/// came back 100 × `unreachable` with no word on why. The unreached targets now lie metres
/// from the model's tool at their seeds and within millimetres once the `[base]` places them:
/// the hint says they look given in the robot base frame. The same targets in the
/// measurement frame are all reached, without a hint.
#[test]
fn compensate_says_when_targets_look_given_in_the_robot_base_frame() {
    let dir = tempfile::tempdir().unwrap();
    let (text, _) = three_reflector_robot();
    let text =
        format!("{text}[base]\nxyz_mm = [400.0, -3000.0, 200.0]\nrpy_deg = [0.0, 0.0, 25.0]\n");
    let robot = write(dir.path(), "model.toml", &text);
    let model = RobotFile::load(&robot).unwrap().to_robot::<6>().unwrap();
    let base = *model.base();
    let mut rng = rand::rngs::StdRng::seed_from_u64(46);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let header = "q1,q2,q3,q4,q5,q6,x,y,z\n";
    let (mut measured, mut robot_frame) = (String::from(header), String::from(header));
    for _ in 0..30 {
        let q: [f64; 6] = std::array::from_fn(|_| rng.random_range(-120.0f64..120.0));
        let p = fk
            .compute_point(&model, &q.map(f64::to_radians), 0)
            .unwrap();
        let local = base.inverse().point(&p);
        let seed = q.map(|v| format!("{:.6}", v + 0.2)).join(",");
        measured += &format!("{seed},{:.6},{:.6},{:.6}\n", p.x, p.y, p.z);
        robot_frame += &format!("{seed},{:.6},{:.6},{:.6}\n", local.x, local.y, local.z);
    }
    let out = dir.path().join("q.csv");
    let run = |t: &str, name: &str| {
        let t = write(dir.path(), name, t);
        kinecal(&[
            "compensate",
            "--model",
            s(&robot),
            "--targets",
            s(&t),
            "--out",
            s(&out),
            "--json",
        ])
    };
    let ok = run(&measured, "measured.csv");
    assert_eq!(ok.status.code(), Some(0), "{}", stderr(&ok));
    let v = json_of(&ok);
    assert!(v["hint"].is_null() && v["failed"] == 0, "{v}");
    let wrong = run(&robot_frame, "robot_frame.csv");
    assert_eq!(wrong.status.code(), Some(3), "{}", stderr(&wrong));
    let v: serde_json::Value = serde_json::from_slice(&wrong.stdout).unwrap();
    let hint = v["hint"].as_str().expect("a hint");
    assert!(
        hint.contains("look given in the robot base frame"),
        "{hint}"
    );
    assert!(stderr(&wrong).contains(hint), "{}", stderr(&wrong));
    // Three targets of the measured file out of reach (moved 300 mm further from the base):
    // just out of reach, no frame hint.
    let mut lines: Vec<String> = measured.lines().map(String::from).collect();
    for line in lines.iter_mut().skip(1).take(3) {
        let mut c: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let p = Vector3::new(c[6], c[7], c[8]);
        let out = p + (p - base.o).normalize() * 300.0;
        c[6..9].copy_from_slice(&[out.x, out.y, out.z]);
        *line = c
            .iter()
            .map(|v| format!("{v:.6}"))
            .collect::<Vec<_>>()
            .join(",");
    }
    let few = run(&(lines.join("\n") + "\n"), "few.csv");
    assert_eq!(few.status.code(), Some(3), "{}", stderr(&few));
    let v: serde_json::Value = serde_json::from_slice(&few.stdout).unwrap();
    assert!(
        v["failed"].as_u64().unwrap() <= 3 && v["hint"].is_null(),
        "{v}"
    );
    // Reflector B's points taken as A's (no --tool): the hint names B.
    let mut b_points = String::from(header);
    for line in measured.lines().skip(1) {
        let c: Vec<f64> = line.split(',').map(|x| x.parse().unwrap()).collect();
        let q: [f64; 6] = std::array::from_fn(|i| (c[i] - 0.2).to_radians());
        let p = fk.compute_point(&model, &q, 1).unwrap();
        let seed = c[..6]
            .iter()
            .map(|v| format!("{v:.6}"))
            .collect::<Vec<_>>()
            .join(",");
        b_points += &format!("{seed},{:.6},{:.6},{:.6}\n", p.x, p.y, p.z);
    }
    let as_a = run(&b_points, "b_points.csv");
    let v: serde_json::Value = serde_json::from_slice(&as_a.stdout).unwrap();
    let hint = v["hint"].as_str().unwrap_or_default();
    assert!(hint.contains("give --tool B"), "{v}");
}
