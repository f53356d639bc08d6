//! Units at the door (docs/formats.md): files in metres or radians are refused with exit 2
//! and a one-line reason naming the flag, by every command that reads measurements, sweeps or
//! targets; with the flag the results equal those of the millimetre/degree file; a unit given
//! explicitly is never second-guessed; real data in the right units is never refused;
//! malformed files exit 2; `check` without limits in the robot file warns about none.
//!
//! Data are made with `kinecal simulate` (known truth) for the UR10 robot file of
//! data/ur10 (no `[base]`: fitted), a placed ER20-like 6R and a placed 7R (`[base]`
//! known), then rewritten in other units here.

use std::path::{Path, PathBuf};
use std::process::Output;

use crate::common::{
    args_with_out, kinecal, run_on, s, simulate, stderr, ur10_dir, write, ER20_TILTED_PLACED,
    LBR7_PLACED,
};

/// Stdout parsed as one JSON object (the command may have exited 0 or 3).
fn json_of(out: &Output) -> serde_json::Value {
    let code = out.status.code();
    assert!(
        code == Some(0) || code == Some(3),
        "exit {code:?}: {}",
        stderr(out)
    );
    let text = String::from_utf8(out.stdout.clone()).unwrap();
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("one JSON object ({e}): {text}"))
}

/// Units a file is rewritten in.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Variant {
    Metres,
    Radians,
    Both,
}

impl Variant {
    const ALL: [Variant; 3] = [Variant::Metres, Variant::Radians, Variant::Both];
    fn metres(self) -> bool {
        self != Variant::Radians
    }
    fn radians(self) -> bool {
        self != Variant::Metres
    }
    /// The flags that read the file right.
    fn flags(self) -> Vec<&'static str> {
        let mut f = Vec::new();
        if self.metres() {
            f.extend(["--length-unit", "m"]);
        }
        if self.radians() {
            f.extend(["--angle-unit", "rad"]);
        }
        f
    }
    fn tag(self) -> &'static str {
        match self {
            Variant::Metres => "m",
            Variant::Radians => "rad",
            Variant::Both => "m_rad",
        }
    }
}

/// Rewrites a millimetre/degree CSV: `q…` (and `rx`, `ry`, `rz`) columns to radians, `x`,
/// `y`, `z` to metres, as the variant says; numbers written in the shortest exact form
/// (radians: those of `f64::to_radians`, the values the library works with).
fn convert(path: &Path, v: Variant) -> PathBuf {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with('#'));
    let head: Vec<String> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|c| c.trim().to_string())
        .collect();
    let angle = |c: &str| {
        (c.len() > 1 && c.starts_with('q') && c[1..].parse::<usize>().is_ok())
            || ["rx", "ry", "rz"].contains(&c)
    };
    let length = |c: &str| ["x", "y", "z"].contains(&c);
    let mut out = head.join(",");
    out.push('\n');
    for l in lines {
        let cells: Vec<String> = l
            .split(',')
            .zip(&head)
            .map(|(cell, name)| {
                let cell = cell.trim();
                let Ok(x) = cell.parse::<f64>() else {
                    return cell.to_string();
                };
                if v.radians() && angle(name) {
                    format!("{}", x.to_radians())
                } else if v.metres() && length(name) {
                    // The same decimal number in metres (the decimal point moved), as a
                    // tracker exporting metres would write it.
                    format!("{}", format!("{cell}e-3").parse::<f64>().unwrap())
                } else {
                    cell.to_string()
                }
            })
            .collect();
        out.push_str(&cells.join(","));
        out.push('\n');
    }
    let stem = path.file_stem().unwrap().to_str().unwrap();
    let p = path.with_file_name(format!("{stem}_{}.csv", v.tag()));
    std::fs::write(&p, out).unwrap();
    p
}

