//! Files in other layouts (`--map M.toml`, docs/formats.md "Files in other layouts") and the
//! doors behind the units door: the order of a file's three angles ("The convention check")
//! and a stated base that puts the data far away ("Base").

use crate::common::*;
use kinecal::forward::ForwardKinematics;
use kinecal::Frame;
use kinecal_cli::formats::loading::load_measurements;
use kinecal_cli::formats::measurements::{self, Dataset};
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::formats::rotation_order::RotationOrder;
use kinecal_cli::formats::units::UnitArgs;
use nalgebra::Matrix3;
use std::path::{Path, PathBuf};

/// data/ur10 of the repository.
fn ur10() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/ur10")
}

fn with_map(map: &Path) -> UnitArgs {
    UnitArgs {
        map: Some(map.to_path_buf()),
        ..UnitArgs::default()
    }
}

/// The UR10 measurement file `data` read as `identify` reads it (no `[base]`).
fn load(data: &Path, units: &UnitArgs) -> Dataset<6> {
    let file = RobotFile::load(&ur10().join("robot.toml")).unwrap();
    let robot = file.to_robot::<6>().unwrap();
    load_measurements::<6, _>(data, units, &robot, false).unwrap()
}

fn column(ds: &Dataset<6>, name: &str) -> Vec<f64> {
    ds.extra(name)
        .unwrap_or_else(|| panic!("column {name} in {:?}", ds.extra_names))
}

/// Angle, degrees, between two rotations (from the chord `|A − B|`, exact near 0 where the
/// trace's `acos` is not).
fn angle_deg(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    let chord = (a - b).norm() / (2.0 * 2f64.sqrt());
    (2.0 * chord.clamp(0.0, 1.0).asin()).to_degrees()
}

fn rotation_of(ds: &Dataset<6>, i: usize) -> Matrix3<f64> {
    let a = ["rx_deg", "ry_deg", "rz_deg"].map(|c| column(ds, c)[i]);
    RotationOrder::KINECAL.matrix(a)
}

/// The angles about x, y, z (degrees) that compose `r` in `order` (R = R_i(a)·R_j(b)·R_k(c)).
fn angles_in(order: RotationOrder, r: &Matrix3<f64>) -> [f64; 3] {
    let [i, j, k] = order.axes;
    // +1 for the cyclic orders (x-y-z, y-z-x, z-x-y), -1 for the others.
    let e = if (j + 3 - i) % 3 == 1 { 1.0 } else { -1.0 };
    let b = (e * r[(i, k)]).clamp(-1.0, 1.0).asin();
    let a = (-e * r[(j, k)]).atan2(r[(k, k)]);
    let c = (-e * r[(i, j)]).atan2(r[(i, i)]);
    let mut out = [0.0; 3];
    out[i] = a.to_degrees();
    out[j] = b.to_degrees();
    out[k] = c.to_degrees();
    out
}

/// A number with a decimal comma.
fn comma(x: f64) -> String {
    format!("{x:?}").replace('.', ",")
}

/// Metres of a length in millimetres, as a tracker exporting metres writes it.
fn metres(mm: f64) -> f64 {
    format!("{mm}e-3").parse().unwrap()
}

/// The first `n` rows of the converted 6-D UR10 file, as a file of their own.
fn converted_rows(dir: &Path, n: usize) -> PathBuf {
    let text = std::fs::read_to_string(ur10().join("ur10_random_poses_6d.csv")).unwrap();
    let head: Vec<&str> = text.lines().take(n + 1).collect();
    write(dir, "converted.csv", &(head.join("\n") + "\n"))
}

