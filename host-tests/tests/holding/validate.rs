//! `kinecal validate`: a calibrated model judged on another session's data (docs/formats.md,
//! "Validation on another session"). Simulated truths: a model calibrated on session 1 holds on
//! a session 2 where only the tracker and the probe moved, and is refused (exit 3) on a
//! session 2 of a robot whose geometry changed; the registration lists what it fitted; 6-D
//! data and several reflectors work (the real UR10 series, changes the nominal robot hides and
//! wrong readings: `validate_sessions.rs`).

use crate::common::{json_of, kinecal, s, simulate, stderr, write, ER20_PLACED};
use kinecal::{ForwardKinematics, Frame};
use kinecal_cli::formats::robot_file::{BaseSpec, RobotFile};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use std::path::{Path, PathBuf};
use std::process::Output;

const REASON: &str = "the robot or the set-up changed since calibration: recalibrate";

/// `kinecal validate --robot R --model M --data D EXTRA… --json`.
pub(super) fn validate(robot: &Path, model: &Path, data: &Path, extra: &[&str]) -> Output {
    let mut args = vec![
        "validate",
        "--robot",
        s(robot),
        "--model",
        s(model),
        "--data",
        s(data),
        "--json",
    ];
    args.extend_from_slice(extra);
    kinecal(&args)
}

/// stdout as one JSON object, whatever the exit status.
pub(super) fn json_any(out: &Output) -> serde_json::Value {
    serde_json::from_slice(&out.stdout)
        .unwrap_or_else(|e| panic!("stdout is JSON ({e}): {}", stderr(out)))
}

pub(super) fn num(v: &serde_json::Value, path: &[&str]) -> f64 {
    let mut v = v;
    for k in path {
        v = &v[*k];
    }
    v.as_f64()
        .unwrap_or_else(|| panic!("{path:?} is not a number: {v}"))
}

fn names(v: &serde_json::Value) -> Vec<String> {
    v.as_array()
        .unwrap_or_else(|| panic!("an array: {v}"))
        .iter()
        .map(|x| x.as_str().unwrap().to_string())
        .collect()
}

/// `identify --robot R --data D --out M` (asserting success); returns M.
pub(super) fn calibrate(dir: &Path, robot: &Path, data: &Path, name: &str) -> PathBuf {
    let model = dir.join(name);
    let out = kinecal(&[
        "identify",
        "--robot",
        s(robot),
        "--data",
        s(data),
        "--out",
        s(&model),
        "--json",
    ]);
    let j = json_of(&out);
    assert_eq!(j["converged"], true, "{j}");
    model
}

/// The robot file at `from` edited by `f`, written to `dir/name`.
pub(super) fn edited(
    from: &Path,
    dir: &Path,
    name: &str,
    f: impl FnOnce(&mut RobotFile),
) -> PathBuf {
    let mut file = RobotFile::load(from).unwrap();
    f(&mut file);
    let p = dir.join(name);
    std::fs::write(&p, file.to_toml().unwrap()).unwrap();
    p
}

/// Moves the base by `dxyz` (mm) and `drpy` (degrees) and every tool point by `dtool` (mm).
pub(super) fn move_setup(f: &mut RobotFile, dxyz: [f64; 3], drpy: [f64; 3], dtool: [f64; 3]) {
    let b = f.base.clone().unwrap_or(BaseSpec {
        xyz_mm: [0.0; 3],
        rpy_deg: [0.0; 3],
    });
    f.base = Some(BaseSpec {
        xyz_mm: std::array::from_fn(|a| b.xyz_mm[a] + dxyz[a]),
        rpy_deg: std::array::from_fn(|a| b.rpy_deg[a] + drpy[a]),
    });
    for (a, d) in dtool.iter().enumerate() {
        f.tool.xyz_mm[a] += d;
        for t in f.tools.iter_mut() {
            t.xyz_mm[a] += d;
        }
    }
}