/// Asserts a refusal: exit 2, nothing on stdout (with `--json`: the error object), one stderr line naming `file` and `flags`
/// (and not the flag of a unit that is right).
fn assert_refused(out: &Output, file: &Path, v: Variant, what: &str) {
    let err = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{what}: exit 2 expected: {err}");
    // Nothing on stdout, or with --json exactly {"error": <the stderr line's reason>}.
    if !out.stdout.is_empty() {
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        let reason = err.trim_end().strip_prefix("kinecal: ").unwrap();
        assert_eq!(v, serde_json::json!({ "error": reason }), "{what}");
    }
    assert_eq!(err.lines().count(), 1, "{what}: one line: {err}");
    let name = file.display().to_string();
    assert!(err.contains(&name), "{what}: names {name}: {err}");
    let want = format!("pass {}", v.flags().join(" "));
    assert!(err.contains(&want), "{what}: `{want}` in: {err}");
    if !v.metres() {
        assert!(!err.contains("--length-unit"), "{what}: {err}");
        assert!(err.contains("radians"), "{what}: {err}");
    }
    if !v.radians() {
        assert!(!err.contains("--angle-unit"), "{what}: {err}");
        assert!(err.contains("metres"), "{what}: {err}");
    }
    assert!(
        !err.contains("inf") && !err.contains("NaN"),
        "{what}: {err}"
    );
}

/// One robot's files: measurements, a validation set, sweeps and targets, mm and degrees.
struct Case {
    name: &'static str,
    robot: PathBuf,
    data: PathBuf,
    valid: PathBuf,
    sweeps: Option<PathBuf>,
    /// The robot file itself is the model for `compensate`; the targets are the simulated
    /// points of a robot without errors, seeds = the joints.
    targets: PathBuf,
}

fn case(dir: &Path, name: &'static str, robot_text: Option<&str>) -> Case {
    let d = dir.join(name);
    std::fs::create_dir_all(&d).unwrap();
    let robot = match robot_text {
        Some(t) => write(&d, "robot.toml", t),
        None => ur10_dir().join("robot.toml"),
    };
    let (data, valid) = (d.join("data.csv"), d.join("valid.csv"));
    simulate(
        &robot,
        Some(40),
        Some(0.02),
        Some(7),
        &["--geom-errors"],
        &data,
    );
    simulate(
        &robot,
        Some(25),
        Some(0.02),
        Some(8),
        &["--geom-errors"],
        &valid,
    );
    let n = if name == "lbr7" { 7 } else { 6 };
    let sweeps = (n == 6).then(|| {
        let sweeps = d.join("sweeps.csv");
        let args = ["--sweeps", "1,2,5,6", "--sweep-points", "12"];
        simulate(&robot, None, Some(0.005), None, &args, &sweeps);
        sweeps
    });
    let targets = d.join("targets.csv");
    simulate(&robot, Some(12), None, Some(9), &[], &targets);
    Case {
        name,
        robot,
        data,
        valid,
        sweeps,
        targets,
    }
}

/// The commands that read a file, each as (label, arguments, the file it reads).
fn commands(
    c: &Case,
    dir: &Path,
    conv: &dyn Fn(&Path) -> PathBuf,
) -> Vec<(String, Vec<String>, PathBuf)> {
    let r: &str = s(&c.robot);
    let data = conv(&c.data);
    let valid = conv(&c.valid);
    let mut v = vec![
        (
            "check".to_string(),
            vec!["check", "--robot", r, "--data", s(&data)],
            data.clone(),
        ),
        (
            "identify".to_string(),
            vec![
                "identify",
                "--robot",
                r,
                "--data",
                s(&data),
                "--validate",
                s(&valid),
            ],
            data.clone(),
        ),
        (
            "diagnose".to_string(),
            vec!["diagnose", "--robot", r, "--data", s(&data), "--folds", "3"],
            data.clone(),
        ),
    ];
    let q = dir.join(format!("{}_q.csv", c.name));
    let targets = conv(&c.targets);
    v.push((
        "compensate".to_string(),
        args_with_out("compensate", &c.robot, &targets, &q),
        targets.clone(),
    ));
    let mut out: Vec<(String, Vec<String>, PathBuf)> = v
        .into_iter()
        .map(|(l, a, f)| (l, a.into_iter().map(String::from).collect(), f))
        .collect();
    if let Some(sw) = &c.sweeps {
        let sw = conv(sw);
        out.push((
            "frames".to_string(),
            ["frames", "--robot", r, "--data", s(&sw)]
                .into_iter()
                .map(String::from)
                .collect(),
            sw,
        ));
    }
    out
}

fn run(args: &[String], extra: &[&str]) -> Output {
    let mut a: Vec<&str> = args.iter().map(String::as_str).collect();
    a.extend_from_slice(extra);
    a.push("--json");
    kinecal(&a)
}

