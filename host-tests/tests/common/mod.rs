//! Support shared by the test binaries (`mod common;` in each): running the `kinecal` binary,
//! paths and temporary files, `kinecal simulate`, and the robot files of the tests.
//!
//! The robot texts are the files of tests/data/, included as text so that a test can edit them
//! (drop the `[base]`, append `[[effects]]`, break a line) before writing them out.

// Every test binary compiles its own copy and uses only part of it.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A placed, tilted ER20-like 6R: `beta_deg = 0.3` on joint 3, `[base]` known.
pub const ER20_TILTED_PLACED: &str = include_str!("../data/er20_tilted_placed.toml");

/// The ER20-like 6R of [`ER20_TILTED_PLACED`] without the tilt, named "ER20-C10-like 6R".
pub const ER20_PLACED: &str = include_str!("../data/er20_placed.toml");

/// A placed 7R with a tilted joint 3 (`beta_deg = -0.5`), `[base]` known.
pub const LBR7_TILTED_PLACED: &str = include_str!("../data/lbr7_tilted_placed.toml");

/// The 7R of [`LBR7_TILTED_PLACED`] without the tilt (its name is the same).
pub const LBR7_PLACED: &str = include_str!("../data/lbr7_placed.toml");

/// The `kinecal` binary of this build.
pub fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_kinecal-under-test")
}

/// Runs `kinecal` with `args`; the exit status is the caller's to check.
pub fn kinecal(args: &[&str]) -> Output {
    Command::new(bin())
        .args(args)
        .output()
        .expect("run kinecal")
}

/// Runs `kinecal` with `args` and asserts that it succeeded.
pub fn kinecal_ok(args: &[&str]) -> Output {
    let out = kinecal(args);
    assert!(out.status.success(), "kinecal {args:?}: {}", stderr(&out));
    out
}

/// Runs `kinecal COMMAND --robot ROBOT --data DATA EXTRA…` (`check`, `identify`, `diagnose`,
/// `frames`); the exit status is the caller's to check.
pub fn run_on(command: &str, robot: &Path, data: &Path, extra: &[&str]) -> Output {
    let mut args = vec![command, "--robot", s(robot), "--data", s(data)];
    args.extend_from_slice(extra);
    kinecal(&args)
}

/// The arguments `COMMAND --robot ROBOT --data DATA --out OUT`; for `compensate`, `--model
/// ROBOT --targets DATA`.
pub fn args_with_out<'a>(
    command: &'a str,
    robot: &'a Path,
    data: &'a Path,
    out: &'a Path,
) -> Vec<&'a str> {
    let (model, input) = match command {
        "compensate" => ("--model", "--targets"),
        _ => ("--robot", "--data"),
    };
    vec![command, model, s(robot), input, s(data), "--out", s(out)]
}

/// Asserts success and returns stdout parsed as exactly one JSON object.
pub fn json_of(out: &Output) -> serde_json::Value {
    assert!(out.status.success(), "stderr: {}", stderr(out));
    let text = String::from_utf8(out.stdout.clone()).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("stdout is one JSON object ({e}): {text}"));
    assert!(v.is_object(), "stdout is one JSON object: {text}");
    v
}

/// The numbers of a JSON array.
pub fn f64s(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap_or_else(|| panic!("an array: {v}"))
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

pub fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).to_string()
}

pub fn s(p: &Path) -> &str {
    p.to_str().unwrap()
}

/// Writes `text` to `dir/name`.
pub fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p
}

/// The CSV `text` with `f` applied to the cells of each data row (the header kept), as a
/// user's mistake would change them: columns exchanged, a sign flipped, readings wrapped.
pub fn edit_rows(text: &str, f: impl Fn(&mut Vec<String>)) -> String {
    let mut out = String::new();
    for (k, line) in text.lines().enumerate() {
        let mut cells: Vec<String> = line.split(',').map(String::from).collect();
        if k > 0 {
            f(&mut cells);
        }
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    out
}

/// A file of tests/data/.
pub fn data_file(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

/// The real UR10 data (robot.toml and the tracker measurements) in data/ur10.
pub fn ur10_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../data/ur10")
}

/// `kinecal COMMAND --robot ROBOT --data DATA --json`, asserted to be no calibration (exit 3,
/// JSON `converged: false`): its `error:` line on stderr.
pub fn no_calibration(command: &str, robot: &Path, data: &Path) -> String {
    let out = run_on(command, robot, data, &["--json"]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(3), "{command} {data:?}: {err}");
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["converged"], false, "{command} {data:?}");
    err.lines()
        .find(|l| l.starts_with("error:"))
        .unwrap_or_else(|| panic!("{command} {data:?}: {err}"))
        .to_string()
}