/// A session from `truth` (a robot file): `poses` random poses within the joint limits, the
/// points of every tool point (`x_NAME` … with several) with noise `noise_mm` per axis and,
/// with `six_d`, the tool frame's orientation with noise `noise_deg` per component.
fn session(
    truth: &Path,
    poses: usize,
    seed: u64,
    (noise_mm, noise_deg): (f64, f64),
    six_d: bool,
) -> String {
    let file = RobotFile::load(truth).unwrap();
    let robot = file.to_robot::<6>().unwrap();
    let names = file.tool_names();
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    let np = Normal::new(0.0, noise_mm).unwrap();
    let nr = Normal::new(0.0, noise_deg.to_radians()).unwrap();
    let mut head: Vec<String> = (1..=6).map(|j| format!("q{j}")).collect();
    if names.len() > 1 {
        for n in &names {
            head.extend(["x", "y", "z"].map(|a| format!("{a}_{n}")));
        }
    } else {
        head.extend(["x", "y", "z"].map(String::from));
    }
    if six_d {
        head.extend(["rx_deg", "ry_deg", "rz_deg"].map(String::from));
    }
    let mut csv = head.join(",") + "\n";
    let mut fk = ForwardKinematics::<f64, 6>::new();
    for _ in 0..poses {
        let q: [f64; 6] = std::array::from_fn(|j| {
            let [lo, hi] = file.limits_deg(j);
            rng.random_range(lo.max(-170.0)..hi.min(170.0))
        });
        let qr = q.map(f64::to_radians);
        let mut row: Vec<String> = q.iter().map(|v| format!("{v:.6}")).collect();
        for k in 0..names.len().max(1) {
            let p = fk.compute_point(&robot, &qr, k).unwrap()
                + Vector3::from_fn(|_, _| np.sample(&mut rng));
            row.extend([p.x, p.y, p.z].map(|v| format!("{v:.6}")));
        }
        if six_d {
            fk.compute_point(&robot, &qr, 0).unwrap();
            let mut frame: Frame<f64> = fk.tool_pose(&robot);
            frame.rotate_in_parent(&Vector3::from_fn(|_, _| nr.sample(&mut rng)));
            row.extend(frame.rpy().map(|v| format!("{:.8}", v.to_degrees())));
        }
        csv += &(row.join(",") + "\n");
    }
    csv
}

/// Session 1 of the ER20-like robot with geometric errors (`simulate --geom-errors --truth`),
/// the model calibrated on it, and the true robot's file.
pub(super) struct Calibrated {
    pub(super) dir: tempfile::TempDir,
    pub(super) robot: PathBuf,
    pub(super) truth: PathBuf,
    pub(super) model: PathBuf,
    /// Session 1's data.
    pub(super) s1: PathBuf,
}

pub(super) fn calibrated() -> Calibrated {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20_PLACED);
    let truth = dir.path().join("truth.toml");
    let s1 = dir.path().join("s1.csv");
    simulate(
        &robot,
        Some(150),
        Some(0.02),
        Some(11),
        &["--geom-errors", "--truth", s(&truth)],
        &s1,
    );
    let model = calibrate(dir.path(), &robot, &s1, "model.toml");
    Calibrated {
        dir,
        robot,
        truth,
        model,
        s1,
    }
}

