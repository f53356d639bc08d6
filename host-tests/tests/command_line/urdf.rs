//! URDF import and export against an independent URDF forward kinematics: the files
//! are read with `urdf-rs` (not the command line's `roxmltree` reader) and each joint is
//! composed as origin·Rot(axis, q) with its own matrices.
//!
//! `cargo test -p kinecal-host --test command_line urdf:: -- --nocapture` prints the worst differences.

use crate::common::{kinecal, kinecal_ok, s, stderr};
use kinecal::ForwardKinematics;
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::with_joints;
use nalgebra::{Matrix3, Matrix4, Rotation3, Unit, Vector3, Vector4};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::{Path, PathBuf};

/// The five public URDFs: (folder, file, import options).
const URDFS: [(&str, &str, &[&str]); 5] = [
    ("abb_irb140", "irb140.urdf", &[]),
    ("kuka_kr16_2", "kr16_2.urdf", &[]),
    ("kuka_lbr_iiwa_14", "lbr_iiwa_14_r820.urdf", &[]),
    ("franka_panda", "panda_arm.urdf", &[]),
    ("ur10", "ur10_robot.urdf", &["--tip-link", "tool0"]),
];

fn urdf_path(dir: &str, file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("data/urdf")
        .join(dir)
        .join(file)
}

// ---- the independent reference ----------------------------------------------------------

fn rot_x(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(1.0, 0.0, 0.0, 0.0, c, -s, 0.0, s, c)
}
fn rot_y(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, 0.0, s, 0.0, 1.0, 0.0, -s, 0.0, c)
}
fn rot_z(a: f64) -> Matrix3<f64> {
    let (s, c) = a.sin_cos();
    Matrix3::new(c, -s, 0.0, s, c, 0.0, 0.0, 0.0, 1.0)
}

/// A homogeneous transform in millimetres from a rotation and a translation in metres.
fn homogeneous(r: Matrix3<f64>, xyz_m: [f64; 3]) -> Matrix4<f64> {
    let mut t = Matrix4::identity();
    t.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    t[(0, 3)] = xyz_m[0] * 1000.0;
    t[(1, 3)] = xyz_m[1] * 1000.0;
    t[(2, 3)] = xyz_m[2] * 1000.0;
    t
}

/// URDF `<origin>`: Rz(yaw)·Ry(pitch)·Rx(roll), then the translation.
fn origin(p: &urdf_rs::Pose) -> Matrix4<f64> {
    let r = p.rpy.0;
    homogeneous(rot_z(r[2]) * rot_y(r[1]) * rot_x(r[0]), p.xyz.0)
}

/// The reference chain from `base` to `tip`: joints base first.
struct RefChain {
    joints: Vec<urdf_rs::Joint>,
}

impl RefChain {
    fn new(text: &str, base: &str, tip: &str) -> RefChain {
        let robot = urdf_rs::read_from_string(text).expect("urdf-rs reads the file");
        let mut joints = Vec::new();
        let mut link = tip.to_string();
        while link != base {
            let j = robot
                .joints
                .iter()
                .find(|j| j.child.link == link)
                .unwrap_or_else(|| panic!("no joint has child {link}"))
                .clone();
            link = j.parent.link.clone();
            joints.push(j);
        }
        joints.reverse();
        RefChain { joints }
    }

    fn movable(&self) -> Vec<&urdf_rs::Joint> {
        self.joints
            .iter()
            .filter(|j| !matches!(j.joint_type, urdf_rs::JointType::Fixed))
            .collect()
    }

    /// Pose of the tip link in the base link (mm) at joint angles `q` (radians, movable joints
    /// in chain order).
    fn pose(&self, q: &[f64]) -> Matrix4<f64> {
        let mut t = Matrix4::identity();
        let mut k = 0;
        for j in &self.joints {
            t *= origin(&j.origin);
            if !matches!(j.joint_type, urdf_rs::JointType::Fixed) {
                let axis = Unit::new_normalize(Vector3::from(j.axis.xyz.0));
                let r = Rotation3::from_axis_angle(&axis, q[k]).into_inner();
                t *= homogeneous(r, [0.0; 3]);
                k += 1;
            }
        }
        t
    }

