//! `identify --effect thermal-expansion` on a tracker file with a `temp_c` column: a simulated
//! warm-up of a steel ER20 (15 → 35 °C, 1.2e-5 per kelvin) gives its expansion back, the
//! held-out poses reach the noise floor with the term and stay well above it without.

use crate::common::*;

/// Simulates a warm-up session of `robot` into `out`: `(poses, noise_mm, from:to °C)`, its
/// links expanding by `c` per kelvin, geometric errors from `seed`.
fn warm_up(
    robot: &std::path::Path,
    out: &std::path::Path,
    (poses, noise_mm, range): (&str, &str, &str),
    c: f64,
    seed: u64,
) {
    let (effect, seed) = (format!("thermal-expansion:0:{c}"), seed.to_string());
    kinecal_ok(&[
        "simulate",
        "--robot",
        s(robot),
        "--poses",
        poses,
        "--noise-mm",
        noise_mm,
        "--seed",
        &seed,
        "--geom-errors",
        "--temperature",
        range,
        "--effect",
        &effect,
        "--out",
        s(out),
    ]);
}

#[test]
fn thermal_expansion_is_fitted_from_a_warming_tracker_session() {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file("er20.toml");
    let data = dir.path().join("warm.csv");
    let c = 1.2e-5;
    warm_up(&robot, &data, ("400", "0.01", "15:35"), c, 21);
    let head = std::fs::read_to_string(&data).unwrap();
    assert!(head.lines().next().unwrap().ends_with(",temp_c"), "{head}");
    // Every 5th pose held out: the session's temperatures on both sides.
    let split = ["--json", "--holdout", "0.2", "--split", "every:5"];
    let plain = json_of(&run_on("identify", &robot, &data, &split));
    let mut with_term = split.to_vec();
    with_term.extend(["--effect", "thermal-expansion"]);
    let v = json_of(&run_on("identify", &robot, &data, &with_term));
    assert_eq!(v["converged"], true, "{v}");
    let fitted = v["parameters"]["thermal-expansion1"].as_f64().unwrap();
    let held = |v: &serde_json::Value| v["after"]["validation_rms_mm"].as_f64().unwrap();
    // Noise 0.01 mm per axis: a held-out floor near 0.0173 mm.
    let floor = 0.01 * 3f64.sqrt();
    eprintln!(
        "tracker warm-up 15 -> 35 °C: c = {fitted:e} per K (truth {c:e}); held-out RMS {} mm \
         without the term, {} mm with it (floor {floor:.4})",
        held(&plain),
        held(&v)
    );
    assert!((fitted - c).abs() < 0.05 * c, "c = {fitted:e}");
    assert!(held(&v) < 1.2 * floor, "{v}");
    assert!(held(&plain) > 2.0 * held(&v), "{plain}");
}

/// `diagnose` on the command line names the expansion of a warm-up and exits 0: the finding
/// turns no joint, so its `explanation` has no angle (`peak_to_peak_deg` null) and its size at
/// the tool (a non-finite angle once made every such finding exit 1, found on UR10 series A).
#[test]
fn diagnose_names_thermal_expansion_on_the_command_line() {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file("er20.toml");
    let data = dir.path().join("warm.csv");
    let effect = [
        "--temperature",
        "15:35",
        "--effect",
        "thermal-expansion:0:1.2e-5",
    ];
    simulate(&robot, Some(400), Some(0.01), Some(22), &effect, &data);
    assert_diagnose_names_without_angle(
        &robot,
        &data,
        "thermal-expansion",
        "expands with its temperature",
    );
}

