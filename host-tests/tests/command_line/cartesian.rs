//! `kinecal compensate --robot NOMINAL --cartesian`: the targets to send to a controller that
//! keeps its nominal kinematics. Fed to the nominal robot's inverse kinematics (the library's
//! compensation on the nominal robot placed at the model's base, run to convergence), each sent
//! target brings the calibrated robot (geometry, effects, coupling) to the original target.

use crate::common::{
    json_of, kinecal, kinecal_ok, s, stderr, write, ER20_PLACED, ER20_TILTED_PLACED,
};
use kinecal::compensate::{compensate, Config, Target};
use kinecal::{ForwardKinematics, Frame};
use kinecal_cli::formats::robot_file::{CouplingSpec, RobotFile};
use kinecal_cli::formats::rotation_order::RotationOrder;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// The calibrated model: the tilted arm with a joint table, a cyclic term and a compliance.
const EFFECTS: &str = r#"
[[effects]]
kind = "joint-table"
joint = 2
step_deg = 10.0
start_deg = -170.0
values = [0.0004, -0.0003, 0.0005, 0.0002, -0.0004, 0.0001, 0.0003, -0.0002, 0.0004, 0.0]
[[effects]]
kind = "joint-cyclic"
joint = 4
values = [0.0006, -0.0003]
[[effects]]
kind = "joint-compliance"
joint = 1
values = [0.0008]
"#;

/// Bent-arm readings (rad), away from the wrist and stretched singularities.
const RANGES: [(f64, f64); 6] = [
    (-1.5, 1.5),
    (-1.2, -0.2),
    (0.3, 1.2),
    (-1.5, 1.5),
    (0.5, 1.4),
    (-1.5, 1.5),
];

fn cells(line: &str) -> Vec<f64> {
    line.split(',')
        .map(|c| c.parse::<f64>().unwrap_or(f64::NAN))
        .collect()
}