/// The same robot a day later: the tracker moved 50 mm and turned 2°, the probe sits 3 mm
/// elsewhere. Registered (base+tool), the model predicts the session at the noise and far
/// better than the nominal robot registered the same way: exit 0.
#[test]
fn the_same_robot_with_the_setup_moved_is_accepted() {
    let c = calibrated();
    let d = c.dir.path();
    let t2 = edited(&c.truth, d, "truth2.toml", |f| {
        move_setup(f, [50.0, -20.0, 10.0], [0.5, -0.3, 2.0], [2.0, -1.5, 2.0])
    });
    let s2 = d.join("s2.csv");
    simulate(&t2, Some(150), Some(0.02), Some(12), &[], &s2);
    let out = validate(&c.robot, &c.model, &s2, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let j = json_of(&out);
    let (m, n) = (
        num(&j, &["model", "rms_mm"]),
        num(&j, &["nominal", "rms_mm"]),
    );
    eprintln!("moved set-up: model {m:.4} mm, nominal {n:.4} mm (RMS, registered base+tool)");
    assert_eq!(j["worse_than_nominal"], false);
    assert_eq!(j["register"], "base+tool");
    // Noise 0.02 mm per axis: a distance RMS of 0.035 mm.
    assert!(m < 0.06, "model {m} mm");
    assert!(n > 10.0 * m, "nominal {n} mm against model {m} mm");
    for k in [
        "rms_mm", "mean_mm", "max_mm", "p95_mm", "rms_x_mm", "rms_y_mm",
    ] {
        assert!(
            num(&j, &["model", k]) <= num(&j, &["model", "max_mm"]),
            "{k}"
        );
    }
    assert!(num(&j, &["model", "p95_mm"]) >= num(&j, &["model", "mean_mm"]) * 0.9);
    // The registration found where the tracker went (the true base of session 2).
    let truth2 = RobotFile::load(&t2).unwrap();
    let base = truth2.base.unwrap().xyz_mm;
    for (a, k) in ["base.x", "base.y", "base.z"].iter().enumerate() {
        let got = num(&j, &["model", "registration", k]);
        assert!(
            (got - base[a]).abs() < 0.5,
            "{k}: {got} against {}",
            base[a]
        );
    }
    let tool = truth2.tool.xyz_mm;
    for (a, k) in ["tool.x", "tool.y", "tool.z"].iter().enumerate() {
        let got = num(&j, &["model", "registration", k]);
        assert!(
            (got - tool[a]).abs() < 0.5,
            "{k}: {got} against {}",
            tool[a]
        );
    }
    // Text output: the same verdict.
    let text = kinecal(&[
        "validate",
        "--robot",
        s(&c.robot),
        "--model",
        s(&c.model),
        "--data",
        s(&s2),
    ]);
    assert_eq!(text.status.code(), Some(0));
    let t = String::from_utf8_lossy(&text.stdout);
    assert!(t.contains("the model still holds"), "{t}");
}

/// `--model` the robot file itself (or a copy of it): every figure compared the robot with
/// itself without a word. A note says so and that only the recalibration verdict judges it (a
/// nominal robot judged so is a use: `ur10_distances`); a calibration of it draws none (above).
#[test]
fn a_model_equal_to_the_robot_file_is_told() {
    let c = calibrated();
    let d = c.dir.path();
    let s2 = d.join("s2.csv");
    simulate(&c.truth, Some(60), Some(0.02), Some(12), &[], &s2);
    let copy = d.join("copy.toml");
    std::fs::copy(&c.robot, &copy).unwrap();
    for model in [&c.robot, &copy] {
        let out = validate(&c.robot, model, &s2, &[]);
        let err = stderr(&out);
        assert_ne!(out.status.code(), Some(2), "{err}");
        assert!(
            err.contains("itself") && err.contains("recalibration verdict"),
            "{err}"
        );
    }
    let out = validate(&c.robot, &c.model, &s2, &[]);
    assert!(!stderr(&out).contains("itself"), "{}", stderr(&out));
}

/// The robot changed: session 1's truth has theta2 +0.3°, theta3 −0.3° and a3 +1 mm, session
/// 2's the opposite. The model carries session 1's errors, twice session 2's deviation from
/// nominal: no base or tool registration absorbs that, the model is genuinely worse than the
/// nominal robot, and validate says so (exit 3, the reason on stderr, the JSON printed).
#[test]
fn a_changed_robot_is_refused_with_exit_3() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = write(d, "robot.toml", ER20_PLACED);
    let change = |sign: f64| {
        move |f: &mut RobotFile| {
            f.joints[1].theta_deg += sign * 0.3;
            f.joints[2].theta_deg -= sign * 0.3;
            f.joints[2].a_mm += sign * 1.0;
        }
    };
    let t1 = edited(&robot, d, "truth1.toml", change(1.0));
    let t2 = edited(&robot, d, "truth2.toml", |f| {
        change(-1.0)(f);
        move_setup(f, [30.0, 10.0, -5.0], [0.0, 0.0, 1.0], [1.0, 0.0, -1.0]);
    });
    let (s1, s2) = (d.join("s1.csv"), d.join("s2.csv"));
    simulate(&t1, Some(150), Some(0.02), Some(21), &[], &s1);
    simulate(&t2, Some(150), Some(0.02), Some(22), &[], &s2);
    let model = calibrate(d, &robot, &s1, "model.toml");
    let out = validate(&robot, &model, &s2, &[]);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    let j = json_any(&out);
    let (m, n) = (
        num(&j, &["model", "rms_mm"]),
        num(&j, &["nominal", "rms_mm"]),
    );
    eprintln!("changed robot: model {m:.4} mm, nominal {n:.4} mm (RMS, registered base+tool)");
    assert_eq!(j["worse_than_nominal"], true);
    assert!(m > 1.5 * n, "model {m} mm against nominal {n} mm");
    assert!(
        n > 0.2,
        "the change is beyond what the registration absorbs: {n} mm"
    );
    let err = stderr(&out);
    assert!(err.contains(REASON), "{err}");
    assert_eq!(
        err.lines().filter(|l| l.contains(REASON)).count(),
        1,
        "{err}"
    );
    // The same session judged with the robot as it was: the model holds.
    let s3 = d.join("s3.csv");
    simulate(&t1, Some(150), Some(0.02), Some(23), &[], &s3);
    let ok = validate(&robot, &model, &s3, &[]);
    assert_eq!(ok.status.code(), Some(0), "{}", stderr(&ok));
    assert_eq!(json_of(&ok)["worse_than_nominal"], false);
}