    /// Joint limits (radians); continuous joints ±π.
    fn limits(&self) -> Vec<[f64; 2]> {
        self.movable()
            .iter()
            .map(|j| match j.joint_type {
                urdf_rs::JointType::Revolute => [j.limit.lower, j.limit.upper],
                _ => [-std::f64::consts::PI, std::f64::consts::PI],
            })
            .collect()
    }
}

fn point_of(t: &Matrix4<f64>, p_mm: [f64; 3]) -> Vector3<f64> {
    (t * Vector4::new(p_mm[0], p_mm[1], p_mm[2], 1.0)).xyz()
}

fn rotation_of(t: &Matrix4<f64>) -> Matrix3<f64> {
    t.fixed_view::<3, 3>(0, 0).into_owned()
}

/// The angle between two rotations (radians).
fn angle_between(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let m = a.transpose() * b;
    let c = ((m.trace() - 1.0) / 2.0).clamp(-1.0, 1.0);
    let s = Vector3::new(
        m[(2, 1)] - m[(1, 2)],
        m[(0, 2)] - m[(2, 0)],
        m[(1, 0)] - m[(0, 1)],
    )
    .norm()
        / 2.0;
    s.atan2(c)
}

// ---- the library's side ------------------------------------------------------------------

/// The library's (f64) point and frame orientation (flange · tool rpy) at `q` (radians).
fn library_pose(file: &RobotFile, q: &[f64]) -> (Vector3<f64>, Matrix3<f64>) {
    let r: anyhow::Result<(Vector3<f64>, Matrix3<f64>)> = with_joints!(file.joints.len(), N => {
        let robot = file.to_robot::<N>().unwrap();
        let mut qa = [0.0; N];
        qa.copy_from_slice(q);
        let mut fk = ForwardKinematics::<f64, N>::new();
        let p = fk.compute(&robot, &qa);
        // The robot carries `[tool] rpy_deg` as its tool axes.
        let frame = fk.tool_pose(&robot);
        Ok((p, frame.rotation()))
    });
    r.unwrap()
}

fn random_q(rng: &mut Xoshiro256PlusPlus, limits: &[[f64; 2]]) -> Vec<f64> {
    limits
        .iter()
        .map(|[lo, hi]| rng.random_range(*lo..=*hi))
        .collect()
}

/// `kinecal import --urdf F --with-base --out DIR/robot.toml EXTRA…` (the URDF's base link
/// is the frame these tests measure in), read back.
fn import(dir: &Path, urdf: &Path, extra: &[&str]) -> (PathBuf, RobotFile) {
    let out = dir.join("robot.toml");
    let mut args = vec!["import", "--urdf", s(urdf), "--with-base", "--out", s(&out)];
    args.extend_from_slice(extra);
    kinecal_ok(&args);
    let f = RobotFile::load(&out).unwrap();
    (out, f)
}

/// `kinecal export --model MODEL --urdf URDF --out OUT EXTRA…`, which must succeed.
fn export_urdf(model: &Path, urdf: &Path, out: &Path, extra: &[&str]) {
    let mut args = vec![
        "export",
        "--model",
        s(model),
        "--urdf",
        s(urdf),
        "--out",
        s(out),
    ];
    args.extend_from_slice(extra);
    kinecal_ok(&args);
}

/// The chain's end links the import chose (from its JSON report).
fn chain_links(urdf: &Path, dir: &Path, extra: &[&str]) -> (String, String) {
    let out = dir.join("links.toml");
    let mut args = vec!["import", "--urdf", s(urdf), "--out", s(&out), "--json"];
    args.extend_from_slice(extra);
    let o = kinecal_ok(&args);
    let v = crate::common::json_of(&o);
    (
        v["base_link"].as_str().unwrap().to_string(),
        v["tip_link"].as_str().unwrap().to_string(),
    )
}

