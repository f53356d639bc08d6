//! A mistyped bar length (`cli/src/constraints/outliers.rs`): a ball-bar session of 60
//! distances with one length 10 mm off used to fit with exit 0, its model far worse than the
//! right session's, and `diagnose` said "nothing significant is missing" at 160× the noise
//! floor; 1 mm off, the same in silence. Now the first is no calibration (exit 3, its line
//! named), the second is warned about (the row, χ²/dof of the stated σ), and `diagnose` says
//! what it cannot explain.

use super::*;

/// `data` with `dl` mm added to the `length_mm` of distance group `group` (both rows).
fn with_length_off(dir: &Path, data: &Path, group: &str, dl: f64, name: &str) -> PathBuf {
    let text = std::fs::read_to_string(data).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let cols: Vec<&str> = header.split(',').collect();
    let (g, l) = (
        cols.iter().position(|c| *c == "group").unwrap(),
        cols.iter().position(|c| *c == "length_mm").unwrap(),
    );
    let mut out = format!("{header}\n");
    for line in lines {
        let mut cells: Vec<String> = line.split(',').map(String::from).collect();
        if cells[g] == group {
            cells[l] = format!("{:?}", cells[l].parse::<f64>().unwrap() + dl);
        }
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    write(dir, name, &out)
}

/// The first line of `group` in `data`.
fn first_line(data: &Path, group: &str) -> usize {
    let text = std::fs::read_to_string(data).unwrap();
    text.lines()
        .position(|l| l.split(',').nth(1) == Some(group))
        .unwrap()
        + 1
}

#[test]
fn a_mistyped_bar_length_is_refused_or_warned_and_a_clean_session_is_not() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "distance:60", 3);
    let robot = data_file("er20.toml");
    let line = first_line(&data, "d7");
    let run = |command: &str, data: &Path| {
        kinecal(&[command, "--robot", s(&robot), "--data", s(data), "--json"])
    };

    // The session as simulated: χ²/dof near 1 and not a word about its rows.
    for command in ["identify", "diagnose"] {
        let out = run(command, &data);
        assert_eq!(out.status.code(), Some(0), "{command}: {}", stderr(&out));
        let err = stderr(&out);
        assert!(
            !err.contains("point(s)") && !err.contains("χ²"),
            "{command}: {err}"
        );
    }
    let clean = json_of(&run("identify", &data));
    let chi2 = clean["chi2_per_dof"].as_f64().unwrap();
    assert!((0.5..2.0).contains(&chi2), "{chi2}");
    assert!(clean.get("stray_points").is_none(), "{clean}");

    // 10 mm off: no calibration, the group's line named, nothing diagnosed.
    let far = with_length_off(dir.path(), &data, "d7", 10.0, "far.csv");
    for command in ["identify", "diagnose"] {
        let out = run(command, &far);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(3), "{command}: {err}");
        assert!(
            err.contains("1 point(s) far from the model")
                && err.contains(&format!("line {line} "))
                && err.contains("mistyped length_mm"),
            "{command}: {err}"
        );
    }

    // 1 mm off: a calibration still, but the row is named and χ²/dof is far from 1; diagnose
    // says that no effect explains what is left.
    let near = with_length_off(dir.path(), &data, "d7", 1.0, "near.csv");
    let out = run("identify", &near);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(
        err.contains("1 point(s) lie far from the model")
            && err.contains(&format!("line {line} "))
            && err.contains("χ²/dof = "),
        "{err}"
    );
    let v = json_of(&out);
    assert_eq!(v["stray_points"]["rows"][0]["line"], line);
    assert!(v["chi2_per_dof"].as_f64().unwrap() > 10.0, "{v}");
    let out = kinecal(&["diagnose", "--robot", s(&robot), "--data", s(&near)]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("no effect of the catalogue explains")
            && !text.contains("nothing significant is missing"),
        "{text}"
    );
    assert!(
        stderr(&out).contains(&format!("line {line} ")),
        "{}",
        stderr(&out)
    );
}