/// A `temp_c` column logged in degrees Fahrenheit (a room at 70 °F) is warned about by every
/// command that reads it, naming the warmest line and the conversion (an arm's own sensors can
/// read 70 °C, so it is not refused); a column no arm reaches (°F of a hot cell, 200) is
/// refused with its line. The same rows in °C are read without a word.
#[test]
fn a_temperature_column_in_fahrenheit_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(ur10_dir().join("ur10_random_poses.csv")).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    assert!(header.ends_with(",temp_c"), "{header}");
    let rows: Vec<&str> = lines.take(100).collect();
    let scaled = |f: &dyn Fn(f64) -> f64| -> Vec<String> {
        rows.iter()
            .map(|l| {
                let (head, c) = l.rsplit_once(',').unwrap();
                format!("{head},{:.2}", f(c.parse::<f64>().unwrap()))
            })
            .collect()
    };
    let file = |name: &str, r: Vec<String>| {
        write(dir.path(), name, &format!("{header}\n{}\n", r.join("\n")))
    };
    let f = file("f.csv", scaled(&|c| c * 1.8 + 32.0));
    let hot = file("hot.csv", scaled(&|c| c + 180.0));
    let c = file("c.csv", scaled(&|c| c));
    let robot = ur10_dir().join("robot.toml");
    for command in ["check", "identify", "diagnose"] {
        let out = run_on(command, &robot, &f, &[]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(0), "{command}: {err}");
        let warned: Vec<&str> = err.lines().filter(|l| l.contains("temp_c")).collect();
        assert!(
            warned.len() == 1
                && warned[0].starts_with("warning: ")
                && warned[0].contains("temp_c reaches 71.")
                && warned[0].contains("Fahrenheit"),
            "{command}: {err}"
        );
        let out = run_on(command, &robot, &hot, &[]);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{command}: {err}");
        assert!(err.contains("hot.csv:2: temp_c"), "{command}: {err}");
        let out = run_on(command, &robot, &c, &[]);
        assert!(
            !stderr(&out).contains("temp_c"),
            "{command}: {}",
            stderr(&out)
        );
    }
}

/// A temperature column that does not follow the arm: the warm-up's temperatures in reverse
/// order fitted a coefficient of −1.2e-5 per kelvin (links shrinking as they warm) with exit 0,
/// and one row at 45 °C among rows at 21 °C fitted one from that row alone. The first is now no
/// calibration (exit 3, identify and diagnose's limit), the second refused (exit 2); the
/// warm-up as simulated is fitted.
#[test]
fn a_temperature_column_that_does_not_follow_the_arm_is_no_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file("er20.toml");
    let data = dir.path().join("warm.csv");
    warm_up(&robot, &data, ("400", "0.01", "15:35"), 1.2e-5, 22);
    let text = std::fs::read_to_string(&data).unwrap();
    let rows: Vec<(&str, &str)> = text.lines().map(|l| l.rsplit_once(',').unwrap()).collect();
    let with_temps = |name: &str, temps: &dyn Fn(usize) -> String| {
        let mut out = format!("{},{}\n", rows[0].0, rows[0].1);
        for (i, (rest, _)) in rows.iter().enumerate().skip(1) {
            out += &format!("{rest},{}\n", temps(i));
        }
        write(dir.path(), name, &out)
    };
    let n = rows.len() - 1;
    let reversed = with_temps("reversed.csv", &|i| rows[n + 1 - i].1.to_string());
    let glitch = with_temps("glitch.csv", &|i| {
        if i == 123 { "45.0" } else { "21.00" }.to_string()
    });
    let term = ["--json", "--effect", "thermal-expansion"];
    let right = run_on("identify", &robot, &data, &term);
    assert_eq!(right.status.code(), Some(0), "{}", stderr(&right));
    let out = run_on("identify", &robot, &reversed, &term);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("shrink as they warm"),
        "{}",
        stderr(&out)
    );
    // Over 1 K and 80 noisy poses the data do not determine the coefficient (−10 ± 24 ppm):
    // a warning, not a refusal.
    let (ur10, narrow) = (ur10_dir().join("robot.toml"), dir.path().join("narrow.csv"));
    warm_up(&ur10, &narrow, ("80", "0.05", "21:22"), 1.2e-5, 1);
    let out = run_on("identify", &ur10, &narrow, &term);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("the data do not determine it"),
        "{}",
        stderr(&out)
    );
    // The real UR10 session's air temperature determines a coefficient no arm has.
    let out = run_on(
        "identify",
        &ur10,
        &ur10_dir().join("ur10_random_poses.csv"),
        &term,
    );
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("beyond the 100 ppm"),
        "{}",
        stderr(&out)
    );
    let out = run_on("identify", &robot, &glitch, &term);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("on only 1 of 400 rows"),
        "{}",
        stderr(&out)
    );
}