#[test]
fn imported_robots_reproduce_the_urdf_forward_kinematics() {
    let tool = [12.5, -7.25, 40.0];
    for (folder, file, extra) in URDFS {
        let dir = tempfile::tempdir().unwrap();
        let path = urdf_path(folder, file);
        let text = std::fs::read_to_string(&path).unwrap();
        let (base, tip) = chain_links(&path, dir.path(), extra);
        let mut args = vec!["--tool-xyz-mm", "12.5,-7.25,40"];
        args.extend_from_slice(extra);
        let (_, robot) = import(dir.path(), &path, &args);
        let chain = RefChain::new(&text, &base, &tip);
        assert_eq!(chain.movable().len(), robot.joints.len(), "{file}");
        // The URDF's limits carried over (degrees).
        for (j, l) in robot.joints.iter().zip(chain.limits()) {
            if let Some([lo, hi]) = j.limits_deg {
                assert!((lo - l[0].to_degrees()).abs() < 1e-6, "{file}");
                assert!((hi - l[1].to_degrees()).abs() < 1e-6, "{file}");
            }
        }
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(17);
        let (mut worst_mm, mut worst_rad) = (0.0f64, 0.0f64);
        for _ in 0..300 {
            let q = random_q(&mut rng, &chain.limits());
            let t = chain.pose(&q);
            let (p, r) = library_pose(&robot, &q);
            worst_mm = worst_mm.max((p - point_of(&t, tool)).norm());
            worst_rad = worst_rad.max(angle_between(&r, &rotation_of(&t)));
        }
        eprintln!(
            "{file}: {} joints, 300 poses, worst point difference {worst_mm:.3e} mm, worst \
             orientation difference {worst_rad:.3e} rad",
            robot.joints.len()
        );
        assert!(worst_mm < 1e-6, "{file}: {worst_mm} mm");
        assert!(worst_rad < 1e-8, "{file}: {worst_rad} rad");
    }
}

/// The nominal-based model of `file` with `base` as base (the URDF's view of the robot).
fn with_base(model: &RobotFile, nominal: &RobotFile) -> RobotFile {
    let mut m = model.clone();
    m.base = nominal.base.clone();
    m
}

#[test]
fn calibrated_model_exported_to_urdf_reproduces_its_forward_kinematics() {
    for (folder, file, extra) in [URDFS[1], URDFS[2], URDFS[4]] {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let path = urdf_path(folder, file);
        let (robot_path, nominal) = import(d, &path, extra);
        let data = d.join("meas.csv");
        let truth = d.join("truth.toml");
        crate::common::simulate(
            &robot_path,
            Some(300),
            Some(0.005),
            Some(3),
            &["--geom-errors", "--truth", s(&truth)],
            &data,
        );
        let model_path = d.join("model.toml");
        kinecal_ok(&[
            "identify",
            "--robot",
            s(&robot_path),
            "--data",
            s(&data),
            "--out",
            s(&model_path),
        ]);
        let model = RobotFile::load(&model_path).unwrap();
        // [tool] rpy_deg is carried through simulate --truth and identify --out.
        assert!(nominal.tool.rpy_deg.is_some());
        assert_eq!(model.tool.rpy_deg, nominal.tool.rpy_deg, "{file}");
        assert_eq!(
            RobotFile::load(&truth).unwrap().tool.rpy_deg,
            nominal.tool.rpy_deg
        );
        let moved = model
            .joints
            .iter()
            .zip(&nominal.joints)
            .any(|(a, b)| (a.a_mm - b.a_mm).abs() > 0.01 || (a.d_mm - b.d_mm).abs() > 0.01);
        assert!(
            moved,
            "{file}: the identified model differs from the nominal one"
        );
        // A Hayati tilt on joint 3 as well (beta of a nominally parallel pair): the exported
        // origins must carry it too.
        let mut model = model;
        model.joints[2].beta_deg = Some(0.03);
        let model_path = d.join("model_tilted.toml");
        model.save(&model_path).unwrap();
        let exported = d.join("exported.urdf");
        export_urdf(&model_path, &path, &exported, extra);
        let text = std::fs::read_to_string(&exported).unwrap();
        let (base, _) = chain_links(&path, d, extra);
        let chain = RefChain::new(&text, &base, "kinecal_tool");
        let in_base = with_base(&model, &nominal);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
        let mut worst = 0.0f64;
        let mut worst_rad = 0.0f64;
        for _ in 0..300 {
            let q = random_q(&mut rng, &chain.limits());
            let t = chain.pose(&q);
            let (p, r) = library_pose(&in_base, &q);
            worst = worst.max((p - point_of(&t, [0.0; 3])).norm());
            worst_rad = worst_rad.max(angle_between(&r, &rotation_of(&t)));
        }
        eprintln!(
            "{file}: exported calibrated URDF vs identified model: worst {worst:.3e} mm, \
             {worst_rad:.3e} rad"
        );
        assert!(worst < 1e-6, "{file}: {worst} mm");
        assert!(worst_rad < 1e-8, "{file}: {worst_rad} rad");
    }
}