#[test]
fn cartesian_targets_through_the_nominal_ik_reach_the_targets_on_the_calibrated_robot() {
    let dir = tempfile::tempdir().unwrap();
    let model_text = format!("{ER20_TILTED_PLACED}{EFFECTS}");
    let model_path = write(dir.path(), "model.toml", &model_text);
    // The controller's nominal model: no tilt, no effects, and it does not know the base.
    let mut nominal_file = RobotFile::parse(ER20_PLACED, "n").unwrap();
    nominal_file.base = None;
    let nominal_path = dir.path().join("nominal.toml");
    nominal_file.save(&nominal_path).unwrap();

    let model = RobotFile::parse(&model_text, "m")
        .unwrap()
        .to_robot::<6>()
        .unwrap();
    assert_eq!(model.effects().len(), 3);
    // The nominal robot where the controller's robot stands (the model's base).
    let mut placed = nominal_file.to_robot::<6>().unwrap();
    placed.set_base(*model.base()).unwrap();

    let mut rng = Xoshiro256PlusPlus::seed_from_u64(41);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let (mut points, mut poses) = (String::new(), String::new());
    let head = "q1,q2,q3,q4,q5,q6,x,y,z";
    points.push_str(&format!("{head}\n"));
    poses.push_str(&format!("{head},rx,ry,rz\n"));
    let mut goals = Vec::new();
    let mut skipped = 0;
    while goals.len() < 40 {
        let qt: [f64; 6] = std::array::from_fn(|j| rng.random_range(RANGES[j].0..RANGES[j].1));
        // Poses where the model's compensation or the nominal IK is singular are no test of
        // the route: both robots' poses at the sampled readings must solve well-conditioned.
        fk.compute(&placed, &qt);
        let own = Target::Pose(fk.tool_pose(&placed));
        fk.compute(&model, &qt);
        let goal = fk.tool_pose(&model);
        if compensate(&placed, &own, &qt, &Config::default()).is_err()
            || compensate(&model, &Target::Pose(goal), &qt, &Config::default()).is_err()
        {
            skipped += 1;
            assert!(skipped <= 10, "too many singular samples");
            continue;
        }
        let seed: [f64; 6] = std::array::from_fn(|j| qt[j] + rng.random_range(-0.005..0.005));
        let seed_deg: Vec<String> = seed.iter().map(|v| format!("{}", v.to_degrees())).collect();
        let xyz = format!("{},{},{}", goal.o.x, goal.o.y, goal.o.z);
        let rpy = goal.rpy().map(|a| format!("{}", a.to_degrees())).join(",");
        points.push_str(&format!("{},{xyz}\n", seed_deg.join(",")));
        poses.push_str(&format!("{},{xyz},{rpy}\n", seed_deg.join(",")));
        goals.push((seed, goal));
    }
    let cfg = Config::<f64> {
        iterations: 30,
        ..Config::default()
    };
    for (name, text, pose) in [("points", &points, false), ("poses", &poses, true)] {
        let targets = write(dir.path(), &format!("{name}.csv"), text);
        let out = dir.path().join(format!("{name}-sent.csv"));
        let run = kinecal_ok(&[
            "compensate",
            "--model",
            s(&model_path),
            "--targets",
            s(&targets),
            "--out",
            s(&out),
            "--robot",
            s(&nominal_path),
            "--cartesian",
            "--json",
        ]);
        let report = json_of(&run);
        assert_eq!(report["ok"], 40, "{report}");
        let sent = std::fs::read_to_string(&out).unwrap();
        let mut lines = sent.lines();
        let want_head = if pose {
            "x,y,z,rx,ry,rz,status"
        } else {
            "x,y,z,status"
        };
        assert_eq!(lines.next(), Some(want_head));
        let (mut worst, mut worst_rad, mut moved) = (0.0f64, 0.0f64, 0.0f64);
        for ((seed, goal), line) in goals.iter().zip(lines) {
            let v = cells(line);
            assert!(line.ends_with(",ok"), "{line}");
            let p = nalgebra::Vector3::new(v[0], v[1], v[2]);
            moved = moved.max((p - goal.o).norm());
            // The controller: its nominal inverse kinematics of the sent target.
            let target = if pose {
                let rpy = [v[3], v[4], v[5]].map(f64::to_radians);
                Target::Pose(Frame::from_xyz_rpy([p.x, p.y, p.z], rpy))
            } else {
                Target::Point(p)
            };
            let q = compensate(&placed, &target, seed, &cfg)
                .expect("nominal IK of the sent target")
                .q;
            fk.compute(&model, &q);
            let reached = fk.tool_pose(&model);
            worst = worst.max((reached.o - goal.o).norm());
            if pose {
                let e = kinecal::model::frame::orientation_error(&reached, goal).norm();
                worst_rad = worst_rad.max(e);
            }
        }
        println!(
            "--cartesian {name}: sent targets up to {moved:.3} mm from the targets; the calibrated \
             robot at the nominal IK of the sent targets: worst {worst:.2e} mm, {worst_rad:.2e} rad"
        );
        assert!(moved > 0.1, "the corrections are real ({moved} mm)");
        assert!(worst < 0.01, "{name}: {worst} mm");
        assert!(worst_rad < 1e-5, "{name}: {worst_rad} rad");
    }
    let poses = write(dir.path(), "poses.csv", &poses);
    written_back_in_the_map_s_units(dir.path(), &model_path, &nominal_path, &poses);
    misstated_angles_are_refused(dir.path(), &model_path, &poses);
}

/// Pose targets whose `rx`, `ry`, `rz` are in radians, or compose in another order than
/// kinecal's, are refused naming the unit or the order: they gave every row `limited` without a
/// hint, and with a larger `--max-step-deg` commands far from the targets with status `ok`.
fn misstated_angles_are_refused(
    dir: &std::path::Path,
    model: &std::path::Path,
    poses: &std::path::Path,
) {
    let text = std::fs::read_to_string(poses).unwrap();
    let rewrite = |f: &dyn Fn([f64; 3]) -> [f64; 3]| -> String {
        let mut out = format!("{}\n", text.lines().next().unwrap());
        for line in text.lines().skip(1) {
            let v = cells(line);
            let a = f([v[9], v[10], v[11]]);
            let row: Vec<String> = v[..9].iter().chain(&a).map(|x| format!("{x}")).collect();
            out.push_str(&format!("{}\n", row.join(",")));
        }
        out
    };
    let order = RotationOrder::parse("Rx*Ry*Rz").unwrap();
    let cases = [
        (
            "radians.csv",
            rewrite(&|a| a.map(f64::to_radians)),
            "look like radians",
        ),
        (
            "order.csv",
            rewrite(&|a| order.angles_deg(&RotationOrder::KINECAL.matrix(a))),
            "composed as R = Rx*Ry*Rz",
        ),
    ];
    for (name, text, said) in cases {
        let targets = write(dir, name, &text);
        let out = dir.join("refused.csv");
        let run = kinecal(&[
            "compensate",
            "--model",
            s(model),
            "--targets",
            s(&targets),
            "--out",
            s(&out),
        ]);
        assert_eq!(run.status.code(), Some(2), "{name}: {}", stderr(&run));
        assert!(stderr(&run).contains(said), "{name}: {}", stderr(&run));
        assert!(!out.exists(), "{name}: nothing written");
    }
}