/// Every number (and bool, and array length) of `a` equals `b`'s within 1e-9 relative;
/// timing keys and strings (paths, sentences) are skipped.
fn assert_same_figures(a: &serde_json::Value, b: &serde_json::Value, at: &str, what: &str) {
    use serde_json::Value;
    const SKIP: [&str; 5] = [
        "seconds",
        "geometry_seconds",
        "microseconds_per_target",
        "out",
        "plots",
    ];
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (k, va) in x {
                if SKIP.contains(&k.as_str()) {
                    continue;
                }
                let vb = y
                    .get(k)
                    .unwrap_or_else(|| panic!("{what}: {at}.{k} missing"));
                assert_same_figures(va, vb, &format!("{at}.{k}"), what);
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            assert_eq!(x.len(), y.len(), "{what}: length of {at}");
            for (i, (va, vb)) in x.iter().zip(y).enumerate() {
                assert_same_figures(va, vb, &format!("{at}[{i}]"), what);
            }
        }
        (Value::Number(x), Value::Number(y)) => {
            let (x, y) = (x.as_f64().unwrap(), y.as_f64().unwrap());
            assert!(
                (x - y).abs() <= 1e-9 * x.abs().max(y.abs()) + 1e-12,
                "{what}: {at}: {x} vs {y}"
            );
        }
        (Value::Bool(x), Value::Bool(y)) => assert_eq!(x, y, "{what}: {at}"),
        (Value::Null, Value::Null) | (Value::String(_), Value::String(_)) => {}
        _ => panic!("{what}: {at}: {a} vs {b}"),
    }
}

/// Joint commands of a `compensate` output (columns `q1`…`qN`), in degrees.
fn commands_deg(path: &Path, rad: bool) -> Vec<Vec<f64>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let n = lines
        .next()
        .unwrap()
        .split(',')
        .filter(|c| c.starts_with('q'))
        .count();
    lines
        .map(|l| {
            l.split(',')
                .take(n)
                .map(|c| {
                    let x: f64 = c.parse().unwrap();
                    if rad {
                        x.to_degrees()
                    } else {
                        x
                    }
                })
                .collect()
        })
        .collect()
}

fn cases(dir: &Path) -> Vec<Case> {
    vec![
        case(dir, "ur10", None),
        case(dir, "er20", Some(ER20_TILTED_PLACED)),
        case(dir, "lbr7", Some(LBR7_PLACED)),
    ]
}

/// Metres, radians and both, for a robot without `[base]` (UR10) and placed 6R and 7R robots:
/// refused by check, identify, diagnose, frames and compensate with exit 2 and the flag named;
/// with the flag, the same figures as the millimetre/degree files.
#[test]
fn wrong_units_are_refused_and_the_flag_gives_the_same_results() {
    let dir = tempfile::tempdir().unwrap();
    for c in cases(dir.path()) {
        // Reference run in mm/deg: no refusal, figures to compare with.
        let reference: Vec<(String, Output)> = commands(&c, dir.path(), &|p| p.to_path_buf())
            .into_iter()
            .map(|(l, a, _)| {
                let o = run(&a, &[]);
                (l, o)
            })
            .collect();
        let q_ref = commands_deg(&dir.path().join(format!("{}_q.csv", c.name)), false);
        for (l, o) in &reference {
            assert_ne!(
                o.status.code(),
                Some(2),
                "{} {l} in mm/deg: {}",
                c.name,
                stderr(o)
            );
        }
        for v in Variant::ALL {
            let cmds = commands(&c, dir.path(), &|p| convert(p, v));
            for ((label, args, file), (_, ref_out)) in cmds.iter().zip(&reference) {
                let what = format!("{} {label} {v:?}", c.name);
                // Without the flag: refused.
                assert_refused(&run(args, &[]), file, v, &what);
                // With it: the same figures.
                let o = run(args, &v.flags());
                assert_eq!(
                    o.status.code(),
                    ref_out.status.code(),
                    "{what}: {}",
                    stderr(&o)
                );
                assert_same_figures(&json_of(ref_out), &json_of(&o), "", &what);
                if label == "compensate" {
                    // Commands come back in the targets' angle unit.
                    let q =
                        commands_deg(&dir.path().join(format!("{}_q.csv", c.name)), v.radians());
                    assert_eq!(q.len(), q_ref.len());
                    for (a, b) in q.iter().flatten().zip(q_ref.iter().flatten()) {
                        assert!((a - b).abs() <= 1e-8, "{what}: command {a} vs {b}");
                    }
                }
            }
        }
    }
}