const BASE: [&str; 6] = [
    "base.x", "base.y", "base.z", "base.rx", "base.ry", "base.rz",
];

/// `--register none|base|base+tool` fits what it says, and `none` refuses a robot file without
/// `[base]` (exit 2, one line saying what to do), as JSON too; a bad value is a JSON error.
#[test]
fn register_lists_what_it_fitted_and_none_needs_a_base() {
    let c = calibrated();
    let d = c.dir.path();
    // Session 2 with the set-up as in session 1: even `none` accepts the model.
    let s2 = d.join("s2.csv");
    simulate(&c.truth, Some(60), Some(0.02), Some(13), &[], &s2);
    let tool = ["tool.x", "tool.y", "tool.z"];
    let cases: [(&str, Vec<&str>); 3] = [
        ("none", vec![]),
        ("base", BASE.to_vec()),
        ("base+tool", [&BASE[..], &tool[..]].concat()),
    ];
    for (register, expected) in cases {
        let out = validate(&c.robot, &c.model, &s2, &["--register", register]);
        let j = json_of(&out);
        assert_eq!(j["register"], register);
        assert_eq!(names(&j["registered"]), expected, "{register}");
        assert_eq!(j["worse_than_nominal"], false, "{register}");
        assert!(num(&j, &["model", "rms_mm"]) < 0.06, "{register}: {j}");
        let fitted: Vec<String> = j["model"]["registration"]
            .as_object()
            .unwrap()
            .keys()
            .cloned()
            .collect();
        let mut sorted = expected.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        sorted.sort();
        assert_eq!(fitted, sorted, "{register}");
    }
    // The nominal file without [base]: `none` cannot place it.
    let no_base = edited(&c.robot, d, "no_base.toml", |f| f.base = None);
    for json in [false, true] {
        let mut args = vec![
            "validate",
            "--robot",
            s(&no_base),
            "--model",
            s(&c.model),
            "--data",
            s(&s2),
            "--register",
            "none",
        ];
        if json {
            args.push("--json");
        }
        let out = kinecal(&args);
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        let err = stderr(&out);
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(
            err.contains("has no [base]") && err.contains("--register base"),
            "{err}"
        );
        if json {
            let e = json_any(&out);
            assert!(
                e["error"].as_str().unwrap().contains("has no [base]"),
                "{e}"
            );
        }
    }
    // …but registering the base places it.
    let out = validate(&no_base, &c.model, &s2, &["--register", "base"]);
    assert_eq!(names(&json_of(&out)["registered"]), BASE.to_vec());
    // A value that is not a registration: a JSON error, exit 2.
    let out = validate(&c.robot, &c.model, &s2, &["--register", "tool"]);
    assert_eq!(out.status.code(), Some(2));
    let e = json_any(&out);
    let msg = e["error"].as_str().unwrap();
    assert!(
        msg.contains("--register") && msg.contains("base+tool"),
        "{msg}"
    );
    assert_eq!(e.as_object().unwrap().len(), 1, "{e}");
}

