//! `kinecal diagnose` on measurement files as trackers deliver them: the search names
//! the missing effect from the first reflector's positions, and the model it writes is fitted
//! to every observation (6-D poses weighted by their σ, several reflectors), so it predicts the
//! orientation and every reflector of poses it never saw at the tracker's noise.

use crate::common::{json_of, run_on, s, stderr, write};
use kinecal::forward::ForwardKinematics;
use kinecal::Frame;
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::HostRobot;
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};

/// MDH rows of a UR10-like arm (alpha°, a mm, theta°, d mm).
pub(crate) const ROWS: [[f64; 4]; 6] = [
    [0.0, 0.0, 0.0, 118.0],
    [90.0, 0.0, 180.0, 0.0],
    [0.0, 612.7, 0.0, 0.0],
    [0.0, 571.6, 0.0, 163.9],
    [-90.0, 0.0, 0.0, 115.7],
    [90.0, 0.0, 180.0, 92.2],
];

/// A robot file: `rows` with the offsets `dev` added (per joint: da, dd, dalpha°, dtheta°),
/// a known base, the tools (`[tool]` when one is unnamed) and `extra` TOML.
pub(crate) fn robot_text(
    dev: &[[f64; 4]; 6],
    tools: &[(&str, [f64; 3])],
    rpy: [f64; 3],
    extra: &str,
) -> String {
    let mut t = String::from("name = \"UR10-like\"\n");
    for (r, d) in ROWS.iter().zip(dev) {
        t += &format!(
            "[[joints]]\nalpha_deg = {}\na_mm = {}\ntheta_deg = {}\nd_mm = {}\nlimits_deg = [-180.0, 180.0]\n",
            r[0] + d[2],
            r[1] + d[0],
            r[2] + d[3],
            r[3] + d[1]
        );
    }
    t += "[base]\nxyz_mm = [400.0, -3000.0, 200.0]\nrpy_deg = [0.0, 0.0, 17.0]\n";
    if tools.len() == 1 {
        let p = tools[0].1;
        t += &format!(
            "[tool]\nxyz_mm = [{}, {}, {}]\nrpy_deg = [{}, {}, {}]\n",
            p[0], p[1], p[2], rpy[0], rpy[1], rpy[2]
        );
    } else {
        for (n, p) in tools {
            t += &format!(
                "[[tools]]\nname = \"{n}\"\nxyz_mm = [{}, {}, {}]\n",
                p[0], p[1], p[2]
            );
        }
    }
    t + extra
}

/// Rows off by up to 0.5 mm and 0.05°.
pub(crate) fn deviations(rng: &mut rand::rngs::StdRng) -> [[f64; 4]; 6] {
    std::array::from_fn(|_| {
        [
            rng.random_range(-0.5..0.5),
            rng.random_range(-0.5..0.5),
            rng.random_range(-0.05..0.05),
            rng.random_range(-0.05..0.05),
        ]
    })
}

/// A hidden once-per-turn error on joint 2 (0.03° and 0.02°: ~0.4 mm at the tool).
const HIDDEN: &str =
    "[[effects]]\nkind = \"joint-cyclic\"\njoint = 2\nvalues = [0.0006, -0.0004]\n";

pub(crate) fn load(
    text: &str,
    dir: &std::path::Path,
    name: &str,
) -> (std::path::PathBuf, HostRobot<6>) {
    let path = write(dir, name, text);
    let robot = RobotFile::load(&path).unwrap().to_robot::<6>().unwrap();
    (path, robot)
}

