//! `--map` on every subcommand that reads measurements, sweeps or targets: each file rewritten
//! in a vendor layout (`;`, decimal commas, the tracker's column names) and read with a map
//! gives the same report as the file in kinecal's layout. (Units through a map are the
//! vendor_files tests'; here the cells stay the same digits so the reports agree bit for bit.)

use crate::common::{kinecal, run_on, s, simulate, stderr, write, ER20_PLACED};
use std::path::{Path, PathBuf};

/// `file` (kinecal's layout, comma-separated) rewritten as a vendor writes it: `;`-separated,
/// decimal commas, every column renamed `V_<name>`; and the map that reads it back.
fn vendor(dir: &Path, file: &Path) -> (PathBuf, PathBuf) {
    let text = std::fs::read_to_string(file).unwrap();
    let mut lines = text
        .lines()
        .filter(|l| !l.is_empty() && !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let mut out = header
        .iter()
        .map(|c| format!("V_{c}"))
        .collect::<Vec<_>>()
        .join(";");
    out.push('\n');
    for l in lines {
        let cells: Vec<String> = l.split(',').map(|v| v.replace('.', ",")).collect();
        out.push_str(&cells.join(";"));
        out.push('\n');
    }
    let mut map = String::from("delimiter = \";\"\ndecimal = \",\"\n[columns]\n");
    for c in &header {
        map.push_str(&format!("{c} = \"V_{c}\"\n"));
    }
    let name = file.file_stem().unwrap().to_string_lossy().to_string();
    (
        write(dir, &format!("{name}.vendor.csv"), &out),
        write(dir, &format!("{name}.map.toml"), &map),
    )
}

/// The JSON of `args` with `file` and of the same with the vendor file and `--map`; both
/// succeed, and they agree but for paths and timings.
fn same_with_map(dir: &Path, args: &[&str], flag: &str, file: &Path) {
    let (v, map) = vendor(dir, file);
    let run = |data: &Path, extra: &[&str]| {
        let mut a: Vec<&str> = args.to_vec();
        a.extend([flag, s(data)]);
        a.extend_from_slice(extra);
        a.push("--json");
        let o = kinecal(&a);
        assert!(o.status.success(), "{a:?}: {}", stderr(&o));
        // Timings differ at any depth (`seconds`, `microseconds_per_target`), and paths (the
        // two files) at the top.
        let mut j = crate::common::json_without_timings(&o);
        if let Some(m) = j.as_object_mut() {
            m.retain(|_, v| !v.as_str().is_some_and(|t| t.contains(s(dir))));
        }
        j
    };
    let plain = run(file, &[]);
    let mapped = run(&v, &["--map", s(&map)]);
    assert_eq!(plain, mapped, "{args:?}");
}

#[test]
fn every_reader_takes_a_map() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = write(d, "er20.toml", ER20_PLACED);
    let data = d.join("data.csv");
    simulate(
        &robot,
        Some(30),
        Some(0.01),
        Some(3),
        &["--geom-errors"],
        &data,
    );
    let r = s(&robot);
    same_with_map(d, &["check", "--robot", r], "--data", &data);
    same_with_map(d, &["identify", "--robot", r], "--data", &data);
    // validate: the robot file is the model, so the session is of the robot it describes (with
    // the geometric errors a calibration finds, validate would say it changed since).
    let same = d.join("same.csv");
    simulate(&robot, Some(30), Some(0.01), Some(3), &[], &same);
    same_with_map(
        d,
        &["validate", "--robot", r, "--model", r],
        "--data",
        &same,
    );
    // Sweeps.
    let sweeps = d.join("sweeps.csv");
    simulate(
        &robot,
        None,
        Some(0.01),
        Some(4),
        &["--sweeps", "1,2,5,6", "--sweep-points", "12"],
        &sweeps,
    );
    same_with_map(d, &["frames", "--robot", r], "--data", &sweeps);
    // Targets: the measured points.
    let text = std::fs::read_to_string(&data).unwrap();
    let targets = write(d, "targets.csv", &text);
    let out = d.join("q.csv");
    same_with_map(
        d,
        &["compensate", "--model", r, "--out", s(&out)],
        "--targets",
        &targets,
    );
    // The stated σ of plan --noise-from.
    let mut sig = String::new();
    for (k, l) in text.lines().filter(|l| !l.starts_with('#')).enumerate() {
        sig.push_str(l);
        sig.push_str(if k == 0 {
            ",sx_mm,sy_mm,sz_mm\n"
        } else {
            ",0.02,0.03,0.04\n"
        });
    }
    let sig = write(d, "sigma.csv", &sig);
    let plan_out = d.join("plan.csv");
    same_with_map(
        d,
        &[
            "plan",
            "--robot",
            r,
            "--poses",
            "12",
            "--criterion",
            "random",
            "--work=0,-30,30,0,30,0",
            "--out",
            s(&plan_out),
        ],
        "--noise-from",
        &sig,
    );
}

