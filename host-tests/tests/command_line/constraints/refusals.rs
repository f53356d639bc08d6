//! What cannot be right in a constraint file is refused with a one-line reason that says what
//! to do: malformed groups, radians, a misstated unit, commands that need tracker points.

use super::*;

/// One row of a hand-made constraint file: kind, group, length_mm.
type Cells<'a> = (&'a str, &'a str, &'a str);

/// A constraint file of the ER20 with `rows` (kind, group, length) at one pose each.
fn file_of(dir: &Path, rows: &[(&str, &str, &str)]) -> PathBuf {
    let mut text = String::from("kind,group,q1,q2,q3,q4,q5,q6,length_mm\n");
    for (k, (kind, group, length)) in rows.iter().enumerate() {
        let q = 10.0 + k as f64;
        text.push_str(&format!(
            "{kind},{group},{q},{q},{q},{q},{q},{q},{length}\n"
        ));
    }
    write(dir, "bad.csv", &text)
}

#[test]
fn malformed_groups_are_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let socket3 = [("socket", "s1", ""); 3];
    let distance3 = [("distance", "d1", "500"); 3];
    let lengths = [("distance", "d1", "500"), ("distance", "d1", "501")];
    let missing = [("distance", "d1", "500"), ("distance", "d1", "")];
    let negative = [("distance", "d1", "-5"), ("distance", "d1", "-5")];
    let unknown = [("sphere", "s1", ""); 4];
    let badname = [("socket", "s 1", ""); 4];
    let cases: [(&[Cells], &str); 7] = [
        (&socket3, "at least 4"),
        (&distance3, "exactly 2"),
        (&lengths, "same length_mm"),
        (&missing, "length_mm on both rows"),
        (&negative, "must be > 0"),
        (&unknown, "unknown"),
        (&badname, "letters, digits"),
    ];
    for (rows, why) in cases {
        let data = file_of(dir.path(), rows);
        let o = kinecal(&[
            "identify",
            "--robot",
            s(&data_file("er20.toml")),
            "--data",
            s(&data),
        ]);
        assert_eq!(o.status.code(), Some(2), "{rows:?}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(e.contains(why), "{rows:?}: {e}");
        assert_eq!(e.trim().lines().count(), 1, "one line: {e}");
    }
}

/// A constraint file written with `;` and decimal commas: it was read as tracker points ("the
/// header needs x, y, z … read it with --map", and with --map "not a number: '' in column x").
/// It is named a constraint file, told how it must be written, by every command.
#[test]
fn a_constraint_file_with_semicolons_is_told_to_be_converted() {
    let dir = tempfile::tempdir().unwrap();
    let text = "kind;group;q1;q2;q3;q4;q5;q6;length_mm\n\
                distance;d1;10,5;20;30;40;50;60;500,25\n\
                distance;d1;11;21;31;41;51;61;500,25\n";
    let data = write(dir.path(), "eu.csv", text);
    for command in ["check", "identify", "validate"] {
        let robot = data_file("er20.toml");
        let mut args = vec![command, "--robot", s(&robot), "--data", s(&data)];
        if command == "validate" {
            args.extend(["--model", s(&robot)]);
        }
        let o = kinecal(&args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{command}: {e}");
        assert!(
            e.contains("comma-separated with `.` decimals") && e.trim().lines().count() == 1,
            "{command}: {e}"
        );
    }
}

/// A `sigma` column (for `sigma_mm`) was ignored without a word (the default 0.01 mm used, no
/// χ²); `length` for `length_mm` likewise. Refused, naming the column to rename.
#[test]
fn a_sigma_or_length_column_without_its_unit_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "distance:12", 4);
    let text = std::fs::read_to_string(&data).unwrap();
    for (from, to) in [("length_mm", "length"), ("sigma_mm", "sigma")] {
        let mut lines = text.lines().filter(|l| !l.starts_with('#'));
        let mut out = format!("{}\n", lines.next().unwrap().replace(from, to));
        for l in lines {
            out.push_str(&format!("{l}\n"));
        }
        let file = write(dir.path(), "renamed.csv", &out);
        let o = kinecal(&[
            "identify",
            "--robot",
            s(&data_file("er20.toml")),
            "--data",
            s(&file),
        ]);
        let e = stderr(&o);
        let want = format!("`{from}`");
        assert_eq!(o.status.code(), Some(2), "{e}");
        assert!(e.contains(&want) && e.contains("rename it"), "{e}");
    }
}