/// The header and the first `n` rows of the UR10 series C file (`q1`…`q6`, `x`, `y`, `z`,
/// `temp_c`), each row's cells passed to `edit` with the row's index, written to `dir/name`.
pub fn ur10_rows(
    dir: &Path,
    name: &str,
    n: usize,
    edit: impl Fn(usize, &mut Vec<String>),
) -> PathBuf {
    let text = std::fs::read_to_string(ur10_dir().join("ur10_random_poses.csv")).unwrap();
    let mut lines = text.lines();
    let mut out = format!("{}\n", lines.next().unwrap());
    for (i, l) in lines.take(n).enumerate() {
        let mut cells: Vec<String> = l.split(',').map(String::from).collect();
        edit(i, &mut cells);
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    write(dir, name, &out)
}

/// Runs `kinecal simulate --robot ROBOT [--poses N] [--noise-mm σ] [--seed S] EXTRA… --out OUT`
/// and asserts that it succeeded; `None` leaves the program's default.
pub fn simulate(
    robot: &Path,
    poses: Option<usize>,
    noise_mm: Option<f64>,
    seed: Option<u64>,
    extra: &[&str],
    out: &Path,
) -> Output {
    let (poses, noise_mm, seed) = (
        poses.map(|n| n.to_string()),
        noise_mm.map(|x| x.to_string()),
        seed.map(|x| x.to_string()),
    );
    let mut args = vec!["simulate", "--robot", s(robot)];
    for (flag, value) in [
        ("--poses", &poses),
        ("--noise-mm", &noise_mm),
        ("--seed", &seed),
    ] {
        if let Some(v) = value {
            args.extend([flag, v.as_str()]);
        }
    }
    args.extend_from_slice(extra);
    args.extend(["--out", s(out)]);
    let o = kinecal(&args);
    assert!(o.status.success(), "{args:?}: {}", stderr(&o));
    o
}

/// Where a one-line error message names `file`: `(line, column, the rest of the message)`
/// from `…FILE:LINE:COLUMN:rest`.
pub fn location<'a>(msg: &'a str, file: &str) -> (usize, usize, &'a str) {
    let needle = format!("{file}:");
    let at = msg
        .find(&needle)
        .unwrap_or_else(|| panic!("names {file}: {msg}"));
    let mut it = msg[at + needle.len()..].splitn(3, ':');
    let mut number = |what: &str| -> usize {
        it.next()
            .unwrap_or("")
            .parse()
            .unwrap_or_else(|_| panic!("{what} number: {msg}"))
    };
    let (line, column) = (number("line"), number("column"));
    (line, column, it.next().unwrap_or(""))
}

/// A hidden effect for `kinecal_cli::simulation` (joint 1-based; tables spread over the limits).
pub fn effect(
    kind: &str,
    joint: usize,
    values: &[f64],
    order: u16,
) -> kinecal_cli::simulation::EffectArg {
    kinecal_cli::simulation::EffectArg {
        kind: kind.into(),
        joint: joint - 1,
        values: values.to_vec(),
        order,
        grid: None,
    }
}

/// The JSON report of a successful run without its timings (every key containing "seconds"),
/// for comparing two runs' figures.
pub fn json_without_timings(out: &Output) -> serde_json::Value {
    fn strip(v: &mut serde_json::Value) {
        if let Some(o) = v.as_object_mut() {
            o.retain(|k, _| !k.contains("seconds"));
            o.values_mut().for_each(strip);
        } else if let Some(a) = v.as_array_mut() {
            a.iter_mut().for_each(strip);
        }
    }
    let mut v = json_of(out);
    strip(&mut v);
    v
}

/// `diagnose` on `data` names `effect`, which turns no joint: its explanation has no angle
/// (`peak_to_peak_deg`, `amplitude_deg` null) and a size at the tool, and the text output
/// says `phrase`.
pub fn assert_diagnose_names_without_angle(robot: &Path, data: &Path, effect: &str, phrase: &str) {
    let v = json_of(&run_on("diagnose", robot, data, &["--json"]));
    let f = v["found"]
        .as_array()
        .unwrap()
        .iter()
        .find(|f| f["effect"] == effect)
        .unwrap_or_else(|| panic!("{effect} not named: {v}"));
    let e = &f["explanation"];
    assert!(
        e["peak_to_peak_deg"].is_null() && e["amplitude_deg"].is_null(),
        "{e}"
    );
    assert!(e["tool_max_mm"].as_f64().unwrap() > 0.0, "{e}");
    let text = kinecal_ok(&["diagnose", "--robot", s(robot), "--data", s(data)]);
    let out = String::from_utf8_lossy(&text.stdout);
    assert!(out.contains(phrase), "{out}");
}