/// A model whose thermal expansion is referred to 73.6 °C (fitted to a `temp_c` in °F) sent
/// to a controller, which feeds its sensor's °C, is warned about by `export --format
/// firmware`; one referred to 22 °C is not.
#[test]
fn exporting_a_model_referred_to_fahrenheit_is_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let er20 = std::fs::read_to_string(crate::common::data_file("er20.toml")).unwrap();
    for (reference, warned) in [(73.6, true), (22.0, false)] {
        let text = format!(
            "{er20}\n[[effects]]\nkind = \"thermal-expansion\"\njoint = 0\nvalues = [1.3e-5]\nreference_c = {reference}\n"
        );
        let model = crate::common::write(dir.path(), "m.toml", &text);
        let blob = dir.path().join("m.kcm");
        let out = crate::common::kinecal(&[
            "export",
            "--model",
            s(&model),
            "--format",
            "firmware",
            "--out",
            s(&blob),
        ]);
        assert!(out.status.success(), "{}", stderr(&out));
        let err = stderr(&out);
        assert_eq!(err.contains("reference_c is 73.6 °C"), warned, "{err}");
    }
}

/// `compensate` evaluates a model's thermal expansion at each target's `temp_c`: targets of a
/// warm-up's true arm at 35 °C are reached within 0.01 mm with it, and missed by tenths of
/// a millimetre without it, with a warning (stderr and JSON `temperature_warning`) naming the
/// reference temperature used; `validate` warns about a session without temperatures.
#[test]
fn compensate_and_validate_use_the_arms_temperature() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = data_file("er20.toml");
    let (data, truth, model) = (d.join("warm.csv"), d.join("t.toml"), d.join("m.toml"));
    let sim = [
        "simulate",
        "--robot",
        s(&robot),
        "--poses",
        "300",
        "--noise-mm",
        "0.01",
    ];
    let more = ["--seed", "3", "--geom-errors", "--temperature", "15:35"];
    let last = [
        "--effect",
        "thermal-expansion:0:2e-5",
        "--out",
        s(&data),
        "--truth",
        s(&truth),
    ];
    kinecal_ok(&[&sim[..], &more[..], &last[..]].concat());
    let fit = ["--effect", "thermal-expansion", "--out", s(&model)];
    let o = run_on("identify", &robot, &data, &fit);
    assert!(o.status.success(), "{}", stderr(&o));
    // Targets: the true arm's points at 35 °C (with a temp_c column), and the same without it.
    let hot = d.join("hot.csv");
    let sim = [
        "simulate",
        "--robot",
        s(&truth),
        "--poses",
        "8",
        "--noise-mm",
        "0",
    ];
    kinecal_ok(
        &[
            &sim[..],
            &["--seed", "9", "--temperature", "35:35", "--out", s(&hot)],
        ]
        .concat(),
    );
    let text = std::fs::read_to_string(&hot).unwrap();
    let plain: String = text
        .lines()
        .map(|l| l.rsplit_once(',').unwrap().0.to_string() + "\n")
        .collect();
    let cold = write(d, "no_temp.csv", &plain);
    let truth_robot = kinecal_cli::formats::robot_file::RobotFile::load(&truth)
        .unwrap()
        .to_robot::<6>()
        .unwrap();
    let mut worst = Vec::new();
    for (targets, warned) in [(&hot, false), (&cold, true)] {
        let out = d.join("q.csv");
        let args = ["compensate", "--model", s(&model), "--targets", s(targets)];
        let o = kinecal_ok(&[&args[..], &["--out", s(&out), "--json"]].concat());
        let j = json_of(&o);
        assert_eq!(j["temperature_warning"].is_string(), warned, "{j}");
        assert_eq!(
            stderr(&o).contains("thermal expansion is evaluated at its reference"),
            warned
        );
        // Each command on the true arm at 35 °C against its target.
        let commands = std::fs::read_to_string(&out).unwrap();
        let mut fk = kinecal::ForwardKinematics::<f64, 6>::new();
        fk.temp_c = Some(35.0);
        let mut max = 0.0f64;
        for (c, t) in commands.lines().skip(1).zip(text.lines().skip(1)) {
            let q: Vec<f64> = c
                .split(',')
                .take(6)
                .map(|v| v.parse::<f64>().unwrap().to_radians())
                .collect();
            let p: Vec<f64> = t
                .split(',')
                .skip(6)
                .take(3)
                .map(|v| v.parse().unwrap())
                .collect();
            let reached = fk.compute(&truth_robot, &q.try_into().unwrap());
            max = max.max((reached - nalgebra::Vector3::new(p[0], p[1], p[2])).norm());
        }
        worst.push(max);
    }
    eprintln!(
        "targets at 35 °C: worst {:.4} mm with temp_c, {:.4} mm without",
        worst[0], worst[1]
    );
    assert!(worst[0] < 0.01 && worst[1] > 0.1, "{worst:?}");
    let o = run_on("validate", &robot, &cold, &["--model", s(&model)]);
    assert!(
        stderr(&o).contains("has no temp_c column"),
        "{}",
        stderr(&o)
    );
    // A targets file logged in °F (77) is warned about; one no arm works at (160) refused, as
    // a measurement file's: compensate took any temp_c with status ok and exit 0.
    for (t, code) in [("77", 0), ("160", 2)] {
        let at: String = plain
            .lines()
            .enumerate()
            .map(|(k, l)| format!("{l},{}\n", if k == 0 { "temp_c" } else { t }))
            .collect();
        let targets = write(d, &format!("t{t}.csv"), &at);
        let out = d.join("q.csv");
        let args = ["compensate", "--model", s(&model), "--targets", s(&targets)];
        let o = kinecal(&[&args[..], &["--out", s(&out)]].concat());
        let err = stderr(&o);
        assert_eq!(o.status.code(), Some(code), "{err}");
        let told = if code == 0 {
            "temp_c reaches 77 °C"
        } else {
            "160 °C is not"
        };
        assert!(err.contains(told), "{err}");
    }
}

