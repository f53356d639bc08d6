//! The `frames` subcommand: the base into the robot file, warnings, one JSON object.

use super::*;

#[test]
fn frames_command_reports_the_base_and_writes_it_into_the_robot_file() {
    let dir = tempfile::tempdir().unwrap();
    let robot_path = write_robot(dir.path(), &ER20, ER20_TOOL);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(99);
    let base = random_base(&mut rng);
    let truth: Robot<f64, 6, kinecal::Inline<0>> = robot(&ER20, ER20_TOOL, base);
    let data = sweep_data(
        &truth,
        &[20.0, 10.0, -10.0, 0.0, 20.0, 0.0],
        &[1, 2, 5, 6],
        24,
        360.0,
        0.015,
        8,
    )
    .unwrap();
    let csv = dir.path().join("sweeps.csv");
    measurements::write(&csv, &data).unwrap();
    let out = dir.path().join("r2.toml");
    let v = find_frames(&robot_path, &csv, Some(&out)).unwrap();
    let found = Frame::from_xyz_rpy(v.base.xyz_mm, v.base.rpy_deg.map(f64::to_radians));
    let (mm, deg) = frame_error(&found, &base);
    let (radial, axial) = (v.tool_radial_mm.unwrap(), v.tool_axial_mm.unwrap());
    println!("frames: base error {mm:.4} mm, {deg:.5}°; tool {radial} / {axial}");
    assert!(mm < 0.1 && deg < 0.01);
    assert!((axial - 225.0).abs() < 0.05);
    assert!(radial < 0.05);
    assert_eq!(v.circles.len(), 4);
    assert!(v.circles.iter().all(|c| c.radius_mm().is_finite()));
    assert!(v.circles[0].rms_mm().unwrap() < 0.05);
    assert_eq!(v.out, Some(out.display().to_string()));
    // The written robot file has the same base and reads back.
    let (_, r2) = kinecal_cli::formats::robot_file::load_robot::<6>(&out).unwrap();
    let (mm2, deg2) = frame_error(r2.base(), &found);
    assert!(mm2 < 1e-9 && deg2 < 1e-9);
    assert_eq!(r2.joints()[1].a, 170.0);
}

#[test]
fn frames_command_warns_about_short_or_noisy_sweeps_and_names_bad_cells() {
    let dir = tempfile::tempdir().unwrap();
    let robot_path = write_robot(dir.path(), &UR10, UR10_TOOL);
    let truth: Robot<f64, 6, kinecal::Inline<0>> = robot(&UR10, UR10_TOOL, Frame::identity());
    let run = |data: &measurements::Dataset<6>, name: &str| {
        let csv = dir.path().join(name);
        measurements::write(&csv, data).unwrap();
        find_frames(&robot_path, &csv, None)
    };
    let warnings = |v: &kinecal_cli::reports::FramesReport| v.warnings.clone();
    let good = sweep_data(&truth, &[0.0; 6], &[1, 2, 5, 6], 24, 360.0, 0.015, 1).unwrap();
    let w = warnings(&run(&good, "good.csv").unwrap());
    assert!(
        w.iter()
            .all(|w| !w.contains("too short") && !w.contains("too noisy")),
        "{w:?}"
    );
    let short = sweep_data(&truth, &[0.0; 6], &[1, 2], 24, 8.0, 0.015, 1).unwrap();
    let w = warnings(&run(&short, "short.csv").unwrap());
    assert!(
        w.iter()
            .any(|w| w.contains("joint 1") && w.contains("too short")),
        "{w:?}"
    );
    let noisy = sweep_data(&truth, &[0.0; 6], &[1, 2], 24, 90.0, 0.3, 1).unwrap();
    let w = warnings(&run(&noisy, "noisy.csv").unwrap());
    assert!(w.iter().any(|w| w.contains("too noisy")), "{w:?}");

    // A sweep cell that names no joint: file, line and column.
    let mut bad = good.clone();
    bad.records[4].extra[0] = 9.0;
    let e = run(&bad, "bad.csv").unwrap_err().to_string();
    assert!(
        e.contains("bad.csv:6:") && e.contains(":10:") && e.contains("sweep"),
        "{e}"
    );
    // No sweep column at all.
    let mut none = good.clone();
    none.extra_names.clear();
    none.records.iter_mut().for_each(|r| r.extra.clear());
    let e = run(&none, "none.csv").unwrap_err().to_string();
    assert!(e.contains("none.csv") && e.contains("sweep"), "{e}");
    // No joint-2 sweep.
    let only1 = sweep_data(&truth, &[0.0; 6], &[1], 24, 90.0, 0.015, 1).unwrap();
    let e = run(&only1, "only1.csv").unwrap_err().to_string();
    assert!(e.contains("joint 2"), "{e}");
}