/// A unit given explicitly is taken as given, even when wrong: the commands run (the errors
/// are then large), they do not refuse.
#[test]
fn an_explicit_unit_is_never_second_guessed() {
    let dir = tempfile::tempdir().unwrap();
    let c = case(dir.path(), "er20", Some(ER20_TILTED_PLACED));
    let r = s(&c.robot);
    let base = kinecal(&["check", "--json", "--robot", r, "--data", s(&c.data)]);
    let rms0 = json_of(&base)["nominal_rms_mm"].as_f64().unwrap();
    assert!(rms0 < 5.0, "{rms0}");
    for flags in [
        vec!["--length-unit", "m"],
        vec!["--angle-unit", "rad"],
        vec!["--length-unit", "m", "--angle-unit", "rad"],
    ] {
        let mut a = vec!["check", "--json", "--robot", r, "--data", s(&c.data)];
        a.extend(&flags);
        let o = kinecal(&a);
        assert_eq!(o.status.code(), Some(0), "{flags:?}: {}", stderr(&o));
        let rms = json_of(&o)["nominal_rms_mm"].as_f64().unwrap();
        assert!(rms > 100.0 * rms0, "{flags:?}: {rms} mm");
        let mut a = vec!["identify", "--json", "--robot", r, "--data", s(&c.data)];
        a.extend(&flags);
        let o = kinecal(&a);
        assert_ne!(o.status.code(), Some(2), "{flags:?}: {}", stderr(&o));
        assert!(!stderr(&o).contains("look like"), "{}", stderr(&o));
    }
    // Files in metres and radians, declared mm and deg explicitly: kept as declared.
    let m = convert(&c.data, Variant::Both);
    let o = kinecal(&[
        "check",
        "--json",
        "--robot",
        r,
        "--data",
        s(&m),
        "--length-unit",
        "mm",
        "--angle-unit",
        "deg",
    ]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    // Kept but said (every reason that follows would blame something else); right ones not.
    const SAID: &str =
        "say otherwise: they are kept; if the file is in those units, give --length-unit m";
    assert!(stderr(&o).contains(SAID), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("and --angle-unit rad"),
        "{}",
        stderr(&o)
    );
    let o = run_on("check", &c.robot, &c.data, &["--angle-unit", "deg"]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    assert!(!stderr(&o).contains("say otherwise"), "{}", stderr(&o));
    // One unit given (right), the other free and wrong: only the free one is named.
    let o = kinecal(&["check", "--robot", r, "--data", s(&m), "--length-unit", "m"]);
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("pass --angle-unit rad") && !e.contains("--length-unit"),
        "{e}"
    );
}

/// The real UR10 tracker data (joints spanning wide ranges, base unknown), its 6-D twin, and
/// small subsets of it are accepted; so are sweeps of one joint, even ±2° around zero.
#[test]
fn real_data_in_the_right_units_is_not_refused() {
    let dir = tempfile::tempdir().unwrap();
    let ur = ur10_dir();
    let robot = ur.join("robot.toml");
    let full = ur.join("ur10_random_poses.csv");
    for f in [full.clone(), ur.join("ur10_random_poses_6d.csv")] {
        let v = json_of(&run_on("check", &robot, &f, &["--json"]));
        assert!(v["poses"].as_u64().unwrap() > 2000);
        assert!(v["nominal_rms_mm"].as_f64().unwrap() < 20.0, "{v}");
    }
    let text = std::fs::read_to_string(&full).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let subsets = [
        ("first10", lines[1..11].to_vec()),
        (
            "every250",
            lines[1..].iter().step_by(250).copied().collect(),
        ),
        ("three", lines[100..103].to_vec()),
    ];
    for (name, rows) in subsets {
        let p = write(
            dir.path(),
            &format!("{name}.csv"),
            &format!("{}\n{}\n", lines[0], rows.join("\n")),
        );
        let o = kinecal(&["check", "--json", "--robot", s(&robot), "--data", s(&p)]);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
        let o = kinecal(&["identify", "--json", "--robot", s(&robot), "--data", s(&p)]);
        // Too few poses for the model may be refused (10 poses, 33 parameters), but never for
        // their units.
        let why = stderr(&o);
        if o.status.code() == Some(2) {
            assert!(why.contains("poses to identify"), "{name}: {why}");
            assert!(!why.contains("unit"), "{name}: {why}");
        }
        // The same subset in metres is refused (the check has the power to refuse it).
        if name != "three" {
            let m = convert(&p, Variant::Metres);
            let o = kinecal(&["check", "--robot", s(&robot), "--data", s(&m)]);
            assert_refused(&o, &m, Variant::Metres, name);
        }
    }
    // Sweeps of one joint: a full one, and ±2° around the zero pose (every reading within ±π).
    for (name, text) in [("ur10", None), ("er20", Some(ER20_TILTED_PLACED))] {
        let d = dir.path().join(name);
        std::fs::create_dir_all(&d).unwrap();
        let r = text.map_or(robot.clone(), |t| write(&d, "robot.toml", t));
        for (file, args) in [
            ("one.csv", vec!["--sweeps", "1"]),
            (
                "small.csv",
                vec![
                    "--sweeps",
                    "2",
                    "--sweep-span-deg",
                    "4",
                    "--sweep-points",
                    "9",
                    "--rest",
                    "0,0,0,0,0,0",
                ],
            ),
        ] {
            let p = d.join(file);
            simulate(&r, None, Some(0.01), None, &args, &p);
            let o = kinecal(&["check", "--json", "--robot", s(&r), "--data", s(&p)]);
            assert_eq!(o.status.code(), Some(0), "{name} {file}: {}", stderr(&o));
        }
    }
}

/// Malformed measurement, sweep and target files exit 2 with one line naming file, line and
/// column.
#[test]
fn malformed_files_exit_2() {
    let dir = tempfile::tempdir().unwrap();
    let robot = write(dir.path(), "robot.toml", ER20_TILTED_PLACED);
    let good = "q1,q2,q3,q4,q5,q6,x,y,z\n";
    let bad = [
        (
            "cell.csv",
            format!("{good}0,0,0,0,0,0,1,2,3\n0,0,0,0,zero,0,1,2,3\n"),
            ":3:5:",
        ),
        (
            "missing.csv",
            "q1,q2,q3,q4,q5,q6,x,y\n0,0,0,0,0,0,1,2\n".to_string(),
            ":1:1:",
        ),
        ("short.csv", format!("{good}0,0,0,0,0,0,1,2\n"), ":2:"),
        ("empty.csv", String::new(), ":1:1:"),
    ];
    for (name, text, place) in bad {
        let p = write(dir.path(), name, &text);
        let q = dir.path().join("q.csv");
        for args in [
            vec!["check", "--robot", s(&robot), "--data", s(&p)],
            vec!["identify", "--robot", s(&robot), "--data", s(&p)],
            vec!["diagnose", "--robot", s(&robot), "--data", s(&p)],
            vec!["frames", "--robot", s(&robot), "--data", s(&p)],
            args_with_out("compensate", &robot, &p, &q),
        ] {
            let o = kinecal(&args);
            let e = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{args:?}: {e}");
            assert_eq!(e.lines().count(), 1, "{e}");
            let at = format!("{}{place}", p.display());
            assert!(e.contains(&at), "{args:?}: `{at}` in {e}");
        }
    }
    // A pose target file with only some of rx, ry, rz.
    let p = write(
        dir.path(),
        "rxry.csv",
        "q1,q2,q3,q4,q5,q6,x,y,z,rx,ry\n0,0,0,0,0,0,1,2,3,4,5\n",
    );
    let q = dir.path().join("q.csv");
    let o = kinecal(&args_with_out("compensate", &robot, &p, &q));
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// `check` warns about poses outside the joint limits only where the robot file gives limits.
#[test]
fn check_warns_about_limits_only_where_the_file_has_them() {
    let dir = tempfile::tempdir().unwrap();
    let ur = ur10_dir();
    let data = ur.join("ur10_random_poses.csv");
    let text = std::fs::read_to_string(ur.join("robot.toml")).unwrap();
    // The real data has readings beyond ±180° on several joints.
    let no_limits: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("limits_deg"))
        .collect::<Vec<_>>()
        .join("\n");
    let r = write(dir.path(), "nolimits.toml", &no_limits);
    let o = kinecal(&["check", "--robot", s(&r), "--data", s(&data)]);
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(
        !out.contains("warning") && !stderr(&o).contains("warning"),
        "{out}"
    );
    assert!(out.contains("no limits in the robot file"), "{out}");
    let v = json_of(&run_on("check", &r, &data, &["--json"]));
    assert_eq!(v["outside_limits"], 0);

    // Control: limits of ±180° stated on joint 1 only: the poses beyond them are counted.
    let beyond = std::fs::read_to_string(&data)
        .unwrap()
        .lines()
        .skip(1)
        .filter(|l| l.split(',').next().unwrap().parse::<f64>().unwrap().abs() > 180.0)
        .count();
    assert!(beyond > 0);
    let one = no_limits.replacen(
        "d_mm = 118.0",
        "d_mm = 118.0\nlimits_deg = [-180.0, 180.0]",
        1,
    );
    assert_ne!(one, no_limits);
    let r = write(dir.path(), "onelimit.toml", &one);
    let o = kinecal(&["check", "--robot", s(&r), "--data", s(&data)]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains(&format!("warning: {beyond} of ")), "{out}");
    let v = json_of(&run_on("check", &r, &data, &["--json"]));
    assert_eq!(v["outside_limits"], beyond);
}

/// The UR10 robot file, 60 simulated poses in millimetres (`d.csv`) and 60 others in metres
/// (`v_m.csv`), in `dir`.
fn session_and_metres(dir: &Path) -> (PathBuf, PathBuf, PathBuf) {
    let robot = ur10_dir().join("robot.toml");
    let (data, other) = (dir.join("d.csv"), dir.join("v.csv"));
    simulate(&robot, Some(60), Some(0.01), Some(1), &[], &data);
    simulate(&robot, Some(60), Some(0.01), Some(2), &[], &other);
    let v = in_metres(&other, dir);
    (robot, data, v)
}

/// A copy of the tracker file `path` (6 joints) with its points in metres, `v_m.csv` in `dir`.
fn in_metres(path: &Path, dir: &Path) -> PathBuf {
    let text = std::fs::read_to_string(path).unwrap();
    let mut metres = String::new();
    for (k, line) in text.lines().filter(|l| !l.starts_with('#')).enumerate() {
        let mut cells: Vec<String> = line.split(',').map(String::from).collect();
        if k > 0 {
            for c in &mut cells[6..9] {
                *c = format!("{}", c.parse::<f64>().unwrap() / 1000.0);
            }
        }
        metres.push_str(&(cells.join(",") + "\n"));
    }
    write(dir, "v_m.csv", &metres)
}

/// A `--validate` file in metres beside data in millimetres: the refusal said "pass
/// --length-unit m", which then read the data file in metres too. It now says the flags apply
/// to both files and to give the `--validate` file in the data file's units.
#[test]
fn a_validate_file_in_other_units_is_told_to_match_the_data() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (robot, data, v) = session_and_metres(d);
    let out = run_on("identify", &robot, &data, &["--validate", s(&v)]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--length-unit")
            && err.contains("apply to --data and --validate alike")
            && err.trim().lines().count() == 1,
        "{err}"
    );
}