/// The ER20 text with the tool orientation `rpy_deg` stated.
fn er20_with_tool_rpy(rpy: [f64; 3]) -> String {
    ER20_PLACED.replace(
        "[tool]\nxyz_mm = [12.0, -7.0, 100.0]\n",
        &format!(
            "[tool]\nxyz_mm = [12.0, -7.0, 100.0]\nrpy_deg = [{}, {}, {}]\n",
            rpy[0], rpy[1], rpy[2]
        ),
    )
}

/// 6-D observations: the registration fits the tool orientation too, and the orientation
/// figures are reported; the model, calibrated on 6-D session 1, holds on a moved 6-D session
/// 2 with a probe turned by a degree.
#[test]
fn six_d_sessions_register_the_tool_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = er20_with_tool_rpy([10.0, 30.0, -20.0]);
    assert!(text.contains("rpy_deg = [10, 30, -20]"));
    let robot = write(d, "robot.toml", &text);
    let deviate = |f: &mut RobotFile| {
        for (j, row) in f.joints.iter_mut().enumerate() {
            let s = if j % 2 == 0 { 1.0 } else { -1.0 };
            row.theta_deg += s * 0.05;
            row.d_mm += s * 0.4;
            row.a_mm -= s * 0.3;
        }
        f.tool.rpy_deg = Some([10.3, 30.2, -20.4]);
    };
    let t1 = edited(&robot, d, "truth1.toml", deviate);
    let t2 = edited(&t1, d, "truth2.toml", |f| {
        move_setup(f, [40.0, -30.0, 15.0], [0.3, 0.2, -2.0], [1.5, 2.0, -1.0]);
        f.tool.rpy_deg = Some([11.0, 29.5, -19.5]);
    });
    let noise = (0.01, 0.002);
    let s1 = write(d, "s1.csv", &session(&t1, 200, 31, noise, true));
    let s2 = write(d, "s2.csv", &session(&t2, 150, 32, noise, true));
    let model = calibrate(d, &robot, &s1, "model.toml");
    let out = validate(&robot, &model, &s2, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let j = json_of(&out);
    let tool_rot = ["tool.rx", "tool.ry", "tool.rz"];
    let registered = names(&j["registered"]);
    for k in BASE
        .iter()
        .chain(&["tool.x", "tool.y", "tool.z"])
        .chain(&tool_rot)
    {
        assert!(registered.contains(&k.to_string()), "{k} in {registered:?}");
    }
    let (m, n) = (
        num(&j, &["model", "rms_mm"]),
        num(&j, &["nominal", "rms_mm"]),
    );
    let (md, nd) = (
        num(&j, &["model", "rms_deg"]),
        num(&j, &["nominal", "rms_deg"]),
    );
    eprintln!("6-D: model {m:.4} mm {md:.5}°, nominal {n:.4} mm {nd:.5}°");
    assert!(m < 0.05, "model {m} mm");
    assert!(n > 5.0 * m, "nominal {n} mm against model {m} mm");
    // Orientation noise 0.002° per component: an RMS angle of 0.0035°.
    assert!(md < 0.01, "model {md}°");
    assert!(nd > md, "nominal {nd}° against model {md}°");
    assert!(num(&j, &["model", "p95_deg"]) <= num(&j, &["model", "max_deg"]));
    // Positions only: no orientation figures, no tool orientation fitted.
    let p = json_of(&validate(&robot, &model, &s2, &["--positions-only"]));
    assert!(p["model"].get("rms_deg").is_none());
    assert!(!names(&p["registered"]).contains(&"tool.rx".to_string()));
}

