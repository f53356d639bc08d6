//! Readings that may be right but usually are not are warned about by every command that fits
//! or judges a model, not only by `check`: joint readings outside the robot file's limits
//! (another angle unit, a multi-turn count, a joint's zero) and a `t_s` that goes back in time
//! (rows sorted by something else, sessions with clocks of their own joined). Both used to pass
//! `identify` and `diagnose` in silence.

use crate::common::*;

/// The UR10 file with joint limits of ±180° (its readings reach −234° on joint 1).
fn narrow_limits(dir: &std::path::Path) -> std::path::PathBuf {
    let text = std::fs::read_to_string(ur10_dir().join("robot.toml")).unwrap();
    assert!(text.contains("limits_deg = [-360.0, 360.0]"), "{text}");
    write(
        dir,
        "narrow.toml",
        &text.replace(
            "limits_deg = [-360.0, 360.0]",
            "limits_deg = [-180.0, 180.0]",
        ),
    )
}

#[test]
fn readings_outside_the_joint_limits_are_warned_about_by_every_fitting_command() {
    let dir = tempfile::tempdir().unwrap();
    let robot = narrow_limits(dir.path());
    let data = ur10_rows(dir.path(), "d.csv", 200, |_, _| {});
    // How many rows have a reading beyond ±180°, counted here from the file.
    let text = std::fs::read_to_string(&data).unwrap();
    let beyond = text
        .lines()
        .skip(1)
        .filter(|l| {
            l.split(',')
                .take(6)
                .any(|c| c.parse::<f64>().unwrap().abs() > 180.0)
        })
        .count();
    assert!(beyond > 0);
    let said = format!("{beyond} of 200 poses have readings outside the joint limits of");
    let page = dir.path().join("report.html");
    for command in ["identify", "diagnose", "validate", "report"] {
        let mut args = vec![command, "--robot", s(&robot), "--data", s(&data)];
        if command == "validate" || command == "report" {
            args.extend(["--model", s(&robot)]);
        }
        if command == "report" {
            args.extend(["--out", s(&page)]);
        }
        let out = kinecal(&args);
        let err = stderr(&out);
        assert!(
            err.contains(&said) && err.contains("limits -180") && err.contains("line "),
            "{command}: {err}"
        );
    }
    // Within the limits the file states: nothing said.
    let wide = ur10_dir().join("robot.toml");
    let out = run_on("identify", &wide, &data, &[]);
    assert!(
        !stderr(&out).contains("outside the joint limits"),
        "{}",
        stderr(&out)
    );
}

#[test]
fn a_clock_that_goes_back_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let robot = ur10_dir().join("robot.toml");
    // Two sessions of 100 rows, each with its clock from 0 s, joined.
    let with_time = |name: &str, t: fn(usize) -> f64| {
        let path = ur10_rows(dir.path(), name, 200, |i, cells| {
            cells.push(t(i).to_string())
        });
        let text = std::fs::read_to_string(&path).unwrap();
        let (head, rest) = text.split_once('\n').unwrap();
        write(dir.path(), name, &format!("{head},t_s\n{rest}"))
    };
    let joined = with_time("joined.csv", |i| ((i % 100) * 10) as f64);
    for command in ["check", "identify", "diagnose"] {
        let out = run_on(command, &robot, &joined, &[]);
        let err = stderr(&out);
        assert!(
            err.contains("t_s goes back in time 1 time along the rows")
                && err.contains("from 990 s to 0 s, line 102"),
            "{command}: {err}"
        );
    }
    // Through a map as in kinecal's layout (the file's time column under another name).
    let text = std::fs::read_to_string(&joined).unwrap();
    let renamed = write(
        dir.path(),
        "renamed.csv",
        &text.replacen(",t_s", ",time", 1),
    );
    let map = write(dir.path(), "time.toml", "[columns]\nt_s = \"time\"\n");
    let out = run_on("identify", &robot, &renamed, &["--map", s(&map)]);
    assert!(
        stderr(&out).contains("from 990 s to 0 s, line 102"),
        "{}",
        stderr(&out)
    );
    // In time order, back by less than a second (a clock's jitter), or dates (one clock for
    // every session: the real series A appends rows of earlier days): nothing said.
    let in_order = with_time("in_order.csv", |i| (i * 10) as f64);
    let jitter = with_time("jitter.csv", |i| i as f64 * 0.3 - (i % 2) as f64 * 0.5);
    let dated = with_time("dated.csv", |i| 1.6e9 + ((i % 100) * 10) as f64);
    for data in [&in_order, &jitter, &dated] {
        let out = run_on("check", &robot, data, &[]);
        assert!(!stderr(&out).contains("t_s goes back"), "{}", stderr(&out));
    }
    // Dates in an order of their own (more than 1 % of the steps back): named.
    let shuffled = with_time("shuffled.csv", |i| 1.6e9 + ((i * 37) % 200) as f64 * 10.0);
    let out = run_on("check", &robot, &shuffled, &[]);
    assert!(
        stderr(&out).contains("t_s goes back in time"),
        "{}",
        stderr(&out)
    );
}