/// A `--validate` file in metres read with `--length-unit mm` forced (the flag is never
/// second-guessed): every model missed its poses by ~900 mm, and a fit that predicted them
/// better by a hair was accepted (exit 0). The calibrated model's miss there against the
/// robot file's on the identification poses now refuses the file (exit 2, naming it); the real
/// UR10 session's other poses, read the same way, are judged as before.
#[test]
fn a_validate_file_the_robot_misses_by_far_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (robot, data, v) = session_and_metres(d);
    let args = ["--validate", s(&v), "--length-unit", "mm"];
    let out = run_on("identify", &robot, &data, &args);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("--validate") && err.contains("v_m.csv") && err.contains("misses its poses"),
        "{err}"
    );
    // Should not fire: the real session's poses split in two, both in millimetres.
    let rows: Vec<String> = std::fs::read_to_string(ur10_dir().join("ur10_random_poses.csv"))
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    let half = |odd: usize| {
        let mut t = rows[0].clone() + "\n";
        for (_, r) in rows[1..].iter().enumerate().filter(|(k, _)| k % 2 == odd) {
            t.push_str(&(r.clone() + "\n"));
        }
        t
    };
    let (a, b) = (write(d, "a.csv", &half(0)), write(d, "b.csv", &half(1)));
    let args = ["--validate", s(&b), "--length-unit", "mm"];
    let out = run_on("identify", &robot, &a, &args);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(0), "{err}");
    assert!(!err.contains("misses its poses"), "{err}");
    // Should not fire (the newcomer's review): the 80 real poses whose reflector axis lies
    // within 5° of pose 5's, a tool guessed 60 mm off, the session's 2,693 others held out.
    // The start placed on those poses misses the others by 28.6 mm; the calibration predicts
    // them to 0.6 mm.
    let six = std::fs::read_to_string(ur10_dir().join("ur10_random_poses_6d.csv")).unwrap();
    let axis = |line: &str| {
        let c: Vec<f64> = line.split(',').map(|v| v.parse().unwrap()).collect();
        let r = nalgebra::Rotation3::from_euler_angles(
            c[10].to_radians(),
            c[11].to_radians(),
            c[12].to_radians(),
        );
        r.matrix().column(2).into_owned()
    };
    let lines: Vec<&str> = six.lines().skip(1).collect();
    let z5 = axis(lines[5]);
    let (mut near, mut rest) = (rows[0].clone() + "\n", rows[0].clone() + "\n");
    for (k, line) in lines.iter().enumerate() {
        let keep = axis(line).dot(&z5) > 5f64.to_radians().cos();
        let row = rows[k + 1].clone() + "\n";
        if keep {
            near.push_str(&row)
        } else {
            rest.push_str(&row)
        }
    }
    let text = std::fs::read_to_string(&robot).unwrap();
    let guessed = write(
        d,
        "tool60.toml",
        &text.replace("xyz_mm = [0.0, 0.0, 109.0]", "xyz_mm = [60.0, 0.0, 109.0]"),
    );
    let (near, rest) = (write(d, "near.csv", &near), write(d, "rest.csv", &rest));
    let out = run_on("identify", &guessed, &near, &["--validate", s(&rest)]);
    assert!(
        !stderr(&out).contains("misses its poses"),
        "{}",
        stderr(&out)
    );
}