#[test]
fn joint_readings_in_radians_are_read_with_angle_unit() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "distance:40", 9);
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let mut rad = format!("{header}\n");
    for l in lines {
        let cells: Vec<String> = l
            .split(',')
            .enumerate()
            .map(|(k, c)| {
                if (2..8).contains(&k) {
                    format!("{}", c.parse::<f64>().unwrap().to_radians())
                } else {
                    c.to_string()
                }
            })
            .collect();
        rad.push_str(&cells.join(","));
        rad.push('\n');
    }
    let rad_file = write(dir.path(), "rad.csv", &rad);
    let deg = identify(&data, &[]);
    let r = identify(&rad_file, &["--angle-unit", "rad"]);
    let (a, b) = (
        deg["before"]["identification_rms_mm"].as_f64().unwrap(),
        r["before"]["identification_rms_mm"].as_f64().unwrap(),
    );
    assert!((a - b).abs() < 1e-6 * a, "nominal {a} vs {b}");
    // Both fits end at the same minimum to the convergence tolerance; degrees read as radians
    // would put every tool point metres away.
    let (a, b) = (
        deg["after"]["identification_rms_mm"].as_f64().unwrap(),
        r["after"]["identification_rms_mm"].as_f64().unwrap(),
    );
    assert!((a - b).abs() < 0.05 * a, "calibrated {a} vs {b}");
    // Without --angle-unit the radians are refused, and the reason says which flag (not the
    // lengths, which then look 20 times too long).
    for command in ["identify", "diagnose", "check"] {
        let out = kinecal(&[
            command,
            "--robot",
            s(&data_file("er20.toml")),
            "--data",
            s(&rad_file),
        ]);
        assert_eq!(out.status.code(), Some(2), "{command}");
        let e = stderr(&out);
        assert!(
            e.contains("look like radians") && e.contains("--angle-unit rad"),
            "{command}: {e}"
        );
        assert_eq!(e.trim().lines().count(), 1, "{e}");
    }
}

#[test]
fn commands_that_need_tracker_points_refuse_a_constraint_file_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10", 3);
    let out = kinecal(&[
        "frames",
        "--robot",
        s(&data_file("er20.toml")),
        "--data",
        s(&data),
    ]);
    assert_eq!(out.status.code(), Some(2));
    let e = stderr(&out);
    assert!(
        e.contains("a constraint file (kind column)") && e.contains("tracker points"),
        "{e}"
    );
    assert_eq!(e.trim().lines().count(), 1, "{e}");
}

#[test]
fn a_misstated_unit_on_a_constraint_file_is_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10,distance:20", 3);
    let robot = data_file("er20.toml");
    let run = |cmd: &str, flag: &str, value: &str| {
        let mut args = vec![cmd, "--robot", s(&robot), "--data", s(&data), flag, value];
        if cmd == "validate" {
            args.extend(["--model", s(&robot)]);
        }
        kinecal(&args)
    };
    for cmd in ["check", "identify", "validate"] {
        // Degrees read as radians.
        let out = run(cmd, "--angle-unit", "rad");
        assert_eq!(out.status.code(), Some(2), "{cmd}: {}", stderr(&out));
        assert!(
            stderr(&out).contains("look like degrees; leave --angle-unit rad out"),
            "{cmd}: {}",
            stderr(&out)
        );
        // Millimetre lengths read as metres.
        let out = run(cmd, "--length-unit", "m");
        assert_eq!(out.status.code(), Some(2), "{cmd}: {}", stderr(&out));
        assert!(
            stderr(&out)
                .contains("look like millimetres read as metres; leave --length-unit m out"),
            "{cmd}: {}",
            stderr(&out)
        );
    }
}