/// The rows of `text` (kinecal's layout: degrees, mm, kinecal's angle order) as a vendor
/// writes them: `;`, decimal commas, joints in radians, points in metres, the orientation in
/// degrees composed as Rx·Ry·Rz; and the map that reads them.
fn vendor_poses(text: &str, order: RotationOrder) -> (String, String) {
    let mut out = String::from("J1;J2;J3;J4;J5;J6;X;Y;Z;A;B;C\n");
    for line in text.lines().skip(1) {
        let v = cells(line);
        let rot = RotationOrder::KINECAL.matrix([v[9], v[10], v[11]]);
        let mut row: Vec<f64> = v[..6].iter().map(|d| d.to_radians()).collect();
        row.extend(v[6..9].iter().map(|mm| mm / 1000.0));
        row.extend(order.angles_deg(&rot));
        let cells: Vec<String> = row
            .iter()
            .map(|x| format!("{x}").replace('.', ","))
            .collect();
        out.push_str(&(cells.join(";") + "\n"));
    }
    let map = format!(
        "delimiter = \";\"\ndecimal = \",\"\n[columns]\nq1 = \"J1\"\nq2 = \"J2\"\nq3 = \"J3\"\n\
         q4 = \"J4\"\nq5 = \"J5\"\nq6 = \"J6\"\nx = \"X\"\ny = \"Y\"\nz = \"Z\"\nrx = \"A\"\n\
         ry = \"B\"\nrz = \"C\"\n[units]\njoints = \"rad\"\nlength = \"m\"\n\
         orientation = \"deg\"\nrotation = \"{}\"\n",
        order.text()
    );
    (out, map)
}

/// Pose targets read through a map (joints in radians, points in metres, angles as Rx·Ry·Rz)
/// come back in the map's units and order: the joint commands in radians and the cartesian
/// targets in metres and Rx·Ry·Rz, the same commands and targets as from kinecal's layout.
/// (They came back in degrees, millimetres and kinecal's order, exit 0.)
fn written_back_in_the_map_s_units(
    dir: &std::path::Path,
    model: &std::path::Path,
    nominal: &std::path::Path,
    poses: &std::path::Path,
) {
    let order = RotationOrder::parse("Rx*Ry*Rz").unwrap();
    let (text, map) = vendor_poses(&std::fs::read_to_string(poses).unwrap(), order);
    let vendor = write(dir, "vendor.csv", &text);
    let map = write(dir, "vendor.map.toml", &map);
    let rows = |targets: &std::path::Path, extra: &[&str]| -> Vec<Vec<f64>> {
        let out = dir.join("out.csv");
        let base = [
            "compensate",
            "--model",
            s(model),
            "--targets",
            s(targets),
            "--out",
            s(&out),
        ];
        kinecal_ok(&[&base[..], extra].concat());
        let text = std::fs::read_to_string(&out).unwrap();
        text.lines().skip(1).map(cells).collect()
    };
    let cartesian = ["--robot", s(nominal), "--cartesian"];
    let with_map = ["--map", s(&map)];
    let plain = rows(poses, &cartesian);
    let mapped = rows(&vendor, &[&cartesian[..], &with_map[..]].concat());
    for (p, m) in plain.iter().zip(&mapped) {
        for a in 0..3 {
            assert!((m[a] * 1000.0 - p[a]).abs() < 1e-6, "{m:?} against {p:?}");
        }
        let want = RotationOrder::KINECAL.matrix([p[3], p[4], p[5]]);
        let got = order.matrix([m[3], m[4], m[5]]);
        assert!((want - got).abs().max() < 1e-9, "{m:?} against {p:?}");
    }
    let plain = rows(poses, &[]);
    let mapped = rows(&vendor, &with_map);
    assert_eq!(plain.len(), 40);
    // The joints' unit given by the flag instead of the map: the orientation (degrees, as the
    // map says) was read as radians and every target failed.
    let text = std::fs::read_to_string(&map).unwrap();
    let no_joints = write(
        dir,
        "no_joints.map.toml",
        &text.replace("joints = \"rad\"\n", ""),
    );
    let flagged = rows(&vendor, &["--map", s(&no_joints), "--angle-unit", "rad"]);
    for (p, ms) in plain.iter().zip(mapped.iter().zip(&flagged)) {
        for m in [ms.0, ms.1] {
            for j in 0..6 {
                assert!(
                    (m[j].to_degrees() - p[j]).abs() < 1e-6,
                    "{m:?} against {p:?}"
                );
            }
        }
    }
}