/// diagnose and report judge a `--validate` file as identify does: in metres beside data in
/// millimetres (the file read with `--length-unit mm`), diagnose searched and reported a
/// held-out RMS of 3 m with exit 0, report drew its page. Both refuse it now (exit 2, naming
/// it); the same 200 real UR10 poses in millimetres are judged as before.
#[test]
fn diagnose_and_report_refuse_a_validate_file_in_metres() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    // The real session's rows 1-400 searched and fitted, 401-600 held out.
    let rows: Vec<String> = std::fs::read_to_string(ur10_dir().join("ur10_random_poses.csv"))
        .unwrap()
        .lines()
        .map(String::from)
        .collect();
    let a = write(d, "a.csv", &(rows[..401].join("\n") + "\n"));
    let b = [&rows[..1], &rows[401..601]].concat().join("\n") + "\n";
    let b = write(d, "b.csv", &b);
    let metres = in_metres(&b, d);
    let robot = ur10_dir().join("robot.toml");
    let (model, page) = (d.join("m.toml"), d.join("r.html"));
    let out = run_on("identify", &robot, &a, &["--out", s(&model)]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    for (held, code) in [(&metres, 2), (&b, 0)] {
        let validate = ["--validate", s(held), "--length-unit", "mm"];
        let report = [&validate[..], &["--model", s(&model), "--out", s(&page)]].concat();
        for (command, args) in [("diagnose", &validate[..]), ("report", &report[..])] {
            let out = run_on(command, &robot, &a, args);
            let err = stderr(&out);
            assert_eq!(out.status.code(), Some(code), "{command}: {err}");
            let refused = err.contains("v_m.csv") && err.contains("misses its poses");
            assert_eq!(refused, code == 2, "{command}: {err}");
        }
        assert_eq!(page.exists(), code == 0, "a page of a refused file");
    }
}