/// Labelling and unit slips in a constraint session used to give a nonsense model with exit 0
/// (two sockets under one name: 89 mm RMS, a4 74 mm; lengths in centimetres: links a tenth as
/// long; the lengths are now refused as they are read). `identify` and `diagnose` now apply the tracker path's guards (the arm's size, a
/// joint turned or a link moved, the constraints left far from met), exit 3 naming the slip
/// and what to check, and write no model; the session as simulated calibrates.
#[test]
fn a_mislabelled_group_or_lengths_in_another_unit_are_no_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10,distance:40", 3);
    let text = std::fs::read_to_string(&data).unwrap();
    let robot = data_file("er20.toml");
    // Two sockets under one name.
    let merged = write(dir.path(), "merged.csv", &text.replace(",s2,", ",s1,"));
    assert_ne!(text, std::fs::read_to_string(&merged).unwrap());
    // Every length_mm in centimetres.
    let header: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let k = header.iter().position(|c| *c == "length_mm").unwrap();
    let scaled_lengths = |text: &str, by: f64| -> String {
        text.lines()
            .enumerate()
            .map(|(i, l)| {
                let mut cells: Vec<String> = l.split(',').map(String::from).collect();
                if i > 0 && !cells[k].is_empty() {
                    cells[k] = (cells[k].parse::<f64>().unwrap() * by).to_string();
                }
                cells.join(",") + "\n"
            })
            .collect()
    };
    let cm = scaled_lengths(&text, 0.1);
    let cm = write(dir.path(), "cm.csv", &cm);
    // Lengths in centimetres are refused as they are read (exit 2), naming the unit.
    for command in ["check", "identify", "diagnose"] {
        let out = kinecal(&[command, "--robot", s(&robot), "--data", s(&cm)]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{command}: {err}");
        assert!(
            err.contains("1/10 of the nominal robot's distances")
                && err.contains("they look like centimetres"),
            "{command}: {err}"
        );
    }
    // Inches, and inches read as metres.
    let inches = write(dir.path(), "in.csv", &scaled_lengths(&text, 1.0 / 25.4));
    let err = stderr(&kinecal(&[
        "check",
        "--robot",
        s(&robot),
        "--data",
        s(&inches),
    ]));
    assert!(
        err.contains("they look like inches; convert length_mm"),
        "{err}"
    );
    let out = kinecal(&[
        "check",
        "--robot",
        s(&robot),
        "--data",
        s(&inches),
        "--length-unit",
        "m",
    ]);
    assert!(
        stderr(&out).contains("inches read as metres"),
        "{}",
        stderr(&out)
    );
    // Metres read as millimetres: the flag is named, with what else it reads in metres (the
    // σ, stated in millimetres, came back a thousand times too large).
    let metres = write(dir.path(), "m.csv", &scaled_lengths(&text, 1e-3));
    let err = stderr(&kinecal(&[
        "check",
        "--robot",
        s(&robot),
        "--data",
        s(&metres),
    ]));
    assert!(
        err.contains("give --length-unit m (which reads sigma_mm"),
        "{err}"
    );
    // Lengths 50 % too long: no unit explains them.
    let long = write(dir.path(), "long.csv", &scaled_lengths(&text, 1.5));
    let out = kinecal(&["check", "--robot", s(&robot), "--data", s(&long)]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("no length unit explains it"),
        "{}",
        stderr(&out)
    );
    for bad in [&merged] {
        for command in ["identify", "diagnose"] {
            let out_model = dir.path().join("m.toml");
            let _ = std::fs::remove_file(&out_model);
            let out = kinecal(&[
                command,
                "--robot",
                s(&robot),
                "--data",
                s(bad),
                "--out",
                s(&out_model),
            ]);
            let err = stderr(&out);
            assert_eq!(out.status.code(), Some(3), "{command} {bad:?}: {err}");
            assert!(
                err.lines().any(|l| l.starts_with("error:")
                    && (l.contains("group's label") || l.contains("length_mm"))),
                "{command} {bad:?}: {err}"
            );
            assert!(!out_model.exists(), "{command} {bad:?} wrote a model");
        }
    }
    for command in ["identify", "diagnose"] {
        let out = kinecal(&[command, "--robot", s(&robot), "--data", s(&data)]);
        assert_eq!(out.status.code(), Some(0), "{command}: {}", stderr(&out));
    }
}

/// A session with no equation to spare: two planes of 8 rows give 16 equations, 6 of them
/// taken by the planes; the other 10 are met exactly by the 10 parameters they determine, and
/// `identify` used to report an RMS of 5e-14 mm with exit 0 and write the model. Three
/// distances (3 equations) used to "determine" 22 parameters (the identifiability analysis
/// looked only at as many directions as there were equations) and fit to 2e-13 mm. Both are
/// refused with exit 2 by `identify` and `diagnose`, naming the equations and parameters; a
/// session with equations to spare (two sockets of 6 rows: 36 equations, 6 for the centres,
/// 16 parameters) fits.
#[test]
fn a_session_that_any_robot_meets_exactly_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (planes, _) = session(dir.path(), "plane:2x8", 5);
    let robot = data_file("er20.toml");
    for command in ["identify", "diagnose"] {
        let out = kinecal(&[command, "--robot", s(&robot), "--data", s(&planes)]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{command}: {err}");
        assert!(
            err.contains(
                "2 groups give 16 equations, 6 of them taken by the sockets' centres \
                          and the planes, the rest by the 10 parameters"
            ) && err.contains("exactly whatever the robot"),
            "{command}: {err}"
        );
    }
    // Three bar lengths of a larger session (its first three distance groups, 6 rows).
    let dir2 = tempfile::tempdir().unwrap();
    let (bars, _) = session(dir2.path(), "distance:10", 5);
    let text = std::fs::read_to_string(&bars).unwrap();
    let three: Vec<&str> = text.lines().take(7).collect();
    let three = write(dir2.path(), "three.csv", &(three.join("\n") + "\n"));
    let out = kinecal(&["identify", "--robot", s(&robot), "--data", s(&three)]);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("3 groups give 3 equations, all of them by the 3 parameters"),
        "{err}"
    );
    let dir3 = tempfile::tempdir().unwrap();
    let (sockets, _) = session(dir3.path(), "socket:2x6", 5);
    let v = identify(&sockets, &[]);
    assert_eq!(v["converged"], true);
}