/// `diagnose --holdout 100 --json --out MODEL` on `data`: succeeds and names the hidden
/// joint-2 error ([`HIDDEN`]); returns the JSON.
fn diagnose_names_the_hidden_error(
    nominal: &std::path::Path,
    data: &std::path::Path,
    model: &std::path::Path,
) -> serde_json::Value {
    let out = run_on(
        "diagnose",
        nominal,
        data,
        &["--holdout", "100", "--json", "--out", s(model)],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let j = json_of(&out);
    let found = j["found"].as_array().unwrap();
    assert!(
        found
            .iter()
            .any(|f| f["effect"] == "joint-cyclic" && f["joint"] == 2),
        "{found:?}"
    );
    j
}

/// 6-D data with σ columns from a robot with a hidden joint-2 error, a turned tool frame and
/// theta offsets: diagnose names the error from positions, and its model (fitted to positions
/// and orientations, weighted by σ) predicts the held-out orientations and positions at the
/// noise, with χ²/dof ≈ 1 for the stated σ.
#[test]
fn six_d_diagnose_fits_the_named_effect_to_orientations() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand::rngs::StdRng::seed_from_u64(1806);
    let tool = [("", [60.0, 10.0, 110.0])];
    let (nominal_path, _) = load(
        &robot_text(&[[0.0; 4]; 6], &tool, [0.0; 3], ""),
        dir.path(),
        "robot.toml",
    );
    let dev = deviations(&mut rng);
    let (_, truth) = load(
        &robot_text(&dev, &tool, [0.2, -0.15, 0.4], HIDDEN),
        dir.path(),
        "truth.toml",
    );
    let (sp, sr): (f64, f64) = (0.01, 0.002); // σ: mm per coordinate, degrees per orientation component
    let np = Normal::new(0.0, sp).unwrap();
    let nr = Normal::new(0.0, sr.to_radians()).unwrap();
    let mut csv =
        String::from("q1,q2,q3,q4,q5,q6,x,y,z,rx_deg,ry_deg,rz_deg,sx_mm,sy_mm,sz_mm,srot_deg\n");
    let mut fk = ForwardKinematics::<f64, 6>::new();
    for _ in 0..400 {
        let q: [f64; 6] = std::array::from_fn(|_| rng.random_range(-170.0f64..170.0));
        let p = fk.compute(&truth, &q.map(f64::to_radians))
            + Vector3::from_fn(|_, _| np.sample(&mut rng));
        let mut frame: Frame<f64> = fk.tool_pose(&truth);
        frame.rotate_in_parent(&Vector3::from_fn(|_, _| nr.sample(&mut rng)));
        let rpy = frame.rpy().map(f64::to_degrees);
        csv += &format!(
            "{},{:.6},{:.6},{:.6},{:.8},{:.8},{:.8},{sp},{sp},{sp},{sr}\n",
            q.map(|v| format!("{v:.6}")).join(","),
            p.x,
            p.y,
            p.z,
            rpy[0],
            rpy[1],
            rpy[2]
        );
    }
    let model = dir.path().join("model.toml");
    let j = diagnose_names_the_hidden_error(
        &nominal_path,
        &write(dir.path(), "data.csv", &csv),
        &model,
    );
    let o = &j["observations"];
    assert_eq!(o["six_d"], true);
    assert_eq!(o["sigma"], true);
    // The search's figures weigh the orientations in (a 6-D file's noise floor read 4× the
    // tracker's position noise as "mm"): said in the JSON and in the text.
    assert_eq!(j["figures_include_orientations"], true);
    assert!(
        j["summary"].as_str().unwrap().contains("not position RMS"),
        "{}",
        j["summary"]
    );
    let v = |side: &str, k: &str| o[side][k].as_f64().unwrap();
    // Noise floors: a held-out point's error RMS is √3 σ; an orientation error's, √3 σ_rot.
    let (floor_mm, floor_deg) = (3f64.sqrt() * sp, 3f64.sqrt() * sr);
    let (deg_before, deg_after) = (
        v("before", "validation_rms_deg"),
        v("after", "validation_rms_deg"),
    );
    let (mm_before, mm_after) = (
        v("before", "validation_rms_mm"),
        v("after", "validation_rms_mm"),
    );
    eprintln!(
        "held out: {mm_before:.4} → {mm_after:.4} mm (floor {floor_mm:.4}), \
         {deg_before:.5}° → {deg_after:.5}° (floor {floor_deg:.5}°), χ²/dof {}",
        o["chi2_per_dof"]
    );
    assert!(mm_after < 1.25 * floor_mm, "{mm_after} mm");
    assert!(mm_before > 5.0 * mm_after, "{mm_before} mm");
    assert!(deg_after < 1.25 * floor_deg, "{deg_after}°");
    assert!(deg_before > deg_after, "{deg_before}° → {deg_after}°");
    let chi2 = o["chi2_per_dof"].as_f64().unwrap();
    assert!((0.8..1.25).contains(&chi2), "χ²/dof {chi2}");
    // The model written is that fit: it has the tool orientation, and predicts the truth's
    // tool frame over the workspace within a few σ.
    let m = RobotFile::load(&model).unwrap().to_robot::<6>().unwrap();
    let mut fk2 = ForwardKinematics::<f64, 6>::new();
    let mut worst: f64 = 0.0;
    for _ in 0..200 {
        let q: [f64; 6] = std::array::from_fn(|_| rng.random_range(-170.0f64..170.0).to_radians());
        fk.compute(&truth, &q);
        fk2.compute(&m, &q);
        let a = fk.tool_pose(&truth).rotation();
        let b = fk2.tool_pose(&m).rotation();
        let angle = nalgebra::Rotation3::from_matrix_unchecked(a.transpose() * b).angle();
        worst = worst.max(angle.to_degrees());
    }
    eprintln!("model vs truth, tool frame: worst {worst:.5}° over 200 poses");
    assert!(worst < 3.0 * sr, "{worst}°");
}