/// Slips of a map that used to pass or end in an internal error: one file column read as two
/// joints (check exit 0 at 568 mm), and `[units] length = "m"` on millimetres (exit 1,
/// "estimated base pose is invalid: OutOfRange"). Both are refused (exit 2) by every command
/// that reads the data, saying what to correct.
#[test]
fn a_map_reading_one_column_twice_or_the_wrong_unit_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = crate::common::ur10_dir().join("robot.toml");
    let data = crate::common::ur10_rows(d, "d.csv", 100, |_, _| {});
    let twice = write(d, "twice.toml", "[columns]\nq1 = \"q1\"\nq2 = \"q1\"\n");
    let metres = write(d, "metres.toml", "[units]\nlength = \"m\"\n");
    let inches = write(d, "inches.toml", "[units]\nlength = \"in\"\n");
    for (map, says) in [
        (&twice, "q1 and q2 name the same column"),
        (&metres, "not in the length unit stated"),
        (&inches, "inches: multiply x, y, z by 25.4"),
    ] {
        for command in ["check", "identify", "diagnose", "validate"] {
            let mut args = vec![
                command,
                "--robot",
                s(&robot),
                "--data",
                s(&data),
                "--map",
                s(map),
            ];
            if command == "validate" {
                args.extend(["--model", s(&robot)]);
            }
            let out = kinecal(&args);
            let err = stderr(&out);
            assert_eq!(out.status.code(), Some(2), "{command} {map:?}: {err}");
            assert!(err.contains(says), "{command} {map:?}: {err}");
        }
    }
}

/// A header that names a column twice (`X;Y;Z;X;Y;Z`: a tracker's nominal and measured
/// point) used to be read at its first column in silence; a file without a header read with
/// a map that expects one lost its first pose as the "names". Both are refused (exit 2): the
/// first naming both columns, the second saying `header = false`. A cell like `-3,241` is
/// called what it may be, a decimal comma or a comma grouping thousands.
#[test]
fn a_header_that_names_a_column_twice_or_is_numbers_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = crate::common::ur10_dir().join("robot.toml");
    let data = crate::common::ur10_rows(d, "d.csv", 30, |_, _| {});
    let text = std::fs::read_to_string(&data).unwrap();
    let body: Vec<&str> = text.lines().skip(1).collect();
    // Nominal and measured point under the same names; the map names them.
    let twice_text = std::iter::once("q1,q2,q3,q4,q5,q6,X,Y,Z,temp_c,X,Y,Z".to_string())
        .chain(body.iter().map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            format!("{l},{},{},{}", c[6], c[7], c[8])
        }))
        .collect::<Vec<_>>()
        .join("\n");
    let twice = write(d, "twice.csv", &twice_text);
    let xyz = write(
        d,
        "xyz.toml",
        "[columns]\nx = \"X\"\ny = \"Y\"\nz = \"Z\"\n",
    );
    // The same rows without their header line.
    let bare = write(d, "bare.csv", &body.join("\n"));
    let numbered = write(
        d,
        "numbered.toml",
        "[columns]\nq1 = 1\nq2 = 2\nq3 = 3\nq4 = 4\nq5 = 5\nq6 = 6\nx = 7\ny = 8\nz = 9\n",
    );
    let grouped_text = format!(
        "q1;q2;q3;q4;q5;q6;x;y;z\n{}",
        body.iter()
            .map(|l| {
                let c: Vec<&str> = l.split(',').take(9).collect();
                let mut row = c.join(";");
                if c[7].starts_with("-3") {
                    row = row.replacen(c[7], "-3,241", 1);
                }
                row
            })
            .collect::<Vec<_>>()
            .join("\n")
    );
    assert!(grouped_text.contains("-3,241"));
    let grouped = write(d, "grouped.csv", &grouped_text);
    let semicolon = write(d, "semicolon.toml", "delimiter = \";\"\n");
    for (file, map, says) in [
        (&twice, &xyz, "names 2 columns \"X\" (columns 7 and 11)"),
        (&bare, &numbered, "the first line is numbers, not a header"),
        (&grouped, &semicolon, "a comma grouping thousands"),
    ] {
        let out = run_on("check", &robot, file, &["--map", s(map)]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{file:?}: {err}");
        assert!(err.contains(says), "{file:?}: {err}");
    }
    // With header = false the bare rows are read, every one of them.
    let bare_map = write(
        d,
        "bare.toml",
        &format!(
            "header = false\n{}",
            std::fs::read_to_string(&numbered).unwrap()
        ),
    );
    let out = run_on("check", &robot, &bare, &["--map", s(&bare_map), "--json"]);
    let v = crate::common::json_of(&out);
    assert_eq!(v["poses"], 30, "{v}");
}