/// The tilted, placed ER20 as the model, one target (beyond its placed reach) and where the
/// commands would go, in `dir`.
fn one_target(
    dir: &std::path::Path,
) -> (std::path::PathBuf, std::path::PathBuf, std::path::PathBuf) {
    let model = write(dir, "model.toml", ER20_TILTED_PLACED);
    let targets = write(
        dir,
        "t.csv",
        "q1,q2,q3,q4,q5,q6,x,y,z\n0,-40,50,0,60,0,900,0,900\n",
    );
    (model, targets, dir.join("o.csv"))
}

#[test]
fn robot_without_cartesian_and_cartesian_without_robot_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (model, targets, out) = one_target(dir.path());
    let base = [
        "compensate",
        "--model",
        s(&model),
        "--targets",
        s(&targets),
        "--out",
        s(&out),
    ];
    let r = kinecal(&[&base[..], &["--robot", s(&model)]].concat());
    assert_eq!(r.status.code(), Some(2), "{r:?}");
    let r = kinecal(&[&base[..], &["--cartesian"]].concat());
    assert_ne!(r.status.code(), Some(0), "{r:?}");
    assert!(!out.exists());
    // The model itself as the controller's robot (a copy of it, renamed): every correction
    // would be zero and the targets came back unchanged with exit 0. Refused, saying what to
    // give.
    let renamed = ER20_TILTED_PLACED.replacen("name = \"", "name = \"controller copy of ", 1);
    assert_ne!(renamed, ER20_TILTED_PLACED);
    let copy = write(dir.path(), "copy.toml", &renamed);
    let r = kinecal(&[&base[..], &["--cartesian", "--robot", s(&copy)]].concat());
    assert_eq!(r.status.code(), Some(2), "{r:?}");
    assert!(
        stderr(&r).contains("would all be zero; give --robot the nominal robot file"),
        "{}",
        stderr(&r)
    );
    assert!(!out.exists());
}

/// A model that is no calibration of the controller's robot (a link 100 mm longer: another
/// robot, or a row typed wrong) used to shift every target by ~100 mm with status ok and exit
/// 0 once --max-step-deg let the corrections reach; `export` refused the same pair. Refused
/// now with `export`'s reason and its tolerances; a model within them passes.
#[test]
fn a_model_of_another_robot_is_refused_as_export_refuses_it() {
    let dir = tempfile::tempdir().unwrap();
    let (model, targets, out) = one_target(dir.path());
    let nominal_with = |name: &str, extra_mm: f64| {
        let mut f = RobotFile::load(&model).unwrap();
        f.name = format!("controller {name}");
        f.joints[2].a_mm += extra_mm;
        let path = dir.path().join(name);
        std::fs::write(&path, f.to_toml().unwrap()).unwrap();
        path
    };
    let run = |nominal: &std::path::Path| {
        kinecal(&[
            "compensate",
            "--model",
            s(&model),
            "--targets",
            s(&targets),
            "--out",
            s(&out),
            "--cartesian",
            "--robot",
            s(nominal),
            "--max-step-deg",
            "30",
        ])
    };
    let far = nominal_with("far.toml", -100.0);
    let r = run(&far);
    assert_eq!(r.status.code(), Some(2), "{r:?}");
    assert!(
        stderr(&r).contains("not a calibration of") && stderr(&r).contains("a3 is"),
        "{}",
        stderr(&r)
    );
    assert!(!out.exists());
    // A nominal whose joint 3 is read against joint 2 (a coupling the model lacks) put the
    // targets 0.35–1.0 m off with status ok and exit 0; the reverse pair as well.
    let coupled = {
        let mut f = RobotFile::load(&model).unwrap();
        f.couplings.push(CouplingSpec {
            joint: 3,
            from: 2,
            ratio: -1.0,
        });
        let path = dir.path().join("coupled.toml");
        std::fs::write(&path, f.to_toml().unwrap()).unwrap();
        path
    };
    let r = run(&coupled);
    assert_eq!(r.status.code(), Some(2), "{r:?}");
    assert!(
        stderr(&r).contains("not a calibration of")
            && stderr(&r).contains("joint 3 read against joint 2"),
        "{}",
        stderr(&r)
    );
    assert!(!out.exists());
    // Within the tolerances the check passes (this target lies off the placed robot's reach:
    // compensate then says so with exit 3, not 2).
    let near = nominal_with("near.toml", -0.5);
    let r = run(&near);
    assert_eq!(r.status.code(), Some(3), "{}", stderr(&r));
    assert!(!stderr(&r).contains("not a calibration"), "{}", stderr(&r));
    assert!(
        !stderr(&r).contains("its tool point lies"),
        "{}",
        stderr(&r)
    );
    // A controller whose TCP is a gripper 141 mm beyond the model's reflector: the commands
    // bring the reflector to the targets, which moved every written target by 141 mm with
    // status ok and no word. A warning says whose point the targets are taken for.
    let gripper = {
        let mut f = RobotFile::load(&near).unwrap();
        f.tool.xyz_mm[2] += 141.0;
        let path = dir.path().join("gripper.toml");
        std::fs::write(&path, f.to_toml().unwrap()).unwrap();
        path
    };
    let err = stderr(&run(&gripper));
    assert!(
        err.contains("its tool point lies 141 mm from the model's")
            && err.contains("not its own TCP"),
        "{err}"
    );
}

