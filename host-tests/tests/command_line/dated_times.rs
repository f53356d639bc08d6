//! A tracker file whose time column is a date and time (`2021-03-04 12:00:07`), read with a
//! map's `[units] time` pattern (docs/formats.md, "Files in other layouts"): the rows get the
//! same `t_s` (seconds since 1970-01-01 00:00:00 of the file's clock) as a file that writes
//! those seconds, so `identify --effect base-drift` gives the same figures and finds the
//! simulated drift. A time that does not match the pattern, a pattern that is none, a date
//! written as digits in a `t_s` column, and dates without a pattern are refused in one line.

use crate::common::*;
use std::path::{Path, PathBuf};

/// The true drift, mm per second along the measurement frame's x, y, z.
const DRIFT: [f64; 3] = [4e-5, 3e-5, -2e-5];
/// 2021-03-04 12:00:00 as seconds since 1970-01-01 00:00:00 (18,690 days).
const START: i64 = 18_690 * 86_400 + 12 * 3_600;

/// A simulated hour of a drifting tracker; returns the header and the rows with `t_s`
/// rounded to whole seconds after `START` (the time column last).
fn session(dir: &Path) -> (String, Vec<(Vec<String>, i64)>) {
    let robot = data_file("er20.toml");
    let data = dir.join("sim.csv");
    simulate(
        &robot,
        Some(300),
        Some(0.01),
        Some(31),
        &[
            "--session-s",
            "3600",
            "--effect",
            &format!("base-drift:0:{},{},{}", DRIFT[0], DRIFT[1], DRIFT[2]),
        ],
        &data,
    );
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let head = header.strip_suffix(",t_s").expect(header).to_string();
    let rows = lines
        .map(|l| {
            let mut cells: Vec<String> = l.split(',').map(String::from).collect();
            let t: f64 = cells.pop().unwrap().parse().unwrap();
            (cells, t.round() as i64)
        })
        .collect();
    (head, rows)
}

/// `2021-03-04 12:mm:ss` (or 13:00:00) of a time in seconds after `START`.
fn date(t: i64) -> String {
    let (h, m, s) = (12 + t / 3600, (t % 3600) / 60, t % 60);
    format!("2021-03-04 {h:02}:{m:02}:{s:02}")
}

fn files(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let (head, rows) = session(dir);
    let mut seconds = format!("{head},t_s\n");
    let mut dated = format!("{};stamp\n", head.replace(',', ";"));
    for (cells, t) in &rows {
        seconds.push_str(&format!("{},{}\n", cells.join(","), START + t));
        dated.push_str(&format!("{};{}\n", cells.join(";"), date(*t)));
    }
    let map =
        "delimiter = \";\"\n[columns]\nt_s = \"stamp\"\n[units]\ntime = \"%Y-%m-%d %H:%M:%S\"\n";
    (
        write(dir, "seconds.csv", &seconds),
        write(dir, "dated.csv", &dated),
        write(dir, "dated.map.toml", map),
    )
}

#[test]
fn dates_give_the_seconds_they_stand_for_and_the_drift() {
    let dir = tempfile::tempdir().unwrap();
    let (seconds, dated, map) = files(dir.path());
    let robot = data_file("er20.toml");
    let args = ["--json", "--effect", "base-drift"];
    let a = json_without_timings(&run_on("identify", &robot, &seconds, &args));
    let mut with_map = args.to_vec();
    with_map.extend(["--map", s(&map)]);
    let b = json_without_timings(&run_on("identify", &robot, &dated, &with_map));
    assert_eq!(a, b);
    let fitted: Vec<f64> = ["vx", "vy", "vz"]
        .iter()
        .map(|c| b["parameters"][format!("base-drift.{c}")].as_f64().unwrap())
        .collect();
    let err = fitted
        .iter()
        .zip(DRIFT)
        .map(|(f, t)| (f - t).powi(2))
        .sum::<f64>()
        .sqrt();
    let speed = DRIFT.iter().map(|t| t * t).sum::<f64>().sqrt();
    assert!(err < 0.03 * speed, "{fitted:?} vs {DRIFT:?}");
}

