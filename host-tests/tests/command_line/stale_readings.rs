//! Readings that did not update (docs/formats.md, "Stale readings"): a row that repeats an
//! earlier row's measured point to the last digit although the robot moved, or the row before's
//! joint readings although the tracker saw the tool elsewhere, is left out with a warning naming its
//! line, and the commands compute exactly what they compute on the file without it; so is a
//! row that repeats an earlier one entirely (a copy). A pose measured twice is kept.

use crate::common::*;

/// A simulated session (ER20, 200 poses, noise 0.01 mm, geometric errors).
fn session(dir: &std::path::Path) -> (std::path::PathBuf, Vec<String>) {
    let data = dir.join("session.csv");
    let robot = data_file("er20.toml");
    simulate(
        &robot,
        Some(200),
        Some(0.01),
        Some(31),
        &["--geom-errors"],
        &data,
    );
    let lines = std::fs::read_to_string(&data)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect();
    (data, lines)
}

/// Line `k` (1-based, the header is line 1) with its x, y, z cells replaced by line `from`'s.
fn with_point_of(lines: &[String], k: usize, from: usize) -> String {
    let cells: Vec<&str> = lines[k - 1].split(',').collect();
    let source: Vec<&str> = lines[from - 1].split(',').collect();
    let n = cells.len();
    let mut out: Vec<&str> = cells[..n - 3].to_vec();
    out.extend_from_slice(&source[n - 3..]);
    out.join(",")
}

#[test]
fn a_stale_reading_is_left_out_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let (_, lines) = session(dir.path());
    assert_eq!(lines[0], "q1,q2,q3,q4,q5,q6,x,y,z", "{}", lines[0]);
    // Lines 50 and 51 repeat the point of line 49 (a run), line 121 that of line 120, line 160
    // the joints of line 159; line 181 the point of line 180 with q2 half a degree on (under
    // the 1° of a turned joint: the nominal tool moved millimetres).
    let mut stale = lines.clone();
    stale[49] = with_point_of(&lines, 50, 49);
    stale[50] = with_point_of(&lines, 51, 49);
    stale[120] = with_point_of(&lines, 121, 120);
    stale[159] = with_point_of(&lines, 159, 160);
    let mut cells: Vec<String> = lines[179].split(',').map(str::to_string).collect();
    cells[1] = format!("{:.6}", cells[1].parse::<f64>().unwrap() + 0.5);
    stale[180] = cells.join(",");
    // Line 191 takes line 100's point, far from its neighbours.
    stale[190] = with_point_of(&lines, 191, 100);
    let stale_file = write(dir.path(), "stale.csv", &(stale.join("\n") + "\n"));
    // The same file without those six rows.
    let clean: Vec<String> = stale
        .iter()
        .enumerate()
        .filter(|(i, _)| ![49, 50, 120, 159, 180, 190].contains(i))
        .map(|(_, l)| l.clone())
        .collect();
    let clean_file = write(dir.path(), "clean.csv", &(clean.join("\n") + "\n"));
    let robot = data_file("er20.toml");
    let args = ["--json", "--holdout", "0.2", "--split", "every:5"];
    let out = run_on("identify", &robot, &stale_file, &args);
    let warned = stderr(&out);
    eprintln!("{warned}");
    assert!(
        warned.contains("6 row(s) repeat an earlier row's reading")
            && warned.contains("line 50 repeats line 49's point, joint")
            && warned.contains("line 51 repeats line 49's point, joint")
            && warned.contains("line 121 repeats line 120's point, joint")
            && warned.contains("line 160 repeats line 159's joint readings, the point")
            && warned.contains("line 181 repeats line 180's point, joint 2 0.500° away")
            && warned.contains("; 1 more)")
            && warned.contains("left out"),
        "{warned}"
    );
    assert_eq!(warned.matches("warning:").count(), 1, "{warned}");
    let v = json_of(&out);
    let c = json_of(&run_on("identify", &robot, &clean_file, &args));
    assert!(
        !stderr(&run_on("identify", &robot, &clean_file, &args)).contains("repeat"),
        "the clean file is not warned about"
    );
    for key in ["n_identification", "n_validation"] {
        assert_eq!(v[key], c[key], "{key}: {v} {c}");
    }
    let n = |k: &str| v[k].as_u64().unwrap();
    assert_eq!(n("n_identification") + n("n_validation"), 194);
    for phase in ["before", "after"] {
        for key in ["identification_rms_mm", "validation_rms_mm"] {
            assert_eq!(v[phase][key], c[phase][key], "{phase}.{key}");
        }
    }
    assert_eq!(v["parameters"], c["parameters"]);
    let checked = json_of(&run_on("check", &robot, &stale_file, &["--json"]));
    assert_eq!(checked["poses"], 194, "{checked}");
}

