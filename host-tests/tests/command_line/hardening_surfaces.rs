//! Hostile inputs at the command line's edges: output paths that are devices, links or pipes;
//! URDF files that are no tree, nest without end or are huge; exports the file's text would
//! break; diagnose JSON out of range; usage errors with `--json`. Each is refused with exit
//! status 2 and one line saying why (or, for a device, written into as a stream), never a
//! hang, a panic or a device node replaced by a file.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use crate::common::{kinecal, kinecal_ok, s, stderr, write, ER20_PLACED};

/// A 6R arm as URDF: links `l0`…`l6` and a fixed flange joint to `tip`; `fixed_after` fixed
/// joints more after the flange (links `f1`…), each with an origin.
fn arm(tip: &str, fixed_after: usize) -> String {
    let axes = ["0 0 1", "0 1 0", "0 1 0", "1 0 0", "0 1 0", "1 0 0"];
    let origins = [
        "0 0 0.4",
        "0.16 0 0.1",
        "0 0 0.78",
        "0.15 0 0.15",
        "0.86 0 0",
        "0.15 0 0",
    ];
    let mut t =
        String::from("<?xml version=\"1.0\"?>\n<robot name=\"arm\">\n  <link name=\"l0\"/>\n");
    for i in 1..=6 {
        t.push_str(&format!(
            "  <link name=\"l{i}\"/>\n  <joint name=\"j{i}\" type=\"revolute\"><parent link=\"l{}\"/><child link=\"l{i}\"/><origin xyz=\"{}\" rpy=\"0 0 0\"/><axis xyz=\"{}\"/><limit lower=\"-3\" upper=\"3\" effort=\"1\" velocity=\"1\"/></joint>\n",
            i - 1,
            origins[i - 1],
            axes[i - 1]
        ));
    }
    let mut last = "l6".to_string();
    for k in 1..=fixed_after {
        t.push_str(&format!(
            "  <link name=\"f{k}\"/>\n  <joint name=\"fixed{k}\" type=\"fixed\"><parent link=\"{last}\"/><child link=\"f{k}\"/><origin xyz=\"0 0 0.0001\" rpy=\"0 0 0\"/></joint>\n"
        ));
        last = format!("f{k}");
    }
    t.push_str(&format!(
        "  <link name=\"{tip}\"/>\n  <joint name=\"flange\" type=\"fixed\"><parent link=\"{last}\"/><child link=\"{tip}\"/><origin xyz=\"0 0 0.1\" rpy=\"0 0 0\"/></joint>\n</robot>\n"
    ));
    t
}

/// Runs `kinecal ARGS` and asserts exit status 2 with one line on stderr that holds every
/// needle; returns that line.
fn refused(args: &[&str], needles: &[&str]) -> String {
    let o = kinecal(args);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
    assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
    for n in needles {
        assert!(e.contains(n), "{args:?}: '{n}' in {e}");
    }
    e
}

/// `import --urdf` on `text`: refused with the needles named, nothing written.
fn import_refused(text: &str, needles: &[&str]) -> String {
    let dir = tempfile::tempdir().unwrap();
    let f = write(dir.path(), "robot.urdf", text);
    let out = dir.path().join("r.toml");
    let e = refused(&["import", "--urdf", s(&f), "--out", s(&out)], needles);
    assert!(!out.exists());
    e
}

/// A device node made with `mknod` in `dir` (a private `/dev/null` or `/dev/full`), `None`
/// where this process may not make one (not root).
fn device(dir: &Path, name: &str, minor: &str) -> Option<PathBuf> {
    let p = dir.join(name);
    let ok = Command::new("mknod")
        .args([s(&p), "c", "1", minor])
        .status()
        .is_ok_and(|st| st.success());
    ok.then_some(p)
}

fn is_char_device(p: &Path) -> bool {
    use std::os::unix::fs::FileTypeExt;
    std::fs::metadata(p).is_ok_and(|m| m.file_type().is_char_device())
}