/// Runs `kinecal import` on `text` and returns the stderr of the refusal (exit status 2).
fn refused(text: &str, extra: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let f = crate::common::write(dir.path(), "robot.urdf", text);
    let out = dir.path().join("r.toml");
    let mut args = vec!["import", "--urdf", s(&f), "--out", s(&out)];
    args.extend_from_slice(extra);
    let o = kinecal(&args);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    let e = stderr(&o);
    assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
    assert!(!out.exists());
    e
}

#[test]
fn refusals_name_the_joint_or_link() {
    let kr16 = std::fs::read_to_string(urdf_path("kuka_kr16_2", "kr16_2.urdf")).unwrap();
    let e = refused(
        &kr16.replace(
            r#"<joint name="joint_a3" type="revolute">"#,
            r#"<joint name="joint_a3" type="prismatic">"#,
        ),
        &[],
    );
    assert!(e.contains("joint_a3") && e.contains("prismatic"), "{e}");
    let e = refused(
        &kr16.replace(
            r#"<joint name="joint_a3" type="revolute">"#,
            r#"<joint name="joint_a3" type="revolute"><mimic joint="joint_a2"/>"#,
        ),
        &[],
    );
    assert!(e.contains("joint_a3") && e.contains("mimic"), "{e}");
    let e = refused(
        &kr16.replace(
            "</robot>",
            r#"<link name="extra"/><joint name="extra_joint" type="revolute"><parent link="link_3"/><child link="extra"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="0" velocity="1"/></joint></robot>"#,
        ),
        &[],
    );
    assert!(
        e.contains("extra_joint") && e.contains("link_3") && e.contains("--tip-link"),
        "{e}"
    );
    let e = refused(
        &kr16.replace(
            "</robot>",
            r#"<xacro:property name="p" value="1"/></robot>"#,
        ),
        &[],
    );
    assert!(e.contains("expand it first: xacro"), "{e}");
    // Without the namespace declared (an XML error), still named a xacro file.
    let e = refused(
        r#"<robot name="r"><xacro:include filename="arm.xacro"/></robot>"#,
        &[],
    );
    assert!(e.contains("expand it first: xacro"), "{e}");
    let ur10 = std::fs::read_to_string(urdf_path("ur10", "ur10_robot.urdf")).unwrap();
    let e = refused(&ur10, &[]);
    assert!(
        e.contains("ee_link") && e.contains("tool0") && e.contains("--tip-link"),
        "{e}"
    );
    let e = refused(&kr16, &["--tip-link", "no_such_link"]);
    assert!(e.contains("no_such_link"), "{e}");
    let e = refused(&kr16, &["--base-link", "link_4", "--tip-link", "link_2"]);
    assert!(e.contains("link_2") && e.contains("link_4"), "{e}");
}