/// Three reflectors (`[[tools]]` A, B, C; `x_A` … columns): every reflector is registered
/// (`tool2.x` … `tool3.z`) and has its figures under `per_point`.
#[test]
fn several_reflectors_are_registered_and_judged_each() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let tools = "[[tools]]\nname = \"A\"\nxyz_mm = [60.0, 0.0, 110.0]\n\
                 [[tools]]\nname = \"B\"\nxyz_mm = [-30.0, 52.0, 120.0]\n\
                 [[tools]]\nname = \"C\"\nxyz_mm = [-30.0, -52.0, 95.0]\n";
    let text = ER20_PLACED.replace("[tool]\nxyz_mm = [12.0, -7.0, 100.0]\n", tools);
    assert!(text.contains("name = \"C\""));
    let robot = write(d, "robot.toml", &text);
    let t1 = edited(&robot, d, "truth1.toml", |f| {
        for (j, row) in f.joints.iter_mut().enumerate() {
            let s = if j % 2 == 0 { 1.0 } else { -1.0 };
            row.theta_deg -= s * 0.06;
            row.a_mm += s * 0.5;
        }
    });
    let t2 = edited(&t1, d, "truth2.toml", |f| {
        move_setup(f, [-25.0, 40.0, 5.0], [0.0, 0.5, 1.5], [0.8, -0.6, 1.0])
    });
    let s1 = write(d, "s1.csv", &session(&t1, 150, 41, (0.02, 0.0), false));
    let s2 = write(d, "s2.csv", &session(&t2, 100, 42, (0.02, 0.0), false));
    let model = calibrate(d, &robot, &s1, "model.toml");
    let out = validate(&robot, &model, &s2, &[]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let j = json_of(&out);
    let registered = names(&j["registered"]);
    for k in ["tool.x", "tool2.x", "tool2.z", "tool3.y", "tool3.z"] {
        assert!(registered.contains(&k.to_string()), "{k} in {registered:?}");
    }
    assert_eq!(registered.len(), 6 + 9);
    assert_eq!(j["observations"], 300);
    let pp = j["per_point"].as_object().unwrap();
    assert_eq!(pp.keys().cloned().collect::<Vec<_>>(), ["A", "B", "C"]);
    let mut sum2 = 0.0;
    for (name, p) in pp {
        let (m, n) = (num(p, &["model", "rms_mm"]), num(p, &["nominal", "rms_mm"]));
        eprintln!("reflector {name}: model {m:.4} mm, nominal {n:.4} mm");
        assert_eq!(p["observations"], 100);
        assert!(m < 0.06 && n > 5.0 * m, "{name}: model {m}, nominal {n}");
        sum2 += m * m * 100.0;
    }
    // The totals are over every reflector's observations.
    let total = (sum2 / 300.0).sqrt();
    assert!((total - num(&j, &["model", "rms_mm"])).abs() < 1e-9);
}

/// The figures of the page's cell `key` (`td[data-key=…]`), as printed.
fn cell(doc: &scraper::Html, key: &str) -> String {
    let sel = scraper::Selector::parse(&format!("td[data-key=\"{key}\"]")).unwrap();
    let all: Vec<String> = doc
        .select(&sel)
        .map(|e| e.text().collect::<String>().trim().to_string())
        .collect();
    assert_eq!(all.len(), 1, "{key}: {} cells", all.len());
    all[0].clone()
}