/// The converted rows `ds` in the published layout: `;`, decimal commas, joints in radians,
/// positions and their σ in metres, the vendor's column names; the angles composed in
/// `order` (in degrees), their σ per axis (each the row's `srot_deg`) or as one column.
fn vendor_text(ds: &Dataset<6>, order: RotationOrder, per_axis: bool) -> String {
    let mut s = String::from(
        "Timestamp;shoulder_pan_joint;shoulder_lift_joint;elbow_joint;wrist_1_joint;wrist_2_joint;wrist_3_joint;measurement_temperature;measurement_x;measurement_std_x;measurement_y;measurement_std_y;measurement_z;measurement_std_z;measurement_rx;measurement_ry;measurement_rz",
    );
    s.push_str(if per_axis {
        ";measurement_std_rx;measurement_std_ry;measurement_std_rz\n"
    } else {
        ";measurement_std_rot\n"
    });
    let col = |c: &str| column(ds, c);
    let (t, sx, sy, sz, sr) = (
        col("temp_c"),
        col("sx_mm"),
        col("sy_mm"),
        col("sz_mm"),
        col("srot_deg"),
    );
    for (i, r) in ds.records.iter().enumerate() {
        let mut cells = vec!["2,02011E+13".to_string()];
        cells.extend(r.q_deg.iter().map(|q| comma(q.to_radians())));
        cells.push(comma(t[i]));
        for (p, sp) in r.xyz_mm.iter().zip([sx[i], sy[i], sz[i]]) {
            cells.push(comma(metres(*p)));
            cells.push(comma(metres(sp)));
        }
        let a = if order == RotationOrder::KINECAL {
            ["rx_deg", "ry_deg", "rz_deg"].map(|c| col(c)[i])
        } else {
            angles_in(order, &rotation_of(ds, i))
        };
        cells.extend(a.iter().map(|v| comma(*v)));
        let n = if per_axis { 3 } else { 1 };
        cells.extend((0..n).map(|_| comma(sr[i])));
        s.push_str(&cells.join(";"));
        s.push('\n');
    }
    s
}

fn vendor_map(order: RotationOrder, per_axis: bool) -> String {
    let sigma = if per_axis {
        "srx_deg = \"measurement_std_rx\"\nsry_deg = \"measurement_std_ry\"\nsrz_deg = \"measurement_std_rz\"\n"
    } else {
        "srot_deg = \"measurement_std_rot\"\n"
    };
    format!(
        "decimal = \",\"\n[columns]\nq1 = \"shoulder_pan_joint\"\nq2 = \"shoulder_lift_joint\"\nq3 = \"elbow_joint\"\nq4 = \"wrist_1_joint\"\nq5 = \"wrist_2_joint\"\nq6 = \"wrist_3_joint\"\ntemp_c = \"measurement_temperature\"\nx = \"measurement_x\"\ny = \"measurement_y\"\nz = \"measurement_z\"\nsx_mm = \"measurement_std_x\"\nsy_mm = \"measurement_std_y\"\nsz_mm = \"measurement_std_z\"\nrx_deg = \"measurement_rx\"\nry_deg = \"measurement_ry\"\nrz_deg = \"measurement_rz\"\n{sigma}[units]\njoints = \"rad\"\nlength = \"m\"\norientation = \"deg\"\nrotation = \"{}\"\n",
        order.text()
    )
}

/// `identify --json` without its timings.
fn identify_json(args: &[&str]) -> serde_json::Value {
    json_without_timings(&kinecal(args))
}

#[test]
fn a_vendor_layout_in_kinecal_s_angle_order_gives_the_converted_records_bit_for_bit() {
    let dir = tempfile::tempdir().unwrap();
    let conv = converted_rows(dir.path(), 150);
    let a = load(&conv, &UnitArgs::default());
    let vendor = write(
        dir.path(),
        "vendor.csv",
        &vendor_text(&a, RotationOrder::KINECAL, false),
    );
    let map = write(
        dir.path(),
        "vendor.map.toml",
        &vendor_map(RotationOrder::KINECAL, false),
    );
    let b = load(&vendor, &with_map(&map));
    assert_eq!(a.len(), b.len());
    for (ra, rb) in a.records.iter().zip(&b.records) {
        // Radians read back as the degrees that give exactly those radians (the library's
        // units): the model sees the very numbers of the converted file.
        assert_eq!(ra.q_deg.map(f64::to_radians), rb.q_deg.map(f64::to_radians));
        assert_eq!(ra.xyz_mm, rb.xyz_mm, "line {}", ra.line);
        assert_eq!(ra.line, rb.line);
    }
    let mut names_a = a.extra_names.clone();
    let mut names_b = b.extra_names.clone();
    names_a.sort();
    names_b.sort();
    assert_eq!(names_a, names_b);
    for name in &a.extra_names {
        let (ca, cb) = (column(&a, name), column(&b, name));
        assert!(
            ca.iter().zip(&cb).all(|(x, y)| x.to_bits() == y.to_bits()),
            "{name}"
        );
    }
    // The whole identification agrees to the last digit.
    let robot = ur10().join("robot.toml");
    let run = |data: &Path, extra: &[&str]| {
        let mut args = vec![
            "identify",
            "--robot",
            s(&robot),
            "--data",
            s(data),
            "--json",
        ];
        args.extend_from_slice(extra);
        identify_json(&args)
    };
    let ja = run(&conv, &[]);
    let jb = run(&vendor, &["--map", s(&map)]);
    assert_eq!(ja, jb);
    assert!(ja["after"]["identification_rms_mm"].as_f64().unwrap() < 1.0);
}

