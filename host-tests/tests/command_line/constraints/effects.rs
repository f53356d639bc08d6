//! Effects estimated with the model from a constraint session: a requested joint effect and
//! thermal expansion from a warming session (and its refusals).

use super::*;

#[test]
fn an_effect_requested_on_a_constraint_file_is_estimated_with_the_model() {
    let dir = tempfile::tempdir().unwrap();
    // A cyclic error of joint 2 (a = 0.002 rad, b = −0.001 rad: millimetres at the tool) and
    // no other error.
    let (data, truth) = session_of(
        dir.path(),
        "socket:4x10,distance:40",
        7,
        &["--effect", "joint-cyclic:2:0.002,-0.001:1"],
    );
    let (plain, with) = (dir.path().join("plain.toml"), dir.path().join("with.toml"));
    let v0 = identify(&data, &["--out", s(&plain)]);
    let v1 = identify(&data, &["--effect", "joint-cyclic:2:1", "--out", s(&with)]);
    assert_eq!(v1["converged"], true, "{v1}");
    let estimated = names(&v1["estimated"]);
    for p in ["joint-cyclic2.n1.a", "joint-cyclic2.n1.b"] {
        assert!(
            estimated.contains(&p.to_string()),
            "{p} not estimated: {estimated:?}"
        );
    }
    let (a, b) = (
        v1["parameters"]["joint-cyclic2.n1.a"].as_f64().unwrap(),
        v1["parameters"]["joint-cyclic2.n1.b"].as_f64().unwrap(),
    );
    let nominal = tool_point_rms(&data_file("er20.toml"), &truth, false);
    let (e0, e1) = (
        tool_point_rms(&plain, &truth, false),
        tool_point_rms(&with, &truth, false),
    );
    eprintln!(
        "cyclic error of joint 2 from sockets and distances: tool point RMS {nominal} mm \
         nominal, {e0} mm geometry only, {e1} mm with --effect (a = {a}, b = {b} rad)"
    );
    // The geometry alone cannot follow the cyclic term; with it the model reaches the noise.
    assert!(e1 * 4.0 < e0, "{e1} mm with the effect, {e0} mm without");
    assert!(e1 < 0.05, "{e1} mm");
    assert!(
        (a - 0.002).abs() < 2e-4 && (b + 0.001).abs() < 2e-4,
        "a = {a}, b = {b}"
    );
    let ident = |v: &serde_json::Value| v["after"]["identification_rms_mm"].as_f64().unwrap();
    assert!(ident(&v1) < ident(&v0), "{v0}\n{v1}");
}

#[test]
fn thermal_expansion_on_a_constraint_file_without_temperatures_is_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10", 3);
    let out = kinecal(&[
        "identify",
        "--robot",
        s(&data_file("er20.toml")),
        "--data",
        s(&data),
        "--effect",
        "thermal-expansion",
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("no temp_c column"),
        "{}",
        stderr(&out)
    );
}

/// A warming arm measured with a ball bar: `pairs` distance groups of the ER20 whose lengths
/// expand by `c` per kelvin from 25 °C, the rows' `temp_c` rising from 15 to 35 °C over the
/// session (0.002 mm noise on the lengths); returns the file.
fn warming_distances(dir: &Path, pairs: usize, c: f64, temp_column: bool) -> PathBuf {
    use kinecal::model::effects::EffectKind;
    use rand::{RngExt, SeedableRng};
    let (_, nominal) = load_robot::<6>(&data_file("er20.toml")).unwrap();
    let mut truth = nominal.clone();
    truth
        .effects_mut()
        .push(EffectKind::Thermal, 0, 6, 1, 25.0, 0.0, &[c])
        .unwrap();
    let mut rng = kinecal_cli::simulation::Streams::new(77).configs;
    let qs = kinecal_cli::simulation::random_configurations(&truth, 2 * pairs, &mut rng);
    let mut noise = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(78);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let mut text = String::from("kind,group,q1,q2,q3,q4,q5,q6,length_mm");
    text += if temp_column { ",temp_c\n" } else { "\n" };
    for k in 0..pairs {
        let temp = |i: usize| 15.0 + 20.0 * i as f64 / (2 * pairs - 1) as f64;
        let (a, b) = (2 * k, 2 * k + 1);
        let pa = fk.compute_at(&truth, &qs[a], 0, Some(temp(a))).unwrap();
        let pb = fk.compute_at(&truth, &qs[b], 0, Some(temp(b))).unwrap();
        let length = (pa - pb).norm() + 0.002 * (noise.random::<f64>() - 0.5) * 3.46;
        for i in [a, b] {
            let q: Vec<String> = qs[i].iter().map(|v| v.to_degrees().to_string()).collect();
            text += &format!("distance,bar{k},{},{length}", q.join(","));
            text += &if temp_column {
                format!(",{}\n", temp(i))
            } else {
                "\n".to_string()
            };
        }
    }
    write(dir, "warming.csv", &text)
}