/// `report --validate-json V.json`: the page has the validation section with the very figures
/// of the JSON (4 significant digits, as the page prints every figure), the registration and
/// the verdict; a model worse than nominal turns the section's verdict and a page warning red.
#[test]
fn the_report_shows_the_validation_of_another_session() {
    use kinecal_cli::output::numfmt::sig;
    let c = calibrated();
    let d = c.dir.path();
    let t2 = edited(&c.truth, d, "truth2.toml", |f| {
        move_setup(f, [50.0, -20.0, 10.0], [0.5, -0.3, 2.0], [2.0, -1.5, 2.0])
    });
    // The same robot moved; and a changed one (theta2 off by 0.4°: the model is worse).
    let t3 = edited(&t2, d, "truth3.toml", |f| f.joints[1].theta_deg += 0.4);
    let (s2, s3) = (d.join("s2.csv"), d.join("s3.csv"));
    simulate(&t2, Some(100), Some(0.02), Some(14), &[], &s2);
    simulate(&t3, Some(100), Some(0.02), Some(15), &[], &s3);
    for (session, worse) in [(&s2, false), (&s3, true)] {
        let out = validate(&c.robot, &c.model, session, &[]);
        assert_eq!(
            out.status.code(),
            Some(if worse { 3 } else { 0 }),
            "{}",
            stderr(&out)
        );
        let v = write(d, "v.json", &String::from_utf8_lossy(&out.stdout));
        let j = json_any(&out);
        let page = d.join("page.html");
        let _ = std::fs::remove_file(&page);
        let r = kinecal(&[
            "report",
            "--robot",
            s(&c.robot),
            "--model",
            s(&c.model),
            "--data",
            s(&c.s1),
            "--validate-json",
            s(&v),
            "--out",
            s(&page),
        ]);
        // The page's verdict is the session's too: a model worse there is no calibration to
        // hand on (exit 3, the page written).
        assert_eq!(
            r.status.code(),
            Some(if worse { 3 } else { 0 }),
            "{}",
            stderr(&r)
        );
        let html = std::fs::read_to_string(&page).unwrap();
        let doc = scraper::Html::parse_document(&html);
        for who in ["model", "nominal"] {
            for (key, json_key) in [
                ("rms", "rms_mm"),
                ("mean", "mean_mm"),
                ("max", "max_mm"),
                ("p95", "p95_mm"),
                ("rms_x", "rms_x_mm"),
                ("rms_y", "rms_y_mm"),
                ("rms_z", "rms_z_mm"),
            ] {
                assert_eq!(
                    cell(&doc, &format!("validate.{who}.{key}")),
                    sig(num(&j, &[who, json_key]), 4),
                    "{who}.{key}"
                );
            }
            assert_eq!(cell(&doc, &format!("validate.{who}.rms_deg")), "-");
        }
        let verdict = scraper::Selector::parse("#validation-verdict").unwrap();
        let v_el = doc.select(&verdict).next().expect("the validation verdict");
        let class = v_el.value().attr("class").unwrap_or_default().to_string();
        let text = v_el.text().collect::<String>();
        assert_eq!(class.contains("bad"), worse, "{class}");
        assert_eq!(text.contains("recalibrate"), worse, "{text}");
        assert!(html.contains("base.x, base.y, base.z, base.rx, base.ry, base.rz, tool.x"));
        assert_eq!(html.contains(REASON), worse);
        let warn = scraper::Selector::parse("p.warn").unwrap();
        assert_eq!(
            doc.select(&warn).count(),
            usize::from(worse),
            "page warnings"
        );
    }
    // Not a validate JSON: refused, naming the file.
    let bad = write(d, "bad.json", "{\"found\": []}");
    let r = kinecal(&[
        "report",
        "--robot",
        s(&c.robot),
        "--model",
        s(&c.model),
        "--data",
        s(&c.s1),
        "--validate-json",
        s(&bad),
        "--out",
        s(&d.join("bad.html")),
    ]);
    assert_eq!(r.status.code(), Some(2));
    assert!(stderr(&r).contains("bad.json: not the JSON of `kinecal validate --json`"));
}