/// The text without the `xyz`/`rpy` values of `<origin>` lines and without the appended tool
/// block: what export must leave byte for byte.
fn untouched_part(text: &str) -> (Vec<String>, usize) {
    let kept = match text.find("  <!-- kinecal: the calibrated tool point") {
        Some(cut) => format!(
            "{}{}",
            &text[..cut],
            &text[text.rfind("</robot>").unwrap()..]
        ),
        None => text.to_string(),
    };
    let mut origins = 0;
    let lines = kept
        .lines()
        .map(|l| {
            if l.trim_start().starts_with("<origin ") {
                origins += 1;
                let mut out = String::new();
                let mut inside = false;
                for c in l.chars() {
                    if c == '"' {
                        inside = !inside;
                        out.push(c);
                    } else if !inside {
                        out.push(c);
                    }
                }
                out
            } else {
                l.to_string()
            }
        })
        .collect();
    (lines, origins)
}

#[test]
fn export_leaves_everything_else_untouched() {
    for (folder, file, extra) in URDFS {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        let path = urdf_path(folder, file);
        let (robot_path, mut model) = import(d, &path, extra);
        let original = std::fs::read_to_string(&path).unwrap();
        // A changed model: every length and angle moved a little, a tool point added.
        for j in &mut model.joints {
            j.a_mm += 0.3;
            j.d_mm -= 0.2;
            j.theta_deg += 0.05;
            j.alpha_deg -= 0.04;
        }
        model.tool.xyz_mm[2] += 5.0;
        let model_path = d.join("model.toml");
        model.save(&model_path).unwrap();
        let exported = d.join("out.urdf");
        export_urdf(&model_path, &path, &exported, extra);
        let text = std::fs::read_to_string(&exported).unwrap();
        assert!(text.contains(r#"<link name="kinecal_tool"/>"#));
        // Exporting into an exported file again would give two kinecal_tool links: refused.
        let (_, tip) = chain_links(&path, d, extra);
        let again = d.join("again.urdf");
        let o = kinecal(&[
            "export",
            "--model",
            s(&model_path),
            "--urdf",
            s(&exported),
            "--tip-link",
            &tip,
            "--out",
            s(&again),
        ]);
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        assert!(
            stderr(&o).contains("already has a link 'kinecal_tool'"),
            "{}",
            stderr(&o)
        );
        let (a, n_a) = untouched_part(&original);
        let (b, n_b) = untouched_part(&text);
        assert_eq!(n_a, n_b, "{file}");
        let first = a.iter().zip(&b).position(|(x, y)| x != y);
        if let Some(k) = first {
            panic!("{file}: line {} changed: {:?} -> {:?}", k + 1, a[k], b[k]);
        }
        assert_eq!(
            a.len(),
            b.len(),
            "{file}: only origin values and the tool block may change"
        );
        // Lines that changed: only origins, one per chain joint at most.
        let cut = text
            .find("  <!-- kinecal: the calibrated tool point")
            .unwrap();
        let without_tool = format!(
            "{}{}",
            &text[..cut],
            &text[text.rfind("</robot>").unwrap()..]
        );
        assert_eq!(original.lines().count(), without_tool.lines().count());
        let changed = original
            .lines()
            .zip(without_tool.lines())
            .filter(|(x, y)| x != y)
            .count();
        assert!(
            changed <= model.joints.len(),
            "{file}: {changed} lines changed"
        );
        // The nominal model exported gives back the original origins' numbers.
        let same = d.join("same.urdf");
        let mut args = vec![
            "export",
            "--model",
            s(&robot_path),
            "--urdf",
            s(&path),
            "--out",
            s(&same),
        ];
        args.extend_from_slice(extra);
        kinecal_ok(&args);
        let ours = urdf_rs::read_from_string(&std::fs::read_to_string(&same).unwrap()).unwrap();
        let theirs = urdf_rs::read_from_string(&original).unwrap();
        for j in &theirs.joints {
            let k = ours.joints.iter().find(|k| k.name == j.name).unwrap();
            let dt = (origin(&j.origin) - origin(&k.origin)).abs().max();
            assert!(dt < 1e-9, "{file}: joint {} origin moved by {dt}", j.name);
        }
    }
}

fn csv_rows(text: &str) -> Vec<Vec<String>> {
    text.lines()
        .skip(1)
        .map(|l| l.split(',').map(str::to_string).collect())
        .collect()
}

#[test]
fn dh_table_csv_and_json_agree_with_the_files() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let path = urdf_path("kuka_kr16_2", "kr16_2.urdf");
    let (robot_path, nominal) = import(d, &path, &[]);
    let mut model = nominal.clone();
    model.joints[1].a_mm += 0.25;
    model.joints[2].theta_deg -= 0.01;
    model.tool.xyz_mm[0] += 1.5;
    model.base.as_mut().unwrap().xyz_mm[1] = 2000.0;
    let model_path = d.join("model.toml");
    model.save(&model_path).unwrap();
    let csv = d.join("t.csv");
    kinecal_ok(&[
        "export",
        "--model",
        s(&model_path),
        "--format",
        "dh-table",
        "--robot",
        s(&robot_path),
        "--out",
        s(&csv),
    ]);
    let text = std::fs::read_to_string(&csv).unwrap();
    assert!(text.starts_with("parameter,unit,nominal,calibrated,delta\n"));
    let rows = csv_rows(&text);
    assert_eq!(rows.len(), 6 + 5 * 6 + 3);
    let num = |r: &Vec<String>, k: usize| r[k].parse::<f64>().unwrap();
    let find = |name: &str| rows.iter().find(|r| r[0] == name).unwrap().clone();
    let r = find("joint2_a_mm");
    assert_eq!(
        (num(&r, 2), num(&r, 3)),
        (nominal.joints[1].a_mm, model.joints[1].a_mm)
    );
    assert!((num(&r, 4) - 0.25).abs() < 1e-12);
    let r = find("joint3_theta_deg");
    assert!((num(&r, 4) + 0.01).abs() < 1e-12);
    let r = find("tool_x_mm");
    assert!((num(&r, 4) - 1.5).abs() < 1e-12);
    let r = find("base_y_mm");
    assert_eq!(num(&r, 3), 2000.0);
    for r in &rows {
        assert!((num(r, 3) - num(r, 2) - num(r, 4)).abs() < 1e-9, "{r:?}");
    }
    // JSON, nominal from the URDF itself: the same numbers.
    let json = d.join("t.json");
    kinecal_ok(&[
        "export",
        "--model",
        s(&model_path),
        "--format",
        "dh-table",
        "--urdf",
        s(&path),
        "--out",
        s(&json),
    ]);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let arr = v.as_array().unwrap();
    assert_eq!(arr.len(), rows.len());
    for (o, r) in arr.iter().zip(&rows) {
        assert_eq!(o["parameter"].as_str().unwrap(), r[0]);
        assert_eq!(o["unit"].as_str().unwrap(), r[1]);
        for (k, key) in [(2, "nominal"), (3, "calibrated"), (4, "delta")] {
            assert!(
                (o[key].as_f64().unwrap() - num(r, k)).abs() < 1e-9,
                "{key} {r:?}"
            );
        }
    }
    // No nominal: empty columns and one warning, exit 0.
    let bare = d.join("bare.csv");
    let o = kinecal_ok(&[
        "export",
        "--model",
        s(&model_path),
        "--format",
        "dh-table",
        "--out",
        s(&bare),
    ]);
    assert!(stderr(&o).contains("no nominal given: pass --robot R.toml"));
    let rows = csv_rows(&std::fs::read_to_string(&bare).unwrap());
    assert!(rows
        .iter()
        .all(|r| r[2].is_empty() && r[4].is_empty() && !r[3].is_empty()));
}

#[test]
fn export_warns_about_what_a_urdf_cannot_hold() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let path = urdf_path("kuka_kr16_2", "kr16_2.urdf");
    let (_, mut model) = import(d, &path, &[]);
    model
        .effects
        .push(kinecal_cli::formats::robot_file::EffectSpec {
            kind: "joint-compliance".into(),
            joint: 2,
            values: vec![1e-4],
            order: None,
            step_deg: None,
            start_deg: None,
            reference_c: None,
        });
    let model_path = d.join("model.toml");
    model.save(&model_path).unwrap();
    let out = d.join("out.urdf");
    let o = kinecal_ok(&[
        "export",
        "--model",
        s(&model_path),
        "--urdf",
        s(&path),
        "--out",
        s(&out),
        "--json",
    ]);
    assert!(
        stderr(&o).contains("joint-compliance on joint 2"),
        "{}",
        stderr(&o)
    );
    let v = crate::common::json_of(&o);
    assert_eq!(v["dropped"].as_array().unwrap().len(), 1);
}