#[test]
fn thermal_expansion_is_fitted_from_a_warming_ball_bar_session() {
    let dir = tempfile::tempdir().unwrap();
    let c = 2.0e-5;
    let data = warming_distances(dir.path(), 120, c, true);
    let plain = identify(&data, &[]);
    let model = dir.path().join("model.toml");
    let v = identify(
        &data,
        &["--effect", "thermal-expansion", "--out", s(&model)],
    );
    assert_eq!(v["converged"], true, "{v}");
    assert!(
        names(&v["estimated"]).contains(&"thermal-expansion1".to_string()),
        "{v}"
    );
    let fitted = v["parameters"]["thermal-expansion1"].as_f64().unwrap();
    let rms = |v: &serde_json::Value| v["after"]["identification_rms_mm"].as_f64().unwrap();
    eprintln!(
        "ball bar, 15 -> 35 °C: c = {fitted:e} per K (truth {c:e}); length RMS {} mm without \
         the term, {} mm with it",
        rms(&plain),
        rms(&v)
    );
    // The expansion is the only error: c comes back within 3 %, and the lengths that the
    // geometry alone cannot follow (up to 0.4 mm over the session) fit to the noise.
    assert!((fitted - c).abs() < 0.03 * c, "c = {fitted}");
    assert!(rms(&v) < 0.003, "{v}");
    assert!(rms(&plain) > 5.0 * rms(&v), "{plain}");
    // The reference of a term --effect adds is the rows' mean temperature (25 °C, not the
    // file default of 20 °C); a robot file whose term has a coefficient and no reference_c is
    // read at 20 °C and refitted there (below).
    let text = std::fs::read_to_string(&model).unwrap();
    assert!(text.contains("reference_c = 25"), "{text}");
    let bare: String = text
        .lines()
        .filter(|l| !l.trim_start().starts_with("reference_c"))
        .map(|l| format!("{l}\n"))
        .collect();
    let bare = write(dir.path(), "bare.toml", &bare);
    let again = dir.path().join("again.toml");
    let v2 = json_of(&kinecal_ok(&[
        "identify",
        "--robot",
        s(&bare),
        "--data",
        s(&data),
        "--json",
        "--out",
        s(&again),
    ]));
    let refitted = v2["parameters"]["thermal-expansion1"].as_f64().unwrap();
    assert!((refitted - c).abs() < 0.03 * c, "c = {refitted}");
    // A term with a coefficient and no reference_c means 20 °C, as in every command.
    let text = std::fs::read_to_string(&again).unwrap();
    assert!(text.contains("reference_c = 20"), "{text}");
}

#[test]
fn a_simulated_warming_constraint_session_gives_back_its_expansion() {
    let dir = tempfile::tempdir().unwrap();
    let c = 2.0e-5;
    let (data, truth) = session_of(
        dir.path(),
        "socket:4x10,plane:2x12,distance:40",
        5,
        &[
            "--temperature",
            "15:35",
            "--effect",
            &format!("thermal-expansion:0:{c}"),
        ],
    );
    // The rows are written warming from 15 to 35 °C in their order.
    let text = std::fs::read_to_string(&data).unwrap();
    let temps: Vec<f64> = text
        .lines()
        .skip(1)
        .map(|l| l.rsplit(',').next().unwrap().parse().unwrap())
        .collect();
    assert!(text.lines().next().unwrap().ends_with(",temp_c"), "{text}");
    assert_eq!((temps[0], temps[temps.len() - 1]), (15.0, 35.0));
    assert!(temps.windows(2).all(|w| w[1] >= w[0]));
    let (plain, with) = (dir.path().join("plain.toml"), dir.path().join("with.toml"));
    let v0 = identify(&data, &["--out", s(&plain)]);
    let v1 = identify(&data, &["--effect", "thermal-expansion", "--out", s(&with)]);
    assert_eq!(v1["converged"], true, "{v1}");
    let fitted = v1["parameters"]["thermal-expansion1"].as_f64().unwrap();
    let rms = |v: &serde_json::Value| v["after"]["identification_rms_mm"].as_f64().unwrap();
    let (e0, e1) = (
        tool_point_rms(&plain, &truth, false),
        tool_point_rms(&with, &truth, false),
    );
    eprintln!(
        "simulated warming session (sockets, planes, distances): c = {fitted:e} per K (truth \
         {c:e}); identification RMS {} -> {} mm, tool point RMS {e0} -> {e1} mm",
        rms(&v0),
        rms(&v1)
    );
    assert!((fitted - c).abs() < 0.05 * c, "c = {fitted}");
    assert!(rms(&v1) * 3.0 < rms(&v0), "{v0}\n{v1}");
    assert!(e1 < 0.05, "{e1} mm");
}

