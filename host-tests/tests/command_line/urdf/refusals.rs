//! What import and export refuse or warn about: bad joints and links, what a URDF cannot hold.

use super::*;

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
    // The file as given expanded beside it, not over it (the hint named a robot.urdf.xacro
    // that did not exist and wrote over robot.urdf).
    assert!(
        e.contains("robot.urdf > ") && e.contains("robot.expanded.urdf"),
        "{e}"
    );
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