#[test]
fn angles_in_another_order_and_per_axis_sigma_give_the_same_rotations() {
    let dir = tempfile::tempdir().unwrap();
    let conv = converted_rows(dir.path(), 150);
    let a = load(&conv, &UnitArgs::default());
    let xyz = RotationOrder::parse("Rx*Ry*Rz").unwrap();
    let vendor = write(dir.path(), "vendor.csv", &vendor_text(&a, xyz, true));
    let map = write(dir.path(), "vendor.map.toml", &vendor_map(xyz, true));
    let b = load(&vendor, &with_map(&map));
    assert_eq!(a.len(), b.len());
    let mut worst: f64 = 0.0;
    for i in 0..a.len() {
        assert_eq!(a.records[i].xyz_mm, b.records[i].xyz_mm);
        worst = worst.max(angle_deg(&rotation_of(&a, i), &rotation_of(&b, i)));
    }
    assert!(worst < 1e-9, "largest rotation difference {worst}°");
    // Three equal per-axis σ combine into that σ (their RMS).
    for (x, y) in column(&a, "srot_deg").iter().zip(column(&b, "srot_deg")) {
        assert!((x - y).abs() <= 1e-15 * x, "{x} {y}");
    }
    let robot = ur10().join("robot.toml");
    let ja = identify_json(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&conv),
        "--json",
    ]);
    let jb = identify_json(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&vendor),
        "--map",
        s(&map),
        "--json",
    ]);
    for key in ["identification_rms_mm", "identification_rms_deg"] {
        if let (Some(x), Some(y)) = (ja["after"][key].as_f64(), jb["after"][key].as_f64()) {
            assert!((x - y).abs() <= 1e-6 * x.abs().max(1e-9), "{key}: {x} {y}");
        }
    }
}

#[test]
fn the_published_ur10_layout_reads_as_the_converted_file() {
    let published = ur10().join("published");
    let data = published.join("measurements_random_poses_excerpt.csv");
    let map = published.join("ur10_series_c.map.toml");
    let b = load(&data, &with_map(&map));
    let dir = tempfile::tempdir().unwrap();
    let a = load(&converted_rows(dir.path(), b.len()), &UnitArgs::default());
    assert_eq!(b.len(), 20);
    for i in 0..b.len() {
        let (ra, rb) = (&a.records[i], &b.records[i]);
        // The converted file keeps 6 decimals of the degrees and 5 of the millimetres.
        for (qa, qb) in ra.q_deg.iter().zip(rb.q_deg) {
            assert!((qa - qb).abs() <= 5.0001e-7, "row {i}: {qa} {qb}");
        }
        for (pa, pb) in ra.xyz_mm.iter().zip(rb.xyz_mm) {
            assert!((pa - pb).abs() <= 5.0001e-6, "row {i}: {pa} {pb}");
        }
        let d = angle_deg(&rotation_of(&a, i), &rotation_of(&b, i));
        assert!(d < 2e-6, "row {i}: orientations differ by {d}°");
        for c in ["sx_mm", "sy_mm", "sz_mm"] {
            assert_eq!(column(&a, c)[i], column(&b, c)[i], "row {i} {c}");
        }
        let (sa, sb) = (column(&a, "srot_deg")[i], column(&b, "srot_deg")[i]);
        assert!((sa - sb).abs() <= 5.0001e-9, "row {i}: srot {sa} {sb}");
        assert!((column(&a, "temp_c")[i] - column(&b, "temp_c")[i]).abs() < 1e-6);
    }
    // And through the binary: read as published, `check` passes.
    let robot = ur10().join("robot.toml");
    let out = kinecal(&[
        "check",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--map",
        s(&map),
        "--json",
    ]);
    let v = json_of(&out);
    assert_eq!(v["poses"], 20);
    // Without the map the published file is refused with a one-line reason.
    let out = kinecal(&["check", "--robot", s(&robot), "--data", s(&data)]);
    assert_eq!(out.status.code(), Some(2));
    let err = stderr(&out);
    assert!(
        err.trim().lines().count() == 1 && err.contains("read it with --map M.toml"),
        "{err}"
    );
}