/// A session with a few equations to spare but fewer than ten (18 distances for 17
/// parameters fitted to 0.0005 mm at 0.05 mm noise, exit 0 and no word) is warned about, naming
/// how many are left; with ten or more it is not. Distance sessions of 14 to 30 bars of the
/// ER20: one equation per bar, so the spare ones are the bars less the parameters estimated.
#[test]
fn a_session_with_few_equations_to_spare_is_warned_about() {
    let robot = data_file("er20.toml");
    let mut warned = 0;
    for bars in (14..=30).step_by(2) {
        let dir = tempfile::tempdir().unwrap();
        let (data, _) = session(dir.path(), &format!("distance:{bars}"), 3);
        let out = kinecal(&[
            "identify",
            "--robot",
            s(&robot),
            "--data",
            s(&data),
            "--json",
        ]);
        let err = stderr(&out);
        if out.status.code() == Some(2) {
            assert!(err.contains("exactly whatever the robot"), "{bars}: {err}");
            continue;
        }
        assert_eq!(out.status.code(), Some(0), "{bars}: {err}");
        let v = json_of(&out);
        let spare = v["n_identification"].as_i64().unwrap()
            - v["estimated"].as_array().unwrap().len() as i64;
        let says = format!("only {spare} of the session's equations are left");
        if spare < 10 {
            assert!(err.contains(&says), "{bars} bars, {spare} spare: {err}");
            warned += 1;
        } else {
            assert!(
                !err.contains("of the session's equations are left"),
                "{bars}: {err}"
            );
        }
    }
    assert!(warned > 0);
}

/// A socket row pasted twice was kept without a word (tracker files drop copies with a
/// warning): it weighs double. It is left out with a warning naming both lines, and the fit is
/// the one of the file without it.
#[test]
fn a_copied_constraint_row_is_left_out_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10,distance:12", 5);
    let text = std::fs::read_to_string(&data).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    let row = lines.iter().position(|l| l.starts_with("socket,")).unwrap();
    let mut copied: Vec<&str> = lines.clone();
    copied.insert(lines.len() - 1, lines[row]);
    let copied = write(dir.path(), "copied.csv", &(copied.join("\n") + "\n"));
    let robot = data_file("er20.toml");
    let fit = |file: &Path| {
        kinecal(&[
            "identify",
            "--robot",
            s(&robot),
            "--data",
            s(file),
            "--json",
        ])
    };
    let (plain, twice) = (fit(&data), fit(&copied));
    let err = stderr(&twice);
    assert!(
        err.contains(&format!(
            "1 row(s) repeat an earlier row cell for cell (line {} repeats line {})",
            lines.len(),
            row + 1
        )),
        "{err}"
    );
    let p = |o: &std::process::Output| json_of(o)["parameters"].clone();
    assert_eq!(p(&plain), p(&twice));
}

/// `validate --model` the robot file itself on a constraint session compared the robot with
/// itself without a word (a note now); a model of another robot (a link 150 mm longer) was not
/// refused: it is (exit 2), as on tracker sessions; the true robot as the model is judged.
#[test]
fn validate_tells_the_robot_itself_and_refuses_another_robot_as_the_model() {
    let dir = tempfile::tempdir().unwrap();
    let (data, truth) = session(dir.path(), "distance:30", 5);
    let robot = data_file("er20.toml");
    let run = |model: &Path| {
        kinecal(&[
            "validate",
            "--robot",
            s(&robot),
            "--model",
            s(model),
            "--data",
            s(&data),
        ])
    };
    let out = run(&robot);
    let err = stderr(&out);
    assert_ne!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("itself"), "{err}");
    let text = std::fs::read_to_string(&truth).unwrap();
    let a3 = text
        .lines()
        .find(|l| l.trim_start().starts_with("a_mm") && !l.contains("= 0.0"))
        .unwrap()
        .to_string();
    let value: f64 = a3.split('=').nth(1).unwrap().trim().parse().unwrap();
    let other = write(
        dir.path(),
        "other.toml",
        &text.replacen(&a3, &format!("a_mm = {}", value + 150.0), 1),
    );
    let out = run(&other);
    let err = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(err.contains("not an identified model"), "{err}");
    let out = run(&truth);
    assert_ne!(out.status.code(), Some(2), "{}", stderr(&out));
}