#[test]
fn times_that_cannot_be_right_are_refused_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let (seconds, dated, map) = files(dir.path());
    let robot = data_file("er20.toml");
    let map_text = std::fs::read_to_string(&map).unwrap();
    // Line 6's time in another layout.
    let text = std::fs::read_to_string(&dated).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    lines[5] = lines[5].replace("2021-03-04 ", "04.03.2021 ");
    let other = write(dir.path(), "other.csv", &(lines.join("\n") + "\n"));
    let no_pattern = write(
        dir.path(),
        "none.toml",
        &map_text.replace("%Y-%m-%d %H:%M:%S", "date"),
    );
    let spaced = write(dir.path(), "spaced.csv", &text.replace(';', " "));
    let spaced_map = write(
        dir.path(),
        "spaced.toml",
        &map_text.replace("delimiter = \";\"", "delimiter = \" \""),
    );
    let no_column = write(
        dir.path(),
        "nocol.toml",
        &map_text.replace("t_s = \"stamp\"\n", ""),
    );
    // Digits of a date and time in a t_s column: 20210304120007.
    let digits = std::fs::read_to_string(&seconds)
        .unwrap()
        .lines()
        .enumerate()
        .map(|(i, l)| match (i, l.rsplit_once(',')) {
            (0, _) | (_, None) => l.to_string(),
            (_, Some((rest, t))) => {
                let t: i64 = t.parse::<i64>().unwrap() - START;
                let d = date(t).replace(['-', ' ', ':'], "");
                format!("{rest},{d}")
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n";
    let digits = write(dir.path(), "digits.csv", &digits);
    // Dates under kinecal's own name without a pattern, in kinecal's layout or through a map
    // that names no pattern: every row's time used to be read as empty, the drift fitted to
    // nothing and the drift check blind.
    let named = write(
        dir.path(),
        "named.csv",
        &text.replacen(";stamp", ";t_s", 1).replace(';', ","),
    );
    let no_time = write(
        dir.path(),
        "notime.toml",
        &map_text.replace("[units]\ntime = \"%Y-%m-%d %H:%M:%S\"\n", ""),
    );
    assert!(!std::fs::read_to_string(&no_time)
        .unwrap()
        .contains("time ="));
    for (data, map, says) in [
        (&named, None, "named.csv:2: '2021-03-04 12:00:00' in column t_s is not a number"),
        (
            &dated,
            Some(&no_time),
            "dated.csv:2: '2021-03-04 12:00:00' in column t_s (the file's `stamp`) is not a number",
        ),
        (
            &other,
            Some(&map),
            "other.csv:6:10: '04.03.2021 12:00:48' in column `stamp` (kinecal's t_s) does not match",
        ),
        (
            &dated,
            Some(&no_pattern),
            "[units] time = \"date\": no date or time specifier",
        ),
        (&dated, Some(&no_column), "but no t_s column"),
        (&spaced, Some(&spaced_map), "has spaces, but"),
        (&digits, None, "a date and time written as digits?"),
    ] {
        let mut args = vec!["--effect", "base-drift"];
        if let Some(m) = map {
            args.extend(["--map", s(m)]);
        }
        let out = run_on("identify", &robot, data, &args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{says}: {err}");
        assert!(
            err.contains(says) && err.trim().lines().count() == 1,
            "{says}: {err}"
        );
    }
}

/// The `t_s` that a map's pattern reads from a few rows of the UR10 series C (its joints and
/// points, the times in `stamp`), as `identify` reads them.
fn times(dir: &Path, stamps: &[&str], pattern: &str) -> anyhow::Result<Vec<f64>> {
    use kinecal_cli::formats::loading::load_measurements;
    use kinecal_cli::formats::robot_file::RobotFile;
    use kinecal_cli::formats::units::UnitArgs;
    let text = std::fs::read_to_string(ur10_dir().join("ur10_random_poses.csv")).unwrap();
    let mut lines = text.lines();
    let mut out = format!("{},stamp\n", lines.next().unwrap());
    for (l, t) in lines.zip(stamps) {
        out.push_str(&format!("{l},{t}\n"));
    }
    let data = write(dir, "stamped.csv", &out);
    let map = write(
        dir,
        "stamped.map.toml",
        &format!("delimiter = \",\"\n[columns]\nt_s = \"stamp\"\n[units]\ntime = {pattern:?}\n"),
    );
    let robot = RobotFile::load(&ur10_dir().join("robot.toml"))?.to_robot::<6>()?;
    let units = UnitArgs {
        map: Some(map),
        ..UnitArgs::default()
    };
    let ds = load_measurements::<6, _>(&data, &units, &robot, false)?;
    Ok(ds.extra("t_s").unwrap())
}

/// What each pattern reads: seconds since 1970-01-01 00:00:00 of the stated clock, fractions
/// of a second, a date alone as its midnight, an offset as the instant it names; an empty
/// cell is a row without a time.
#[test]
fn each_pattern_gives_the_seconds_it_states() {
    let dir = tempfile::tempdir().unwrap();
    let s0 = START as f64; // 2021-03-04 12:00:00
    for (stamps, pattern, want) in [
        (
            &[
                "2021-03-04 12:00:07",
                "2021-03-04 13:01:00",
                "2021-03-05 12:00:00",
            ][..],
            "%Y-%m-%d %H:%M:%S",
            vec![s0 + 7.0, s0 + 3660.0, s0 + 86_400.0],
        ),
        (
            &["20210304120007", "20210304120008", "20210304120009"][..],
            "%Y%m%d%H%M%S",
            vec![s0 + 7.0, s0 + 8.0, s0 + 9.0],
        ),
        (
            &[
                "04.03.2021 12:00:07.25",
                "04.03.2021 12:00:07.5",
                "04.03.2021 12:00:08",
            ][..],
            "%d.%m.%Y %H:%M:%S%.f",
            vec![s0 + 7.25, s0 + 7.5, s0 + 8.0],
        ),
        (
            &["2021-03-04", "2021-03-05", "2021-03-06"][..],
            "%Y-%m-%d",
            vec![s0 - 43_200.0, s0 + 43_200.0, s0 + 129_600.0],
        ),
        (
            &[
                "2021-03-04 13:00:07 +0100",
                "2021-03-04 12:00:07 +0000",
                "2021-03-04 12:00:07 -0130",
            ][..],
            "%Y-%m-%d %H:%M:%S %z",
            vec![s0 + 7.0, s0 + 7.0, s0 + 7.0 + 5400.0],
        ),
    ] {
        let got = times(dir.path(), stamps, pattern).unwrap();
        assert_eq!(&got[..3], &want[..], "{pattern}");
        assert!(got[3..].iter().all(|t| t.is_nan()), "{pattern}: {got:?}");
    }
    // Patterns that cannot give comparable times are refused when the map is read.
    for (pattern, says) in [
        ("%H:%M:%S", "a time of day without the date"),
        ("%Y-%m-%d %I:%M:%S", "without AM/PM"),
        ("%Q", "not a pattern chrono can read"),
        ("%Y-%m-%d %H:%M:%S.%f", "write %.f for a point"),
        ("%H:%M:%S,%3f", "a time of day without the date"),
        ("%Y-%m-%d %H:%M:%S %Z", "write %z for its offset"),
        ("date", "no date or time specifier"),
    ] {
        let err = times(dir.path(), &["2021-03-04 12:00:07"], pattern).unwrap_err();
        let text = format!("{err:#}");
        assert!(
            text.contains(says)
                && text.contains("give \"s\" (seconds)")
                && text.lines().count() == 1,
            "{pattern}: {text}"
        );
    }
}