#[test]
fn a_pose_measured_twice_is_kept() {
    let dir = tempfile::tempdir().unwrap();
    let (_, lines) = session(dir.path());
    // Line 80 measured again: the same point, the joints a ten-thousandth of a degree apart
    // (the last digit the file keeps moves).
    let cells: Vec<String> = lines[79].split(',').map(str::to_string).collect();
    let mut nudged = cells.clone();
    let q1: f64 = cells[0].parse().unwrap();
    nudged[0] = format!("{}", q1 + 1e-4);
    // And at the very same joint readings, the point 0.05 mm further along x (the robot's
    // repeatability and the tracker's noise).
    let mut again = cells.clone();
    let n = cells.len();
    let x: f64 = cells[n - 3].parse().unwrap();
    again[n - 3] = format!("{}", x + 0.05);
    let mut twice = lines.clone();
    twice.insert(80, nudged.join(","));
    twice.insert(81, again.join(","));
    let file = write(dir.path(), "twice.csv", &(twice.join("\n") + "\n"));
    let out = run_on("check", &data_file("er20.toml"), &file, &["--json"]);
    assert!(!stderr(&out).contains("repeat"), "{}", stderr(&out));
    assert_eq!(json_of(&out)["poses"], 202);
}

/// A row equal to an earlier one in its joint readings and its point is a copy (no two real
/// readings agree to the last digit): rows pasted twice, or the file appended to itself, are
/// left out with a warning naming them, and `identify` and `diagnose` compute what they compute
/// on the file without them. Kept, the copies gave `diagnose` a noise floor of 0 mm "from the
/// scatter of the repeated poses".
#[test]
fn copied_rows_are_left_out_and_named() {
    let dir = tempfile::tempdir().unwrap();
    let (clean, lines) = session(dir.path());
    let mut pasted = lines.clone();
    for k in [150, 90, 30] {
        pasted.insert(k + 1, lines[k].clone());
    }
    let pasted = write(dir.path(), "pasted.csv", &(pasted.join("\n") + "\n"));
    let appended = [&lines[..], &lines[1..]].concat();
    let appended = write(dir.path(), "appended.csv", &(appended.join("\n") + "\n"));
    let robot = data_file("er20.toml");
    for (file, named, count) in [
        (&pasted, "line 32 repeats line 31 entirely", 3),
        (&appended, "line 202 repeats line 2 entirely", 200),
    ] {
        let args = ["--json", "--holdout", "0.2", "--split", "every:5"];
        let out = run_on("identify", &robot, file, &args);
        let warned = stderr(&out);
        assert!(
            warned.contains(&format!("{count} row(s) repeat an earlier row's reading"))
                && warned.contains(named)
                && warned.contains("copies of a row")
                && warned.contains("left out"),
            "{warned}"
        );
        let (v, c) = (
            json_of(&out),
            json_of(&run_on("identify", &robot, &clean, &args)),
        );
        for phase in ["before", "after"] {
            for key in ["identification_rms_mm", "validation_rms_mm"] {
                assert_eq!(v[phase][key], c[phase][key], "{phase}.{key}");
            }
        }
        let d = json_of(&run_on("diagnose", &robot, file, &["--json"]));
        let dc = json_of(&run_on("diagnose", &robot, &clean, &["--json"]));
        assert!(d["noise_floor_mm"].as_f64().unwrap() > 0.005, "{d}");
        assert_eq!(d["noise_floor_mm"], dc["noise_floor_mm"]);
        assert_eq!(d["final_validation_rms_mm"], dc["final_validation_rms_mm"]);
    }
}

/// A file whose rows are all one row's copies leaves one pose: `check` refuses it (exit 2) as
/// `identify` and `diagnose` do; it used to exit 1, as for a fault of its own.
#[test]
fn a_file_of_one_row_copied_is_refused_by_check_too() {
    let dir = tempfile::tempdir().unwrap();
    let robot = crate::common::ur10_dir().join("robot.toml");
    let first = std::fs::read_to_string(crate::common::ur10_dir().join("ur10_random_poses.csv"))
        .unwrap()
        .lines()
        .nth(1)
        .unwrap()
        .to_string();
    let data = crate::common::ur10_rows(dir.path(), "same.csv", 50, |_, cells| {
        *cells = first.split(',').map(String::from).collect();
    });
    for command in ["check", "identify", "diagnose"] {
        let out = crate::common::run_on(command, &robot, &data, &[]);
        assert_eq!(
            out.status.code(),
            Some(2),
            "{command}: {}",
            crate::common::stderr(&out)
        );
    }
}