/// One row whose σ lost its decimal point (1e-5 mm among 0.02 mm) weighed as millions of the
/// others: the constraint fit stalled on it and the refusal blamed two good rows. A σ a
/// thousand times below the file's median is refused naming its line, in constraint files and
/// tracker files alike; σ that vary as real ones do (0.01 to 0.05 mm) are read.
#[test]
fn a_sigma_a_thousand_times_below_the_others_is_refused_naming_its_line() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = data_file("er20.toml");
    // The σ columns `header` (replacing the file's own, if any) with σ from 0.01 to 0.05 mm,
    // and `tiny` on line 6.
    let with_sigma = |name: &str, source: &Path, header: &str, tiny: &str| -> PathBuf {
        let text = std::fs::read_to_string(source).unwrap();
        let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
        let own = head.iter().position(|c| *c == "sigma_mm");
        let mut out = String::new();
        for (k, line) in text.lines().enumerate() {
            let mut cells: Vec<String> = line.split(',').map(String::from).collect();
            if let Some(c) = own {
                cells.remove(c);
            }
            let sigma = match k {
                0 => header.to_string(),
                5 => tiny.to_string(),
                _ => {
                    let s = format!("{}", 0.01 + 0.01 * (k % 5) as f64);
                    header
                        .split(',')
                        .map(|_| s.clone())
                        .collect::<Vec<_>>()
                        .join(",")
                }
            };
            out.push_str(&format!("{},{sigma}\n", cells.join(",")));
        }
        write(d, name, &out)
    };
    let session = d.join("session.csv");
    let o = kinecal(&[
        "simulate",
        "--robot",
        s(&robot),
        "--constraints",
        "socket:4x10,distance:20",
        "--noise-mm",
        "0.02",
        "--geom-errors",
        "--out",
        s(&session),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let points = d.join("points.csv");
    crate::common::simulate(
        &robot,
        Some(60),
        Some(0.02),
        Some(4),
        &["--geom-errors"],
        &points,
    );
    let cases = [
        (
            with_sigma("c.csv", &session, "sigma_mm", "0.00001"),
            "sigma_mm",
        ),
        (
            with_sigma("p.csv", &points, "sx_mm,sy_mm,sz_mm", "0.00001,0.02,0.02"),
            "sx_mm",
        ),
    ];
    for (data, column) in &cases {
        let o = kinecal(&["identify", "--robot", s(&robot), "--data", s(data)]);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(2), "{data:?}: {e}");
        let at = format!(
            "{}:6: {column} 0.00001 is",
            data.file_name().unwrap().to_string_lossy()
        );
        assert!(
            e.contains(&at) && e.contains("--ignore-sigma"),
            "{data:?}: {e}"
        );
    }
    // A constraint header naming sigma_mm twice read the first in silence.
    let twice = std::fs::read_to_string(&session).unwrap();
    let twice =
        crate::common::edit_rows(&twice.replacen("sigma_mm", "sigma_mm,sigma_mm", 1), |c| {
            c.insert(9, "0.5".to_string())
        });
    let twice = write(d, "twice.csv", &twice);
    let o = kinecal(&["identify", "--robot", s(&robot), "--data", s(&twice)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    assert!(
        stderr(&o).contains("names column `sigma_mm` twice (columns 10 and 11)"),
        "{}",
        stderr(&o)
    );
    // The same files with that row's σ as the others': read.
    for (name, source, header, row) in [
        ("c2.csv", &session, "sigma_mm", "0.03"),
        ("p2.csv", &points, "sx_mm,sy_mm,sz_mm", "0.03,0.02,0.02"),
    ] {
        let data = with_sigma(name, source, header, row);
        let o = kinecal(&["check", "--robot", s(&robot), "--data", s(&data)]);
        assert_eq!(o.status.code(), Some(0), "{name}: {}", stderr(&o));
    }
}
