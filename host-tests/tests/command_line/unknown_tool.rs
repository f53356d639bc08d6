//! A tool point nobody measured, said so in the robot file (`[tool] xyz_mm = "unknown"`, or a
//! `[tool]` without `xyz_mm`): `check` and `identify` start it from the data, nothing calls it
//! suspicious, the "before" figures are those of the started point, and `check`'s coupling
//! hint still finds a missing coupling.

use crate::common::{data_file, json_of, kinecal, kinecal_ok, s, simulate, stderr, write};
use std::path::Path;

/// Where the reflector really is (mm, flange frame): a quarter metre from the flange.
const TRUE_TOOL: [f64; 3] = [30.0, -20.0, 250.0];

/// The ER20 file with its `[tool]` table's `xyz_mm` line replaced by `tool_line`.
fn er20_with_tool(tool_line: &str) -> String {
    let text = std::fs::read_to_string(data_file("er20.toml")).unwrap();
    let old = "[tool]\nxyz_mm = [0.0, 0.0, 100.0]\n";
    assert!(text.contains(old));
    text.replace(old, &format!("[tool]\n{tool_line}"))
}

/// Data of the ER20 with the true tool and geometric errors.
fn measured(dir: &Path) -> std::path::PathBuf {
    let [x, y, z] = TRUE_TOOL;
    let truth = write(
        dir,
        "truth.toml",
        &er20_with_tool(&format!("xyz_mm = [{x:?}, {y:?}, {z:?}]\n")),
    );
    let data = dir.join("data.csv");
    simulate(
        &truth,
        Some(60),
        Some(0.01),
        Some(5),
        &["--geom-errors"],
        &data,
    );
    data
}

#[test]
fn an_unknown_tool_is_started_from_the_data_and_not_suspicious() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let data = measured(d);
    for (name, line) in [("word.toml", "xyz_mm = \"unknown\"\n"), ("empty.toml", "")] {
        let robot = write(d, name, &er20_with_tool(line));
        let c = json_of(&kinecal_ok(&[
            "check",
            "--robot",
            s(&robot),
            "--data",
            s(&data),
            "--json",
        ]));
        let started = c["tool_started_mm"].as_array().expect("tool_started_mm");
        for (a, t) in started.iter().zip(TRUE_TOOL) {
            // The geometric errors (±0.8 mm, ±0.1°) move the start, not by centimetres.
            assert!((a.as_f64().unwrap() - t).abs() < 10.0, "{name}: {c}");
        }
        let nominal = c["nominal_rms_mm"].as_f64().unwrap();
        assert!(
            nominal < 10.0,
            "{name}: nominal {nominal} mm with the started tool"
        );
        let o = kinecal(&[
            "identify",
            "--robot",
            s(&robot),
            "--data",
            s(&data),
            "--json",
        ]);
        assert!(o.status.success(), "{name}: {}", stderr(&o));
        let v = json_of(&o);
        assert_eq!(v["tool_unknown"], true, "{name}");
        let suspicious = v["suspicious"].as_array().unwrap();
        assert!(
            !suspicious
                .iter()
                .any(|p| p.as_str().unwrap().starts_with("tool.")),
            "{name}: {suspicious:?}"
        );
        let before = v["before"]["identification_rms_mm"].as_f64().unwrap();
        // Not the quarter metre of a tool taken as [0, 0, 0].
        assert!(before < 10.0, "{name}: before {before} mm");
        for (k, t) in ["tool.x", "tool.y", "tool.z"].iter().zip(TRUE_TOOL) {
            let got = v["parameters"][k].as_f64().unwrap();
            assert!((got - t).abs() < 2.0, "{name}: {k} = {got}, true {t}");
        }
        // The text says why "before" is what it is.
        let o = kinecal_ok(&["identify", "--robot", s(&robot), "--data", s(&data)]);
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(text.contains("the tool point was unknown"), "{text}");
    }
    // A word that is not "unknown" is refused, saying what to write.
    let robot = write(d, "bad.toml", &er20_with_tool("xyz_mm = \"unkown\"\n"));
    let o = kinecal(&["check", "--robot", s(&robot), "--data", s(&data)]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("\"unknown\""), "{}", stderr(&o));
}