/// A warm-up logged with `t_s` but no `temp_c` looks like a drifting tracker or a creeping
/// reflector, which `diagnose` named with confidence: it now says the arm warming may be the
/// cause and how to tell them apart; with the `temp_c` column it names the expansion and says
/// nothing of the kind.
#[test]
fn diagnose_without_temperatures_names_the_arm_warming_beside_a_drift() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = data_file("er20.toml");
    let data = d.join("warm.csv");
    let sim = [
        "simulate",
        "--robot",
        s(&robot),
        "--poses",
        "400",
        "--noise-mm",
        "0.01",
    ];
    let more = [
        "--seed",
        "61",
        "--geom-errors",
        "--temperature",
        "15:35",
        "--session-s",
        "3600",
    ];
    let last = ["--effect", "thermal-expansion:0:1.2e-5", "--out", s(&data)];
    kinecal_ok(&[&sim[..], &more[..], &last[..]].concat());
    let text = std::fs::read_to_string(&data).unwrap();
    let head: Vec<&str> = text.lines().next().unwrap().split(',').collect();
    let t = head.iter().position(|c| *c == "temp_c").unwrap();
    let without: String = text
        .lines()
        .map(|l| {
            let mut c: Vec<&str> = l.split(',').collect();
            c.remove(t);
            c.join(",") + "\n"
        })
        .collect();
    let no_temp = write(d, "no_temp.csv", &without);
    const WARMING: &str = "may be the arm warming up";
    let o = run_on("diagnose", &robot, &no_temp, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains(WARMING), "{}", stderr(&o));
    let o = run_on("diagnose", &robot, &data, &["--json"]);
    assert!(!stderr(&o).contains(WARMING), "{}", stderr(&o));
    let found = json_of(&o)["found"].to_string();
    assert!(found.contains("thermal-expansion"), "{found}");
    // A step at one row (the tracker bumped by 0.35 mm after row 100) is no warming.
    let plain = d.join("plain.csv");
    let sim = [
        "simulate",
        "--robot",
        s(&robot),
        "--poses",
        "200",
        "--noise-mm",
        "0.02",
    ];
    kinecal_ok(&[&sim[..], &["--seed", "7", "--out", s(&plain)]].concat());
    let stepped: String = std::fs::read_to_string(&plain)
        .unwrap()
        .lines()
        .enumerate()
        .map(|(k, l)| {
            let mut c: Vec<String> = l.split(',').map(String::from).collect();
            if k > 100 {
                c[6] = format!("{:.6}", c[6].parse::<f64>().unwrap() + 0.3);
                c[8] = format!("{:.6}", c[8].parse::<f64>().unwrap() - 0.2);
            }
            c.join(",") + "\n"
        })
        .collect();
    let stepped = write(d, "stepped.csv", &stepped);
    let o = run_on("diagnose", &robot, &stepped, &[]);
    let err = stderr(&o);
    assert!(
        err.contains("the residuals step by") && !err.contains(WARMING),
        "{err}"
    );
}