/// Three reflectors, each unseen in some poses, on a robot with a hidden joint-2 error:
/// the search reads reflector A's positions, the named effect is fitted to all three, and
/// every reflector's held-out error is at the noise (figures per point and in total).
#[test]
fn diagnose_fits_every_reflector() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = rand::rngs::StdRng::seed_from_u64(1807);
    let tools = [
        ("A", [60.0, 0.0, 110.0]),
        ("B", [-30.0, 52.0, 120.0]),
        ("C", [-30.0, -52.0, 95.0]),
    ];
    let (nominal_path, _) = load(
        &robot_text(&[[0.0; 4]; 6], &tools, [0.0; 3], ""),
        dir.path(),
        "robot.toml",
    );
    let dev = deviations(&mut rng);
    let moved: Vec<(&str, [f64; 3])> = tools
        .iter()
        .map(|(n, p)| (*n, p.map(|c| c + rng.random_range(-0.3..0.3))))
        .collect();
    let (_, truth) = load(
        &robot_text(&dev, &moved, [0.0; 3], HIDDEN),
        dir.path(),
        "truth.toml",
    );
    let sp = 0.01;
    let np = Normal::new(0.0, sp).unwrap();
    let mut csv = String::from("q1,q2,q3,q4,q5,q6,x_A,y_A,z_A,x_B,y_B,z_B,x_C,y_C,z_C\n");
    let mut fk = ForwardKinematics::<f64, 6>::new();
    for _ in 0..400 {
        let q: [f64; 6] = std::array::from_fn(|_| rng.random_range(-170.0f64..170.0));
        let qr = q.map(f64::to_radians);
        csv += &q.map(|v| format!("{v:.6}")).join(",");
        let missing = rng.random_range(0..6usize); // 0..3: that reflector is hidden
        for k in 0..3 {
            if missing == k {
                csv += ",,,";
                continue;
            }
            let p = fk.compute_point(&truth, &qr, k).unwrap()
                + Vector3::from_fn(|_, _| np.sample(&mut rng));
            csv += &format!(",{:.6},{:.6},{:.6}", p.x, p.y, p.z);
        }
        csv += "\n";
    }
    let model = dir.path().join("model.toml");
    let j = diagnose_names_the_hidden_error(
        &nominal_path,
        &write(dir.path(), "data.csv", &csv),
        &model,
    );
    let o = &j["observations"];
    assert_eq!(o["points"], 3);
    assert_eq!(j["figures_include_orientations"], false);
    // Poses, not observations: 100 held out (the count read 3 per pose), and the most affected
    // poses are among the 300 searched (they were observation numbers up to ~900, three of one
    // pose side by side).
    assert_eq!(j["holdout"]["poses"], 100);
    assert_eq!(j["poses"], 300);
    for f in j["found"].as_array().unwrap() {
        let listed: Vec<u64> = f["explanation"]["most_affected_poses"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p.as_u64().unwrap())
            .collect();
        let mut distinct = listed.clone();
        distinct.sort_unstable();
        distinct.dedup();
        assert!(
            !listed.is_empty()
                && distinct.len() == listed.len()
                && listed.iter().all(|&p| (1..=300).contains(&p)),
            "{listed:?}"
        );
    }
    let floor = 3f64.sqrt() * sp;
    let total = o["after"]["validation_rms_mm"].as_f64().unwrap();
    eprintln!("total held-out {total:.4} mm (floor {floor:.4})");
    assert!(total < 1.25 * floor, "total {total}");
    for name in ["A", "B", "C"] {
        let p = &o["per_point"][name];
        let (b, a) = (
            p["before"]["validation_rms_mm"].as_f64().unwrap(),
            p["after"]["validation_rms_mm"].as_f64().unwrap(),
        );
        eprintln!("reflector {name}: held out {b:.4} → {a:.4} mm");
        assert!(a < 1.3 * floor && b > 3.0 * a, "{name}: {b} → {a}");
    }
    let names: Vec<String> = RobotFile::load(&model)
        .unwrap()
        .tools
        .iter()
        .map(|t| t.name.clone())
        .collect();
    assert_eq!(names, ["A", "B", "C"]);
}

/// The real UR10 series C with the T-Mac's orientation and σ (first 1,000 poses searched, the
/// 1,773 others held out): the joint tables the search names from positions, fitted to the
/// orientations too, predict held-out positions as well as the search's model and the
/// held-out orientations better than the geometry.
#[test]
fn ur10_six_d_diagnose_predicts_orientations_better() {
    let d = crate::common::ur10_dir();
    let out = run_on(
        "diagnose",
        &d.join("robot.toml"),
        &d.join("ur10_random_poses_6d.csv"),
        &["--holdout", "1773", "--json"],
    );
    assert!(out.status.success(), "{}", stderr(&out));
    let j = json_of(&out);
    assert!(!j["found"].as_array().unwrap().is_empty());
    let o = &j["observations"];
    let v = |side: &str, k: &str| o[side][k].as_f64().unwrap();
    let search_mm = j["holdout"]["final_rms_mm"].as_f64().unwrap();
    eprintln!(
        "held out: geometry {:.4} mm {:.4}°, extended {:.4} mm {:.4}° (the search's model {search_mm:.4} mm), χ²/dof {}",
        v("before", "validation_rms_mm"),
        v("before", "validation_rms_deg"),
        v("after", "validation_rms_mm"),
        v("after", "validation_rms_deg"),
        o["chi2_per_dof"]
    );
    assert!(v("after", "validation_rms_mm") <= 1.02 * search_mm);
    assert!(v("after", "validation_rms_deg") < 0.75 * v("before", "validation_rms_deg"));
    assert!(v("after", "validation_rms_mm") < 0.3 * v("before", "validation_rms_mm"));
}