/// A random URDF: `n` revolute or continuous joints with random origins (xyz, rpy) and random
/// non-unit axes (skew in general), a fixed joint with a random origin before the first,
/// between some and after the last joint; `parallel`: every axis y and every rpy zero.
fn random_urdf(rng: &mut Xoshiro256PlusPlus, n: usize, parallel: bool) -> String {
    let mut s = String::from("<?xml version=\"1.0\"?>\n<robot name=\"random\">\n");
    let r3 = |rng: &mut Xoshiro256PlusPlus, a: f64| -> String {
        let v: Vec<String> = (0..3)
            .map(|_| format!("{}", rng.random_range(-a..a)))
            .collect();
        v.join(" ")
    };
    s.push_str("  <link name=\"l0\"/>\n");
    let mut link = 0;
    let mut add = |s: &mut String, rng: &mut Xoshiro256PlusPlus, kind: &str, name: String| {
        let (xyz, mut rpy) = (r3(rng, 0.6), r3(rng, 3.0));
        if parallel {
            rpy = "0 0 0".into();
        }
        let axis = if parallel && kind != "fixed" {
            "0 1 0".to_string()
        } else {
            r3(rng, 2.0)
        };
        let limit = if kind == "revolute" {
            "<limit lower=\"-2.5\" upper=\"2\" effort=\"1\" velocity=\"1\"/>"
        } else {
            ""
        };
        s.push_str(&format!(
            "  <link name=\"l{}\"/>\n  <joint name=\"{name}\" type=\"{kind}\"><parent link=\"l{}\"/><child link=\"l{}\"/><origin xyz=\"{xyz}\" rpy=\"{rpy}\"/><axis xyz=\"{axis}\"/>{limit}</joint>\n",
            link + 1,
            link,
            link + 1
        ));
        link += 1;
    };
    add(&mut s, rng, "fixed", "mount".into());
    for i in 0..n {
        let kind = if i == 3 { "continuous" } else { "revolute" };
        add(&mut s, rng, kind, format!("j{}", i + 1));
        if i % 2 == 1 {
            add(&mut s, rng, "fixed", format!("f{}", i + 1));
        }
    }
    add(&mut s, rng, "fixed", "flange".into());
    s.push_str("</robot>\n");
    s
}