/// UR10 joint readings and tracker points from `kinecal simulate` (robot placed in a tracker
/// frame), with the probe's orientation of each pose computed here: `(records, rotations)`.
fn simulated_6d(dir: &Path, poses: usize, seed: u64) -> (Dataset<6>, Vec<Matrix3<f64>>) {
    let text = std::fs::read_to_string(ur10().join("robot.toml")).unwrap();
    let placed_text =
        format!("{text}\n[base]\nxyz_mm = [420.0, -3150.0, 180.0]\nrpy_deg = [1.5, -2.0, 97.0]\n");
    let placed = write(dir, "placed.toml", &placed_text);
    let out = dir.join(format!("sim{seed}.csv"));
    simulate(&placed, Some(poses), Some(0.02), Some(seed), &[], &out);
    let ds = measurements::load::<6>(&out).unwrap();
    let robot = RobotFile::parse(&placed_text, "placed.toml")
        .unwrap()
        .to_robot::<6>()
        .unwrap();
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let tool = Frame::from_xyz_rpy([0.0; 3], [0.4f64, -0.3, 1.1]).rotation();
    let rot = ds
        .records
        .iter()
        .map(|r| {
            fk.compute(&robot, &r.q_deg.map(f64::to_radians));
            fk.flange_pose().rotation() * tool
        })
        .collect();
    (ds, rot)
}

/// The simulated rows with their orientation as angles composed in `order`, in kinecal's
/// layout (`rx_deg`, `ry_deg`, `rz_deg`).
fn with_angles(ds: &Dataset<6>, rot: &[Matrix3<f64>], order: RotationOrder) -> String {
    let mut s = String::from("q1,q2,q3,q4,q5,q6,x,y,z,rx_deg,ry_deg,rz_deg\n");
    for (r, m) in ds.records.iter().zip(rot) {
        let a = angles_in(order, m);
        let cells: Vec<String> = r
            .q_deg
            .iter()
            .chain(&r.xyz_mm)
            .chain(&a)
            .map(|v| format!("{v:?}"))
            .collect();
        s.push_str(&cells.join(","));
        s.push('\n');
    }
    s
}

#[test]
fn each_of_the_six_rotation_orders_is_detected_and_refused_when_misstated() {
    let dir = tempfile::tempdir().unwrap();
    let (ds, rot) = simulated_6d(dir.path(), 60, 7);
    let robot = ur10().join("robot.toml");
    for truth in RotationOrder::all() {
        let name = truth.text().replace('*', "");
        let data = write(
            dir.path(),
            &format!("{name}.csv"),
            &with_angles(&ds, &rot, truth),
        );
        // Read as kinecal's own order: refused unless it is kinecal's.
        let out = kinecal(&["check", "--robot", s(&robot), "--data", s(&data)]);
        let err = stderr(&out);
        if truth == RotationOrder::KINECAL {
            assert!(out.status.success(), "{name}: {err}");
        } else {
            assert_eq!(out.status.code(), Some(2), "{name}: {err}");
            assert!(
                err.contains(&format!("rotation = \"{}\"", truth.text()))
                    && err.contains("--map")
                    && err.trim().lines().count() == 1,
                "{name}: {err}"
            );
        }
        // Stated right in a map: accepted; stated wrong: refused, naming the right order.
        let wrong = if truth == RotationOrder::KINECAL {
            RotationOrder::parse("Rx*Ry*Rz").unwrap()
        } else {
            RotationOrder::KINECAL
        };
        for (stated, ok) in [(truth, true), (wrong, false)] {
            let map = write(
                dir.path(),
                "order.map.toml",
                &format!("[units]\nrotation = \"{}\"\n", stated.text()),
            );
            let out = kinecal(&[
                "check",
                "--robot",
                s(&robot),
                "--data",
                s(&data),
                "--map",
                s(&map),
            ]);
            let err = stderr(&out);
            if ok {
                assert!(out.status.success(), "{name} stated right: {err}");
            } else {
                assert_eq!(out.status.code(), Some(2), "{name} stated wrong: {err}");
                assert!(
                    err.contains(&format!("set rotation = \"{}\"", truth.text())),
                    "{name}: {err}"
                );
            }
        }
    }
}