/// A seed beyond a joint's limit (q1 = 175° on a ±170° joint): the command was solved from it
/// and written beyond the limit too (173.26°, status `limited`). The seed is moved onto the
/// limit with a warning that names the line, and every command stays inside the limits; a
/// target the arm reaches inside them is still met, but from the controller's reading (175°) its
/// command (169.5°) is a 5.5° jump against `--max-step-deg` 2: `limited`, never `ok`, exit 3 (it
/// was `ok` with exit 0; the C ABI answers `LIMITED` there too).
#[test]
fn a_seed_beyond_a_joint_limit_gives_a_command_inside_it() {
    let dir = tempfile::tempdir().unwrap();
    let model_path = write(dir.path(), "model.toml", ER20_TILTED_PLACED);
    let model = RobotFile::parse(ER20_TILTED_PLACED, "m")
        .unwrap()
        .to_robot::<6>()
        .unwrap();
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let reach = [169.5f64, -40.0, 50.0, 10.0, 60.0, 20.0];
    fk.compute(&model, &reach.map(f64::to_radians));
    let p = fk.tool_pose(&model).o;
    let mut text = String::from("q1,q2,q3,q4,q5,q6,x,y,z\n");
    for q1 in [175.0, 169.0] {
        text.push_str(&format!("{q1},-40,50,10,60,20,{},{},{}\n", p.x, p.y, p.z));
    }
    let targets = write(dir.path(), "t.csv", &text);
    let out = dir.path().join("q.csv");
    let r = kinecal(&[
        "compensate",
        "--model",
        s(&model_path),
        "--targets",
        s(&targets),
        "--out",
        s(&out),
        "--max-step-deg",
        "2",
    ]);
    let err = stderr(&r);
    assert_eq!(r.status.code(), Some(3), "{err}");
    assert!(
        err.contains("1 seed reading(s) beyond the model's joint limits (line 2: q1 = 175°"),
        "{err}"
    );
    let text = std::fs::read_to_string(&out).unwrap();
    let lines: Vec<&str> = text.lines().skip(1).collect();
    assert_eq!(lines.len(), 2, "{text}");
    for line in &lines {
        assert!(cells(line)[0] <= 170.0 + 1e-9, "{line}");
    }
    // From the limit, 0.5° away, the target is met, 5.5° from the reading: limited.
    assert!(lines[0].contains(",limited,"), "{}", lines[0]);
    assert!((cells(lines[0])[0] - 169.5).abs() < 0.1, "{}", lines[0]);
    // The seed inside the limit, 0.5° from the answer: met, ok.
    assert!(lines[1].contains(",ok,"), "{}", lines[1]);
}