#[test]
fn out_to_a_device_writes_into_it_and_reports_write_errors() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = write(dir.path(), "arm.urdf", &arm("tool0", 0));
    let import = |out: &Path| kinecal(&["import", "--urdf", s(&urdf), "--out", s(out)]);
    // Private device nodes first (a regression replaces them, not the machine's); the real
    // ones only once those behaved.
    let (null, full) = match (
        device(dir.path(), "null", "3"),
        device(dir.path(), "full", "7"),
    ) {
        (Some(n), Some(f)) => (n, f),
        _ => {
            eprintln!("mknod not permitted: testing /dev/null and /dev/full as they are");
            (PathBuf::from("/dev/null"), PathBuf::from("/dev/full"))
        }
    };
    for null in [null, PathBuf::from("/dev/null")] {
        let o = import(&null);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(
            is_char_device(&null),
            "{} is still a device",
            null.display()
        );
        let model = dir.path().join("m.toml");
        if !model.exists() {
            assert!(import(&model).status.success());
        }
        let o = kinecal(&[
            "export",
            "--model",
            s(&model),
            "--format",
            "dh-table",
            "--out",
            s(&null),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(
            is_char_device(&null),
            "{} is still a device",
            null.display()
        );
    }
    for full in [full, PathBuf::from("/dev/full")] {
        let o = import(&full);
        let e = stderr(&o);
        assert!(!o.status.success(), "a full device is an error");
        assert_eq!(e.trim_end().lines().count(), 1, "one line: {e}");
        assert!(e.contains("space"), "{e}");
        assert!(is_char_device(&full));
    }
}

#[test]
fn out_through_a_symbolic_link_keeps_the_link() {
    let dir = tempfile::tempdir().unwrap();
    let urdf = write(dir.path(), "arm.urdf", &arm("tool0", 0));
    // A link to a regular file: the file it points to gets the model, the link stays.
    let real = write(dir.path(), "real.toml", "old");
    let link = dir.path().join("link.toml");
    std::os::unix::fs::symlink(&real, &link).unwrap();
    kinecal_ok(&["import", "--urdf", s(&urdf), "--out", s(&link)]);
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    let text = std::fs::read_to_string(&real).unwrap();
    assert!(text.contains("[[joints]]"), "{text}");
    // A link to the process's standard output (what /dev/stdout is), here a pipe: the model
    // is written into the pipe, the link stays.
    let stdout = dir.path().join("stdout");
    std::os::unix::fs::symlink("/proc/self/fd/1", &stdout).unwrap();
    let o = kinecal_ok(&["import", "--urdf", s(&urdf), "--out", s(&stdout)]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(text.contains("[[joints]]"), "{text}");
    assert!(std::fs::symlink_metadata(&stdout)
        .unwrap()
        .file_type()
        .is_symlink());
}

#[test]
fn urdf_that_is_no_tree_is_refused_naming_the_link() {
    // Two fixed joints A→B and B→A beside a proper arm.
    let cycle = arm("tool0", 0).replace(
        "</robot>",
        "<link name=\"A\"/><link name=\"B\"/>\
         <joint name=\"ab\" type=\"fixed\"><parent link=\"A\"/><child link=\"B\"/></joint>\
         <joint name=\"ba\" type=\"fixed\"><parent link=\"B\"/><child link=\"A\"/></joint></robot>",
    );
    import_refused(&cycle, &["cycle"]);
    // A 30-level diamond: every link of a level the child of both links of the level above.
    let mut diamond = String::from("<robot name=\"d\"><link name=\"root\"/>");
    let mut above = vec!["root".to_string()];
    for level in 0..30 {
        let here = vec![format!("a{level}"), format!("b{level}")];
        for (k, l) in here.iter().enumerate() {
            diamond.push_str(&format!("<link name=\"{l}\"/>"));
            for (m, p) in above.iter().enumerate() {
                diamond.push_str(&format!(
                    "<joint name=\"j{level}_{k}_{m}\" type=\"revolute\"><parent link=\"{p}\"/><child link=\"{l}\"/><axis xyz=\"0 0 1\"/></joint>"
                ));
            }
        }
        above = here;
    }
    diamond.push_str("</robot>");
    import_refused(&diamond, &["several parents", "a1"]);
    // A joint whose parent is a link the file does not declare.
    import_refused(
        &arm("tool0", 0).replace("<parent link=\"l2\"/>", "<parent link=\"ghost\"/>"),
        &["ghost", "j3"],
    );
    // A link declared twice; a joint name used twice.
    import_refused(
        &arm("tool0", 0).replace(
            "<link name=\"l3\"/>",
            "<link name=\"l3\"/><link name=\"l3\"/>",
        ),
        &["'l3'", "twice"],
    );
    import_refused(
        &arm("tool0", 0).replace("<joint name=\"j4\"", "<joint name=\"j2\""),
        &["'j2'", "twice"],
    );
}

#[test]
fn urdf_limits_crossed_and_rotations_out_of_range_are_refused() {
    let crossed = arm("tool0", 0).replacen(
        "<limit lower=\"-3\" upper=\"3\"",
        "<limit lower=\"1\" upper=\"-1\"",
        1,
    );
    import_refused(&crossed, &["j1", "limit lower = 1 is above upper = -1"]);
    let huge = arm("tool0", 0).replacen("rpy=\"0 0 0\"", "rpy=\"1e308 0 0\"", 1);
    import_refused(&huge, &["j1", "no rotation in radians"]);
}

#[test]
fn deeply_nested_or_attribute_laden_xml_is_refused() {
    let n = 13_000;
    let deep = format!(
        "<robot name=\"r\">{}{}</robot>",
        "<a>".repeat(n),
        "</a>".repeat(n)
    );
    import_refused(&deep, &["nested"]);
    let mut many = String::from("<robot name=\"r\"><link name=\"x\"");
    for k in 0..300_000 {
        many.push_str(&format!(" a{k}=\"\""));
    }
    many.push_str("/></robot>");
    import_refused(&many, &["attributes"]);
    // A file larger than any URDF: refused without being read (a sparse file).
    let dir = tempfile::tempdir().unwrap();
    let huge = dir.path().join("huge.urdf");
    std::fs::File::create(&huge)
        .unwrap()
        .set_len(3 << 30)
        .unwrap();
    refused(
        &[
            "import",
            "--urdf",
            s(&huge),
            "--out",
            s(&dir.path().join("r.toml")),
        ],
        &["larger than"],
    );
}

#[test]
fn a_long_chain_of_fixed_joints_imports() {
    let dir = tempfile::tempdir().unwrap();
    let text = arm("tool0", 4000);
    assert!(text.len() > 400_000);
    let urdf = write(dir.path(), "long.urdf", &text);
    let out = dir.path().join("r.toml");
    let t = Instant::now();
    kinecal_ok(&["import", "--urdf", s(&urdf), "--out", s(&out)]);
    eprintln!("import of {} bytes: {:?}", text.len(), t.elapsed());
    let t = Instant::now();
    kinecal_ok(&[
        "export",
        "--model",
        s(&out),
        "--urdf",
        s(&urdf),
        "--out",
        s(&dir.path().join("e.urdf")),
    ]);
    eprintln!("export: {:?}", t.elapsed());
}

/// Imports `text`, exports the imported model into it and returns the exported text, checked
/// to read back as a URDF.
fn export_round_trip(text: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let urdf = write(dir.path(), "arm.urdf", text);
    let model = dir.path().join("m.toml");
    kinecal_ok(&["import", "--urdf", s(&urdf), "--out", s(&model)]);
    let out = dir.path().join("e.urdf");
    kinecal_ok(&[
        "export",
        "--model",
        s(&model),
        "--urdf",
        s(&urdf),
        "--out",
        s(&out),
    ]);
    let written = std::fs::read_to_string(&out).unwrap();
    urdf_rs::read_from_string(&written)
        .unwrap_or_else(|e| panic!("the export is a URDF ({e}):\n{written}"));
    // And kinecal reads it back to the same chain.
    let again = dir.path().join("again.toml");
    kinecal_ok(&[
        "import",
        "--urdf",
        s(&out),
        "--tip-link",
        "kinecal_tool",
        "--out",
        s(&again),
    ]);
    written
}

#[test]
fn export_writes_well_formed_xml_whatever_the_quoting_and_names() {
    // Single-quoted origins without rpy (and without xyz), multibyte text around them.
    let text = arm("tool0", 0)
        .replace(
            "<origin xyz=\"0.16 0 0.1\" rpy=\"0 0 0\"/>",
            "<!-- épaule → bras --><origin xyz='0.16 0 0.1'/>",
        )
        .replace(
            "<origin xyz=\"0 0 0.78\" rpy=\"0 0 0\"/>",
            "<origin rpy='0 0 0' xyz='0 0 0.78' />",
        )
        .replace(
            "<origin xyz=\"0.15 0 0.15\" rpy=\"0 0 0\"/>",
            "<origin xyz=\"0.15 0 0.15\"/><!-- coude ∠ -->",
        );
    let written = export_round_trip(&text);
    assert!(written.contains("épaule → bras") && written.contains("coude ∠"));
    // A tip link whose name needs escaping.
    let written = export_round_trip(&arm("tool&amp;0", 0));
    let robot = urdf_rs::read_from_string(&written).unwrap();
    let tool = robot
        .joints
        .iter()
        .find(|j| j.name == "kinecal_tool_joint")
        .unwrap();
    assert_eq!(tool.parent.link, "tool&0");
    // Duplicate joint names in the file exported into: refused, nothing written.
    let dir = tempfile::tempdir().unwrap();
    let good = write(dir.path(), "arm.urdf", &arm("tool0", 0));
    let model = dir.path().join("m.toml");
    kinecal_ok(&["import", "--urdf", s(&good), "--out", s(&model)]);
    let dup = write(
        dir.path(),
        "dup.urdf",
        &arm("tool0", 0)
            .replace("<joint name=\"j5\"", "<joint name=\"j3\"")
            .replace(
                "<robot name=\"arm\">",
                "<robot name=\"arm\"><!-- ünïcødé -->",
            ),
    );
    let out = dir.path().join("e.urdf");
    refused(
        &[
            "export",
            "--model",
            s(&model),
            "--urdf",
            s(&dup),
            "--out",
            s(&out),
        ],
        &["'j3'"],
    );
    assert!(!out.exists());
}

#[test]
fn report_refuses_diagnose_figures_out_of_range() {
    let tmp = tempfile::tempdir().unwrap();
    let robot = write(tmp.path(), "robot.toml", ER20_PLACED);
    let data = tmp.path().join("d.csv");
    // A robot with errors: a fit to a robot that has none predicts new poses worse than its
    // file (kinecal identify refuses that on thin data).
    crate::common::simulate(
        &robot,
        Some(40),
        Some(0.01),
        Some(3),
        &["--geom-errors"],
        &data,
    );
    let model = tmp.path().join("m.toml");
    kinecal_ok(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--out",
        s(&model),
    ]);
    let out = tmp.path().join("r.html");
    for (name, json) in [
        (
            "rms.json",
            "{\"baseline_validation_rms_mm\":1.7e308,\"final_validation_rms_mm\":-1.7e308,\
             \"noise_floor_mm\":0.1,\"found\":[{\"effect\":\"joint-scale\",\"joint\":2,\
             \"values\":[0.001],\"validation_rms_mm\":1.7e308}]}",
        ),
        (
            "values.json",
            "{\"baseline_validation_rms_mm\":1,\"final_validation_rms_mm\":0.5,\
             \"noise_floor_mm\":0.1,\"found\":[{\"effect\":\"joint-cyclic\",\"joint\":2,\
             \"values\":[1.7e308,-1.7e308],\"validation_rms_mm\":0.5}]}",
        ),
    ] {
        let j = write(tmp.path(), name, json);
        refused(
            &[
                "report",
                "--robot",
                s(&robot),
                "--model",
                s(&model),
                "--data",
                s(&data),
                "--diagnose",
                s(&j),
                "--out",
                s(&out),
            ],
            &["range"],
        );
        assert!(!out.exists());
    }
    // 20,000 findings (a page of hundreds of megabytes): more than a model holds.
    let one =
        "{\"effect\":\"joint-scale\",\"joint\":2,\"values\":[0.001],\"validation_rms_mm\":0.5}";
    let many = format!(
        "{{\"baseline_validation_rms_mm\":1,\"final_validation_rms_mm\":0.5,\
         \"noise_floor_mm\":0.1,\"found\":[{}]}}",
        vec![one; 20_000].join(",")
    );
    let j = write(tmp.path(), "many.json", &many);
    refused(
        &[
            "report",
            "--robot",
            s(&robot),
            "--model",
            s(&model),
            "--data",
            s(&data),
            "--diagnose",
            s(&j),
            "--out",
            s(&out),
        ],
        &["20000 findings", "more than a model holds"],
    );
    assert!(!out.exists());
}

#[test]
fn usage_errors_with_json_print_one_json_error() {
    let tmp = tempfile::tempdir().unwrap();
    let robot = write(tmp.path(), "robot.toml", ER20_PLACED);
    let data = tmp.path().join("d.csv");
    crate::common::simulate(&robot, Some(20), Some(0.01), Some(3), &[], &data);
    let (r, d) = (s(&robot), s(&data));
    let out = s(&tmp.path().join("m.toml")).to_string();
    let cases: [Vec<&str>; 4] = [
        vec![
            "identify",
            "--robot",
            r,
            "--data",
            d,
            "--holdout",
            "-1",
            "--json",
        ],
        vec![
            "identify", "--robot", r, "--data", d, "--method", "nope", "--json",
        ],
        vec!["identify", "--robot", r, "--data", d, "--out", "", "--json"],
        vec![
            "simulate",
            "--robot",
            r,
            "--effect",
            "joint-cyclic:2:65",
            "--out",
            &out,
            "--json",
        ],
    ];
    for args in cases {
        let o = kinecal(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        let text = String::from_utf8(o.stdout.clone()).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text)
            .unwrap_or_else(|e| panic!("{args:?}: stdout is one JSON object ({e}): {text}"));
        let error = v["error"]
            .as_str()
            .unwrap_or_else(|| panic!("{args:?}: {v}"));
        assert!(
            !error.is_empty() && !error.contains('\n'),
            "{args:?}: {error}"
        );
        assert_eq!(v.as_object().unwrap().len(), 1, "{args:?}: {v}");
    }
}

#[test]
fn oversized_or_endless_small_inputs_are_refused_without_reading_them_whole() {
    let dir = tempfile::tempdir().unwrap();
    let huge = dir.path().join("huge");
    std::fs::File::create(&huge)
        .unwrap()
        .set_len(3 << 30)
        .unwrap();
    let out = dir.path().join("t.csv");
    for model in [huge.as_path(), Path::new("/dev/zero")] {
        refused(
            &[
                "export",
                "--model",
                s(model),
                "--format",
                "dh-table",
                "--out",
                s(&out),
            ],
            &["larger than", "robot file"],
        );
    }
    // The report's diagnose JSON, the same way.
    let robot = write(dir.path(), "robot.toml", ER20_PLACED);
    let data = dir.path().join("d.csv");
    crate::common::simulate(&robot, Some(20), Some(0.01), Some(3), &[], &data);
    refused(
        &[
            "report",
            "--robot",
            s(&robot),
            "--model",
            s(&robot),
            "--data",
            s(&data),
            "--diagnose",
            s(&huge),
            "--out",
            s(&dir.path().join("r.html")),
        ],
        &["larger than"],
    );
}