/// A model whose `joint-table` or `joint-cyclic` values were written in degrees (the file
/// holds radians) is far worse than the nominal robot: `validate` still exits 3, but names the
/// effects that look written in degrees (read so, the model predicts the session at the noise)
/// instead of "recalibrate": one table among right effects, a cyclic term alone, and on 6-D
/// data with a stated tool orientation (which the slip throws off too). The right model holds;
/// a table wrong another way (its sign flipped, four times too large) gets the plain verdict.
#[test]
fn a_model_with_effect_values_in_degrees_is_told_so() {
    use kinecal_cli::formats::robot_file::EffectSpec;
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = write(d, "robot.toml", ER20_PLACED);
    // A gearbox's transmission error on joint 2 (±0.05° over 12 knots) and a cyclic error of
    // joint 3 (0.03°, twice per turn).
    let knots: Vec<f64> = (0..12)
        .map(|k| 0.05_f64.to_radians() * (k as f64 * 1.3).sin())
        .collect();
    let cyclic = vec![0.03_f64.to_radians(), -0.01_f64.to_radians()];
    let effects = |table: &[f64], ab: &[f64], rpy: Option<[f64; 3]>| {
        let (table, ab) = (table.to_vec(), ab.to_vec());
        move |f: &mut RobotFile| {
            f.effects.push(EffectSpec {
                kind: "joint-table".into(),
                joint: 2,
                values: table,
                order: None,
                step_deg: Some(30.0),
                start_deg: Some(-165.0),
                reference_c: None,
            });
            f.effects.push(EffectSpec {
                kind: "joint-cyclic".into(),
                joint: 3,
                values: ab,
                order: Some(2),
                step_deg: None,
                start_deg: None,
                reference_c: None,
            });
            f.tool.rpy_deg = rpy;
        }
    };
    let deg = |v: &[f64]| v.iter().map(|x| x.to_degrees()).collect::<Vec<_>>();
    let scaled = |v: &[f64], by: f64| v.iter().map(|x| x * by).collect::<Vec<_>>();
    let truth = edited(&robot, d, "truth.toml", effects(&knots, &cyclic, None));
    let s2 = write(d, "s2.csv", &session(&truth, 150, 31, (0.02, 0.0), false));
    let told = |model: &Path, data: &Path, extra: &[&str]| {
        let out = validate(&robot, model, data, extra);
        assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
        let j = json_any(&out);
        assert_eq!(j["accepted"], false);
        let err = stderr(&out);
        let names = j.get("effects_in_degrees").map_or(Vec::new(), names);
        if !names.is_empty() {
            let (m, r) = (
                num(&j, &["model", "rms_mm"]),
                num(&j, &["effects_as_degrees_rms_mm"]),
            );
            eprintln!("{}: model {m:.3} mm, read as degrees {r:.4} mm", s(model));
            assert!(r < 0.06, "read as degrees the model is the truth: {r} mm");
            assert!(
                err.contains("look written in degrees") && !err.contains(REASON),
                "{err}"
            );
        }
        (names, err)
    };
    let table_deg = edited(
        &robot,
        d,
        "table_deg.toml",
        effects(&deg(&knots), &cyclic, None),
    );
    let (names, _) = told(&table_deg, &s2, &[]);
    assert_eq!(names, ["joint 2's joint-table"]);
    let cyclic_deg = edited(
        &robot,
        d,
        "cyclic_deg.toml",
        effects(&knots, &deg(&cyclic), None),
    );
    let (names, _) = told(&cyclic_deg, &s2, &[]);
    assert_eq!(names, ["joint 3's joint-cyclic of order 2"]);
    let both = edited(
        &robot,
        d,
        "both_deg.toml",
        effects(&deg(&knots), &deg(&cyclic), None),
    );
    let (names, _) = told(&both, &s2, &[]);
    assert_eq!(
        names,
        ["joint 2's joint-table", "joint 3's joint-cyclic of order 2"]
    );
    // 6-D rows and a model that states the tool orientation: the slip turns the tool too.
    let s6 = write(d, "s6.csv", &session(&truth, 150, 32, (0.02, 0.002), true));
    let rpy = Some([0.0; 3]);
    let six = edited(
        &robot,
        d,
        "six_deg.toml",
        effects(&deg(&knots), &cyclic, rpy),
    );
    let (names, _) = told(&six, &s6, &[]);
    assert_eq!(names, ["joint 2's joint-table"]);

    let ok = validate(&robot, &truth, &s2, &[]);
    assert_eq!(ok.status.code(), Some(0), "{}", stderr(&ok));
    assert!(json_of(&ok).get("effects_as_degrees_rms_mm").is_none());
    for (name, by) in [("flipped.toml", -3.0), ("four.toml", 4.0)] {
        let wrong = edited(&robot, d, name, effects(&scaled(&knots, by), &cyclic, None));
        let (names, err) = told(&wrong, &s2, &[]);
        assert!(names.is_empty(), "{name}: {names:?}");
        assert!(err.contains(REASON) && !err.contains("degrees"), "{err}");
    }
}