#[test]
fn random_geometry_with_fixed_joints_and_odd_axes_is_imported_exactly() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2024);
    let mut worst_all = 0.0f64;
    for case in 0..12 {
        let n = 6 + case % 2;
        // In a third of the cases every axis is y and every rpy zero: all axes parallel (a
        // planar arm), the parallel-axes branch of the conversion.
        let text = random_urdf(&mut rng, n, case % 3 == 2);
        let dir = tempfile::tempdir().unwrap();
        let path = crate::common::write(dir.path(), "r.urdf", &text);
        let (base, tip) = chain_links(&path, dir.path(), &[]);
        let (_, robot) = import(dir.path(), &path, &["--tool-xyz-mm", "3,-4,50"]);
        assert_eq!(robot.joints.len(), n);
        assert!(
            robot.joints[3].limits_deg.is_none(),
            "continuous: no limits"
        );
        let chain = RefChain::new(&text, &base, &tip);
        let mut worst = 0.0f64;
        let mut worst_rad = 0.0f64;
        for _ in 0..200 {
            let q = random_q(&mut rng, &chain.limits());
            let t = chain.pose(&q);
            let (p, r) = library_pose(&robot, &q);
            worst = worst.max((p - point_of(&t, [3.0, -4.0, 50.0])).norm());
            worst_rad = worst_rad.max(angle_between(&r, &rotation_of(&t)));
        }
        assert!(worst < 1e-6, "case {case}: {worst} mm\n{text}");
        assert!(worst_rad < 1e-8, "case {case}: {worst_rad} rad\n{text}");
        worst_all = worst_all.max(worst);
        // And back: the nominal exported gives the same origins (to 1e-9 mm / 1e-12).
        let (robot_path, _) = import(dir.path(), &path, &[]);
        let same = dir.path().join("same.urdf");
        kinecal_ok(&[
            "export",
            "--model",
            s(&robot_path),
            "--urdf",
            s(&path),
            "--out",
            s(&same),
        ]);
        let ours = urdf_rs::read_from_string(&std::fs::read_to_string(&same).unwrap()).unwrap();
        let theirs = urdf_rs::read_from_string(&text).unwrap();
        for j in &theirs.joints {
            let k = ours.joints.iter().find(|k| k.name == j.name).unwrap();
            let dt = (origin(&j.origin) - origin(&k.origin)).abs().max();
            assert!(
                dt < 1e-8,
                "case {case}: joint {} origin moved by {dt}",
                j.name
            );
        }
    }
    eprintln!("random URDFs: worst point difference {worst_all:.3e} mm");
}