/// A map key that is none of kinecal's column names (`temp` for `temp_c`, `X` for `x`, `sx_m`
/// for `sx_mm`) used to be carried along as an extra column, its values silently unread: the
/// temperature left out of a `thermal-expansion` fit, the σ out of the weights. It is refused
/// (exit 2) naming the key and the name it most likely meant (a name cut short first); a name
/// near none of kinecal's gets the list of them instead of a guess, and a target's `rx` in a
/// measurement file's map the measured name.
#[test]
fn a_map_key_kinecal_does_not_read_is_refused_with_the_name_meant() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = crate::common::ur10_dir().join("robot.toml");
    let data = crate::common::ur10_rows(d, "d.csv", 100, |_, _| {});
    for (key, says) in [
        ("temp", "did you mean temp_c?"),
        ("X", "did you mean x?"),
        ("sx_m", "did you mean sx_mm?"),
        ("foo", "its names are q1 … q6, x, y, z"),
        // A name cut short is nearer than another name one edit away (`rx`).
        ("srx", "did you mean srx_deg?"),
        ("rx", "use rx_deg as the key"),
        // A quaternion component is no typo of q1: named as one.
        ("qw", "a quaternion component"),
        ("Quat_X", "a quaternion component"),
    ] {
        let map = write(d, "m.toml", &format!("[columns]\n{key} = \"temp_c\"\n"));
        for command in ["check", "identify"] {
            let out = run_on(command, &robot, &data, &["--map", s(&map)]);
            let err = stderr(&out);
            assert_eq!(out.status.code(), Some(2), "{command} {key}: {err}");
            assert!(
                err.contains(&format!("[columns] {key}: ")) && err.contains(says),
                "{command} {key}: {err}"
            );
        }
    }
    // kinecal's own names pass: temp_c; the per-axis angle σ with the real 6-D rows; a further
    // reflector's x_NAME with [[tools]] naming it.
    let map = write(d, "ok.toml", "[columns]\ntemp_c = \"temp_c\"\n");
    let out = run_on("check", &robot, &data, &["--map", s(&map)]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let published = crate::common::ur10_dir().join("published");
    let out = run_on(
        "check",
        &robot,
        &published.join("measurements_random_poses_excerpt.csv"),
        &["--map", s(&published.join("ur10_series_c.map.toml"))],
    );
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let text = std::fs::read_to_string(&robot).unwrap();
    assert!(text.contains("[tool]\n"));
    let named = write(
        d,
        "named.toml",
        &text.replace("[tool]\n", "[[tools]]\nname = \"smr\"\n"),
    );
    let map = write(
        d,
        "smr.toml",
        "[columns]\nx_smr = \"x\"\ny_smr = \"y\"\nz_smr = \"z\"\n",
    );
    let out = run_on("check", &named, &data, &["--map", s(&map)]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
}