#[test]
fn constraint_temperatures_missing_on_a_row_or_implausible_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let data = warming_distances(dir.path(), 10, 2.0e-5, true);
    let text = std::fs::read_to_string(&data).unwrap();
    let mut lines: Vec<String> = text.lines().map(str::to_string).collect();
    let cut = lines[1].rfind(',').unwrap();
    let (blank, hot) = (
        format!("{},", &lines[1][..cut]),
        format!("{},5000", &lines[1][..cut]),
    );
    for (row, want) in [
        (blank, "temp_c column with the arm's temperature"),
        (hot, "temp_c 5000 is not a temperature"),
    ] {
        lines[1] = row;
        let bad = write(dir.path(), "bad.csv", &(lines.join("\n") + "\n"));
        let out = kinecal(&[
            "identify",
            "--robot",
            s(&data_file("er20.toml")),
            "--data",
            s(&bad),
            "--effect",
            "thermal-expansion",
        ]);
        assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
        assert!(stderr(&out).contains(want), "{}", stderr(&out));
    }
}

/// A constraint session gives the expansion no σ, so an impossible coefficient cannot be
/// refused as on tracker points; it is warned about (the temperatures reversed fit a
/// shrinking arm), and `diagnose` refuses the finding instead of calling the geometry complete.
/// A `temp_c` in °F is warned about as in tracker files. The session as measured gets neither.
#[test]
fn impossible_expansions_and_fahrenheit_in_a_constraint_session_are_told() {
    let dir = tempfile::tempdir().unwrap();
    let data = warming_distances(dir.path(), 120, 2.0e-5, true);
    let text = std::fs::read_to_string(&data).unwrap();
    let rows: Vec<&str> = text.lines().collect();
    let temps: Vec<&str> = rows[1..]
        .iter()
        .map(|l| l.rsplit(',').next().unwrap())
        .collect();
    // The same rows with the temperatures in reverse order, and in °F.
    let (mut reversed, mut fahrenheit) = (rows[0].to_string() + "\n", rows[0].to_string() + "\n");
    for (i, l) in rows[1..].iter().enumerate() {
        let head = &l[..l.rfind(',').unwrap()];
        reversed += &format!("{head},{}\n", temps[temps.len() - 1 - i]);
        let f = temps[i].parse::<f64>().unwrap() * 9.0 / 5.0 + 32.0;
        fahrenheit += &format!("{head},{f}\n");
    }
    let reversed = write(dir.path(), "reversed.csv", &reversed);
    let fahrenheit = write(dir.path(), "fahrenheit.csv", &fahrenheit);
    let robot = data_file("er20.toml");
    let run = |command: &str, data: &Path| {
        let mut args = vec![command, "--robot", s(&robot), "--data", s(data)];
        if command == "identify" {
            args.extend(["--effect", "thermal-expansion"]);
        }
        let out = kinecal(&args);
        assert!(out.status.success(), "{command}: {}", stderr(&out));
        (
            String::from_utf8_lossy(&out.stdout).to_string(),
            stderr(&out),
        )
    };
    let (_, err) = run("identify", &reversed);
    assert!(err.contains("lies outside the -5.0 to 100 ppm"), "{err}");
    let (out, _) = run("diagnose", &reversed);
    assert!(
        out.contains("refused: the thermal expansion would be -"),
        "{out}"
    );
    assert!(!out.contains("nothing significant is missing"), "{out}");
    let (_, err) = run("identify", &fahrenheit);
    assert!(
        err.contains("temp_c reaches") && err.contains("Fahrenheit"),
        "{err}"
    );
    let (_, err) = run("identify", &data);
    assert!(!err.contains("warning"), "{err}");
    let (out, _) = run("diagnose", &data);
    assert!(out.contains("found thermal-expansion"), "{out}");
}