#[test]
fn frames_binary_prints_one_json_object() {
    let dir = tempfile::tempdir().unwrap();
    let robot_path = write_robot(dir.path(), &UR10, UR10_TOOL);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let truth: Robot<f64, 6, kinecal::Inline<0>> = robot(&UR10, UR10_TOOL, random_base(&mut rng));
    let data = sweep_data(&truth, &[0.0; 6], &[1, 2, 5, 6], 24, 360.0, 0.02, 2).unwrap();
    let csv = dir.path().join("s.csv");
    measurements::write(&csv, &data).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_kinecal-under-test"))
        .args([
            "frames",
            "--robot",
            robot_path.to_str().unwrap(),
            "--data",
            csv.to_str().unwrap(),
            "--json",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in ["base", "tool_radial_mm", "tool_axial_mm", "circles"] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    let xyz: Vec<f64> = serde_json::from_value(v["base"]["xyz_mm"].clone()).unwrap();
    let rpy: Vec<f64> = serde_json::from_value(v["base"]["rpy_deg"].clone()).unwrap();
    let found = Frame::from_xyz_rpy(
        [xyz[0], xyz[1], xyz[2]],
        [rpy[0], rpy[1], rpy[2]].map(f64::to_radians),
    );
    let (mm, deg) = frame_error(&found, truth.base());
    assert!(mm < 0.1 && deg < 0.01, "{mm} mm {deg}°");
    assert!((v["tool_axial_mm"].as_f64().unwrap() - 201.2).abs() < 0.05);
}

/// A joint whose sign in the data is the opposite of the robot file's still gives a base from
/// the sweeps of joints 1 and 2: turned by 180°, exit 0 (the robot placed there missed the
/// points by 2.4 m). The sweeps of joints 3 to 5 now tell (their axes point away from, or lie
/// metres from, the model's at that base: exit 2 naming the signs), so do the points with
/// sweeps of joints 1 and 2 alone (the stated tool metres from them), and rows whose `sweep`
/// names a joint that did not turn (within an encoder's jitter) name the one that did. Points
/// mirrored or in inches are named as such.
#[test]
fn frames_refuses_a_base_the_other_sweeps_contradict() {
    let dir = tempfile::tempdir().unwrap();
    let robot_path = write_robot(dir.path(), &ER20, ER20_TOOL);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(98);
    let base = random_base(&mut rng);
    let truth: Robot<f64, 6, kinecal::Inline<0>> = robot(&ER20, ER20_TOOL, base);
    let data = sweep_data(
        &truth,
        &[20.0, 10.0, -10.0, 30.0, 20.0, 0.0],
        &[1, 2, 3, 4, 5, 6],
        24,
        300.0,
        0.015,
        9,
    )
    .unwrap();
    let run = |name: &str, edit: &dyn Fn(&mut measurements::Record<6>)| {
        let mut d = data.clone();
        d.records.iter_mut().for_each(edit);
        let csv = dir.path().join(name);
        measurements::write(&csv, &d).unwrap();
        find_frames(&robot_path, &csv, None)
    };
    let v = run("right.csv", &|_| {}).unwrap();
    let found = Frame::from_xyz_rpy(v.base.xyz_mm, v.base.rpy_deg.map(f64::to_radians));
    assert!(frame_error(&found, &base).0 < 0.1);
    // A file that states the tool at the flange (not measured yet): the sweeps measure it.
    let flange = dir.path().join("flange");
    std::fs::create_dir(&flange).unwrap();
    let flange_robot = write_robot(&flange, &ER20, [0.0, 0.0, 0.0]);
    let csv = dir.path().join("right.csv");
    find_frames(&flange_robot, &csv, None).unwrap();
    for joint in [0, 1] {
        let e = run("negated.csv", &|r| r.q_deg[joint] = -r.q_deg[joint]).unwrap_err();
        assert_eq!(kinecal_cli::commands::exit_status(&e), 2);
        let e = format!("{e:#}");
        assert!(
            e.contains("turns about an axis") && e.contains("sign"),
            "joint {} negated: {e}",
            joint + 1
        );
    }
    // The tracker's y axis mirrored, or the points in inches: named as such, where the axes
    // used to blame a joint's sign or zero.
    let e = run("mirrored.csv", &|r| r.xyz_mm[1] = -r.xyz_mm[1]).unwrap_err();
    assert_eq!(kinecal_cli::commands::exit_status(&e), 2);
    let e = format!("{e:#}");
    assert!(
        e.contains("model mirrored") && !e.contains("sign in the data"),
        "{e}"
    );
    let e = run("inches.csv", &|r| r.xyz_mm = r.xyz_mm.map(|v| v / 25.4)).unwrap_err();
    assert_eq!(kinecal_cli::commands::exit_status(&e), 2);
    assert!(format!("{e:#}").contains("inches"), "{e:#}");
    let sweep = data.extra_names.iter().position(|n| n == "sweep").unwrap();
    // Labels exchanged, on readings with an encoder's jitter.
    let e = run("labels.csv", &|r| {
        let jitter = (r.xyz_mm[0] * 1e3).sin() * 5e-4;
        r.q_deg.iter_mut().for_each(|q| *q += jitter);
        match r.extra[sweep] as i64 {
            5 => r.extra[sweep] = 6.0,
            6 => r.extra[sweep] = 5.0,
            _ => {}
        }
    })
    .unwrap_err();
    assert!(
        format!("{e}").contains("names joint 5 but joint 6 turned"),
        "{e}"
    );
    // Sweeps of joints 1 and 2 alone (the least `frames` needs): the stated tool tells.
    let base_only = sweep_data(
        &truth,
        &[20.0, 10.0, -10.0, 30.0, 20.0, 0.0],
        &[1, 2],
        24,
        300.0,
        0.015,
        10,
    )
    .unwrap();
    let csv = dir.path().join("two.csv");
    measurements::write(&csv, &base_only).unwrap();
    find_frames(&robot_path, &csv, None).unwrap();
    let mut negated = base_only.clone();
    negated
        .records
        .iter_mut()
        .for_each(|r| r.q_deg[1] = -r.q_deg[1]);
    measurements::write(&csv, &negated).unwrap();
    let e = find_frames(&robot_path, &csv, None).unwrap_err();
    assert!(
        format!("{e}").contains("mm RMS from the swept points"),
        "{e}"
    );
}

/// A few rows whose `sweep` cell names the wrong joint (rows of joint 2's sweep tagged 1) are
/// refused naming their lines and the sweep they fit, instead of "joint 2 moved during the
/// sweep … sweep again"; the file with the cells right is found as before.
#[test]
fn frames_names_rows_tagged_with_the_wrong_sweep() {
    let dir = tempfile::tempdir().unwrap();
    let robot_path = write_robot(dir.path(), &ER20, ER20_TOOL);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(97);
    let base = random_base(&mut rng);
    let truth: Robot<f64, 6, kinecal::Inline<0>> = robot(&ER20, ER20_TOOL, base);
    let data = sweep_data(
        &truth,
        &[20.0, 10.0, -10.0, 30.0, 20.0, 0.0],
        &[1, 2, 5, 6],
        24,
        300.0,
        0.015,
        10,
    )
    .unwrap();
    let k = data.extra_names.iter().position(|n| n == "sweep").unwrap();
    // Rows 3, 8 and 13 of sweep `from` tagged `to`; the lines they sit on (header = line 1).
    let retag = |from: f64, to: f64| {
        let mut d = data.clone();
        let mut lines = Vec::new();
        let rows = d
            .records
            .iter_mut()
            .enumerate()
            .filter(|(_, r)| r.extra[k] == from);
        for (n, (i, r)) in rows.enumerate() {
            if [3, 8, 13].contains(&n) {
                r.extra[k] = to;
                lines.push(i + 2);
            }
        }
        let csv = dir.path().join("retagged.csv");
        measurements::write(&csv, &d).unwrap();
        (find_frames(&robot_path, &csv, None), lines)
    };
    for (from, to) in [(2.0, 1.0), (5.0, 6.0), (1.0, 2.0)] {
        let (r, lines) = retag(from, to);
        let e = format!("{:#}", r.unwrap_err());
        let named: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
        assert!(
            e.contains(&format!(
                "sweep of joint {to}: 3 of its 27 rows (lines {})",
                named.join(", ")
            )) && e.contains(&format!("set their `sweep` to {from}")),
            "{from} tagged {to}: {e}"
        );
    }
    let csv = dir.path().join("right.csv");
    measurements::write(&csv, &data).unwrap();
    let v = find_frames(&robot_path, &csv, None).unwrap();
    let found = Frame::from_xyz_rpy(v.base.xyz_mm, v.base.rpy_deg.map(f64::to_radians));
    assert!(frame_error(&found, &base).0 < 0.1);
}