/// A robot file with `thermal-expansion` values `[2e-5]` and no `reference_c`: every command
/// read it at 20 °C, `identify` at the data's mean (a session at 28–32 °C made from the file
/// itself: `check` 5e-9 mm, identify's "before" 0.158 mm), and wrote that reference. Now
/// identify's starting model is the file's robot (its "before" at the noise) and the model it
/// writes keeps 20 °C; a term with a zero coefficient is still referred to the mean.
#[test]
fn a_thermal_term_without_reference_means_20_c_in_identify_too() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let text = std::fs::read_to_string(data_file("er20.toml")).unwrap();
    let with = |c: &str| {
        format!("{text}\n[[effects]]\nkind = \"thermal-expansion\"\njoint = 0\nvalues = [{c}]\n")
    };
    let robot = write(d, "r.toml", &with("2e-5"));
    let session = |name: &str, errors: bool| {
        let data = d.join(name);
        let mut args = vec![
            "simulate",
            "--robot",
            s(&robot),
            "--poses",
            "200",
            "--noise-mm",
            "0.01",
            "--seed",
            "4",
            "--temperature",
            "28:32",
            "--out",
            s(&data),
        ];
        if errors {
            args.push("--geom-errors");
        }
        kinecal_ok(&args);
        data
    };
    // The file's own robot: identify starts at the noise (and cannot improve on it: exit 3).
    let own = session("own.csv", false);
    let out = run_on("identify", &robot, &own, &["--holdout", "0.3", "--json"]);
    let j: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let before = j["before"]["identification_rms_mm"].as_f64().unwrap();
    assert!(before < 0.03, "before {before} mm: not the file's robot");
    // A robot with geometric errors: the model written keeps the file's 20 °C.
    let data = session("m.csv", true);
    // The reference_c of the model identify writes from the robot file `from`.
    let reference = |from: &std::path::Path| -> f64 {
        let cal = d.join("cal.toml");
        let out = run_on(
            "identify",
            from,
            &data,
            &["--holdout", "0.3", "--out", s(&cal)],
        );
        assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
        let written = std::fs::read_to_string(&cal).unwrap();
        written
            .lines()
            .find_map(|l| l.trim().strip_prefix("reference_c = "))
            .unwrap_or_else(|| panic!("{written}"))
            .parse()
            .unwrap()
    };
    assert_eq!(reference(&robot), 20.0);
    // A zero coefficient (as --effect adds the term) is referred to the data's mean.
    let zero = reference(&write(d, "z.toml", &with("0.0")));
    assert!((28.0..32.0).contains(&zero), "{zero}");
}