/// A model of another robot (or of the same one in another MDH convention) cannot be spliced
/// into a URDF or tabulated against a nominal: its rows are far from the import's. Refused
/// (exit 2) naming the row, not written as a confident URDF.
#[test]
fn export_refuses_a_model_of_another_robot() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let kr16 = urdf_path("kuka_kr16_2", "kr16_2.urdf");
    let abb = urdf_path("abb_irb140", "irb140.urdf");
    let (kr16_robot, _) = import(d, &kr16, &[]);
    let kr16_model = d.join("kr16.toml");
    std::fs::copy(&kr16_robot, &kr16_model).unwrap();
    let out = d.join("out.urdf");
    let o = kinecal(&[
        "export",
        "--model",
        s(&kr16_model),
        "--urdf",
        s(&abb),
        "--out",
        s(&out),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("not a calibration of") && e.contains("in the model"),
        "{e}"
    );
    assert!(!out.exists());
    // The same against a nominal robot file for the table.
    let abb_robot = d.join("abb.toml");
    kinecal_ok(&["import", "--urdf", s(&abb), "--out", s(&abb_robot)]);
    let table = d.join("t.csv");
    let o = kinecal(&[
        "export",
        "--model",
        s(&kr16_model),
        "--format",
        "dh-table",
        "--robot",
        s(&abb_robot),
        "--out",
        s(&table),
    ]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(!table.exists());
    // Its own URDF, with a calibration's few tenths of a millimetre: accepted.
    kinecal_ok(&[
        "export",
        "--model",
        s(&kr16_model),
        "--urdf",
        s(&kr16),
        "--out",
        s(&out),
    ]);
}