#[test]
fn identify_refuses_angles_in_another_order_instead_of_calibrating_them() {
    let dir = tempfile::tempdir().unwrap();
    let (ds, rot) = simulated_6d(dir.path(), 80, 9);
    let xyz = RotationOrder::parse("Rx*Ry*Rz").unwrap();
    let data = write(dir.path(), "xyz.csv", &with_angles(&ds, &rot, xyz));
    let robot = ur10().join("robot.toml");
    let out = kinecal(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--json",
    ]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    let map = write(
        dir.path(),
        "xyz.map.toml",
        "[units]\nrotation = \"Rx*Ry*Rz\"\n",
    );
    let v = identify_json(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--map",
        s(&map),
        "--json",
    ]);
    assert!(
        v["after"]["identification_rms_mm"].as_f64().unwrap() < 0.1,
        "{v}"
    );
}

#[test]
fn a_stated_base_that_puts_the_data_metres_away_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(ur10().join("robot.toml")).unwrap();
    // Data measured in a tracker frame about 3 m from the robot…
    let placed = write(
        dir.path(),
        "placed.toml",
        &format!("{text}\n[base]\nxyz_mm = [420.0, -3150.0, 180.0]\nrpy_deg = [0.0, 0.0, 97.0]\n"),
    );
    let data = dir.path().join("tracker.csv");
    simulate(&placed, Some(60), Some(0.02), Some(3), &[], &data);
    // …and a robot file that says the base is the tracker's origin.
    let identity = write(
        dir.path(),
        "identity.toml",
        &format!("{text}\n[base]\nxyz_mm = [0.0, 0.0, 0.0]\nrpy_deg = [0.0, 0.0, 0.0]\n"),
    );
    for command in ["check", "identify"] {
        let out = run_on(command, &identity, &data, &[]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{command}: {err}");
        let metres: f64 = err
            .split("[base] puts the measured points ")
            .nth(1)
            .and_then(|r| r.split(" m from").next())
            .and_then(|m| m.parse().ok())
            .unwrap_or_else(|| panic!("{command}: {err}"));
        assert!(
            metres > 2.5 && err.contains("remove [base]") && err.trim().lines().count() == 1,
            "{command}: {err}"
        );
    }
    // The right base, and no base at all, pass.
    assert!(run_on("check", &placed, &data, &[]).status.success());
    assert!(run_on("check", &ur10().join("robot.toml"), &data, &[])
        .status
        .success());
}

#[test]
fn map_mistakes_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let published = ur10().join("published");
    let data = published.join("measurements_random_poses_excerpt.csv");
    let robot = ur10().join("robot.toml");
    let map_text = std::fs::read_to_string(published.join("ur10_series_c.map.toml")).unwrap();
    for (name, text, extra, says) in [
        (
            "no_decimal.toml",
            map_text.replace("decimal = \",\"\n", ""),
            &[][..],
            "say decimal = \",\"",
        ),
        (
            "typo.toml",
            map_text.replace("\"elbow_joint\"", "\"elbow\""),
            &[][..],
            "q3 = \"elbow\"",
        ),
        (
            "flag.toml",
            map_text.clone(),
            &["--angle-unit", "deg"][..],
            "--angle-unit deg contradicts",
        ),
    ] {
        let map = write(dir.path(), name, &text);
        let mut args = vec![
            "check",
            "--robot",
            s(&robot),
            "--data",
            s(&data),
            "--map",
            s(&map),
        ];
        args.extend_from_slice(extra);
        let out = kinecal(&args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{name}: {err}");
        assert!(
            err.contains(says) && err.trim().lines().count() == 1,
            "{name}: {err}"
        );
    }
}