#[test]
fn the_coupling_hint_works_with_an_unknown_tool() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let fanuc = std::fs::read_to_string(data_file("fanuc_j3_horizontal.toml")).unwrap();
    let coupled = write(
        d,
        "coupled.toml",
        &format!("{fanuc}\n[[couplings]]\njoint = 3\nfrom = 2\nratio = 1.0\n"),
    );
    let data = d.join("d.csv");
    simulate(
        &coupled,
        Some(150),
        Some(0.02),
        None,
        &["--geom-errors"],
        &data,
    );
    let old = "[tool]\nxyz_mm = [15.0, -10.0, 120.0]\n";
    assert!(fanuc.contains(old));
    let plain = write(
        d,
        "plain.toml",
        &fanuc.replace(old, "[tool]\nxyz_mm = \"unknown\"\n"),
    );
    let v = json_of(&kinecal_ok(&[
        "check",
        "--robot",
        s(&plain),
        "--data",
        s(&data),
        "--json",
    ]));
    assert_eq!(v["coupling_hint"]["joint"], 3, "{v}");
    assert_eq!(v["coupling_hint"]["from"], 2, "{v}");
}

/// A robot file with an unknown tool written back (`identify --out`, `diagnose --out`, the
/// fuzz target's round trip) keeps `xyz_mm = "unknown"`: the zeros it holds in memory read
/// back as a measured point at the flange (the robot_file fuzz target's reproducer in
/// fuzz/regressions/robot_file/).
#[test]
fn an_unknown_tool_is_written_back_as_unknown() {
    use kinecal_cli::formats::robot_file::RobotFile;
    for line in ["xyz_mm = \"unknown\"\n", "rpy_deg = [0.0, 0.0, 90.0]\n"] {
        let file = RobotFile::parse(&er20_with_tool(line), "er20").unwrap();
        assert!(file.tool.unknown);
        let text = file.to_toml().unwrap();
        assert!(text.contains("xyz_mm = \"unknown\""), "{text}");
        let back = RobotFile::parse(&text, "written").unwrap();
        assert_eq!(back, file);
    }
    // A measured point stays a point.
    let file = RobotFile::parse(&er20_with_tool("xyz_mm = [1.0, 2.0, 3.0]\n"), "er20").unwrap();
    let back = RobotFile::parse(&file.to_toml().unwrap(), "written").unwrap();
    assert!(!back.tool.unknown);
    assert_eq!(back, file);
}

/// A robot file whose tool is unknown exported as if it were the model: every format wrote the
/// tool at the flange as "the whole model" (exit 0), and `compensate` aimed the flange at the
/// targets (exit 3, a hint about frames). Refused, naming the model to use; the model identify
/// writes from it exports.
#[test]
fn a_robot_file_with_an_unknown_tool_is_not_exported() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = write(d, "r.toml", &er20_with_tool("xyz_mm = \"unknown\"\n"));
    for format in ["firmware", "dh-table"] {
        let out = d.join(format!("o.{format}"));
        let args = ["export", "--model", s(&robot), "--format", format];
        let r = kinecal(&[&args[..], &["--out", s(&out)]].concat());
        let err = stderr(&r);
        assert_eq!(r.status.code(), Some(2), "{format}: {err}");
        assert!(
            err.contains("is \"unknown\"") && err.contains("export the model identify wrote"),
            "{err}"
        );
        assert!(!out.exists());
    }
    let targets = write(
        d,
        "t.csv",
        "q1,q2,q3,q4,q5,q6,x,y,z\n0,-40,50,0,60,0,900,0,900\n",
    );
    let args = ["compensate", "--model", s(&robot), "--targets", s(&targets)];
    let r = kinecal(&[&args[..], &["--out", s(&d.join("q.csv"))]].concat());
    assert_eq!(r.status.code(), Some(2), "{}", stderr(&r));
    assert!(
        stderr(&r).contains("compensate with the model identify wrote"),
        "{}",
        stderr(&r)
    );
    let model = d.join("m.toml");
    let data = measured(d);
    kinecal_ok(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--out",
        s(&model),
    ]);
    let out = d.join("m.kcm");
    kinecal_ok(&[
        "export",
        "--model",
        s(&model),
        "--format",
        "firmware",
        "--out",
        s(&out),
    ]);
}