/// A joint table whose `start_deg` is a turn off leaves every reading outside its knots: the
/// model adds the end value everywhere, and `check`, `validate` and `compensate` said nothing
/// (validate called such a model holding). Each now warns, naming the knots' range and the
/// readings'; the table as fitted (its knots over the readings) is not warned about.
#[test]
fn a_joint_table_whose_knots_miss_the_readings_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let data = ur10_rows(dir.path(), "d.csv", 200, |_, _| {});
    let text = std::fs::read_to_string(&data).unwrap();
    let q2: Vec<f64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    let lo = q2.iter().fold(f64::INFINITY, |a, b| a.min(*b)).floor();
    let hi = q2.iter().fold(f64::NEG_INFINITY, |a, b| a.max(*b)).ceil();
    let nominal = std::fs::read_to_string(ur10_dir().join("robot.toml")).unwrap();
    let table = |start: f64, knots: usize| {
        format!(
            "{nominal}\n[[effects]]\nkind = \"joint-table\"\njoint = 2\nstep_deg = 10.0\nstart_deg = {start}\nvalues = [{}]\n",
            vec!["0.0"; knots].join(", ")
        )
    };
    let right = write(dir.path(), "right.toml", &table(lo, 40));
    let shifted = write(dir.path(), "shifted.toml", &table(lo + 360.0, 40));
    // Fitted on other angles of the joint (above the readings, 40° wide): a note, not a
    // warning about start_deg.
    let elsewhere = write(dir.path(), "elsewhere.toml", &table(hi + 50.0, 5));
    let warned = |out: &std::process::Output| stderr(out).contains("joint 2's table");
    let out = run_on("check", &right, &data, &[]);
    assert!(out.status.success() && !warned(&out), "{}", stderr(&out));
    let out = run_on("check", &shifted, &data, &[]);
    assert!(out.status.success(), "{}", stderr(&out));
    let err = stderr(&out);
    assert!(
        warned(&out) && err.contains(&format!("0 of {}", q2.len())),
        "{err}"
    );
    assert!(
        err.contains("warning:") && err.contains(&format!("start_deg {lo:.1} (a turn lower)")),
        "{err}"
    );
    // Its sign lost (a table over 40 knots of 10° holds every reading as written).
    let unsigned = write(dir.path(), "unsigned.toml", &table(-lo, 40));
    let err = stderr(&run_on("check", &unsigned, &data, &[]));
    assert!(
        err.contains(&format!("start_deg {lo:.1} (with the other sign)")),
        "{err}"
    );
    let err = stderr(&run_on("check", &elsewhere, &data, &[]));
    assert!(
        err.contains("note:") && err.contains("the others get its end value"),
        "{err}"
    );
    assert!(!err.contains("start_deg"), "{err}");
    // Read through a map as well (the published layout): the same warning.
    let map = write(
        dir.path(),
        "map.toml",
        "[columns]\nq1 = \"q1\"\nq2 = \"q2\"\nq3 = \"q3\"\nq4 = \"q4\"\nq5 = \"q5\"\nq6 = \"q6\"\nx = \"x\"\ny = \"y\"\nz = \"z\"\n",
    );
    let out = run_on("check", &shifted, &data, &["--map", s(&map)]);
    assert!(
        stderr(&out).contains("check its start_deg"),
        "{}",
        stderr(&out)
    );
    let nominal = ur10_dir().join("robot.toml");
    let page = dir.path().join("page.html");
    // `command --robot <the UR10's> --model MODEL --data DATA EXTRA…`.
    let judged = |command: &str, model: &std::path::Path, extra: [&str; 2]| {
        let args = [
            command,
            "--robot",
            s(&nominal),
            "--model",
            s(model),
            "--data",
            s(&data),
        ];
        kinecal(&[&args[..], &extra[..]].concat())
    };
    for (model, expect) in [(&right, false), (&shifted, true)] {
        let out = judged("validate", model, ["--register", "base"]);
        assert_eq!(warned(&out), expect, "{}", stderr(&out));
        // The report page judges the model on the data too: the same line, naming the model.
        let out = judged("report", model, ["--out", s(&page)]);
        let err = stderr(&out);
        assert_eq!(warned(&out), expect, "{err}");
        assert_eq!(
            err.contains(&format!("table in {}", s(model))),
            expect,
            "{err}"
        );
        // … and on the page, among its warnings.
        let html = std::fs::read_to_string(&page).unwrap();
        let doc = scraper::Html::parse_document(&html);
        let warn = scraper::Selector::parse("p.warn").unwrap();
        let on_page = doc
            .select(&warn)
            .any(|p| p.text().collect::<String>().contains("check its start_deg"));
        assert_eq!(on_page, expect, "{html}");
    }
    // The robot file and the model with the same slipped table: told once, with the robot file.
    for command in ["validate", "report"] {
        let mut args = vec![command, "--robot", s(&shifted), "--model", s(&shifted)];
        args.extend(["--data", s(&data), "--register", "base", "--out", s(&page)]);
        if command == "validate" {
            args.truncate(args.len() - 2);
        } else {
            args.retain(|a| *a != "--register" && *a != "base");
        }
        let err = stderr(&kinecal(&args));
        assert_eq!(
            err.matches("joint 2's table").count(),
            1,
            "{command}: {err}"
        );
    }
}
