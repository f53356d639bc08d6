//! `plan --constraints` (a planned session against a random one) and `diagnose` on a constraint
//! session.

use super::*;

/// `plan --constraints SPEC --criterion CRITERION` of the ER20 into `out`, its JSON.
fn plan_session(out: &Path, spec: &str, criterion: &str, extra: &[&str]) -> serde_json::Value {
    let robot = data_file("er20.toml");
    let mut args = vec![
        "plan",
        "--robot",
        s(&robot),
        "--constraints",
        spec,
        "--criterion",
        criterion,
        "--out",
        s(out),
        "--json",
    ];
    args.extend_from_slice(extra);
    json_of(&kinecal_ok(&args))
}

#[test]
fn a_planned_socket_session_calibrates_better_than_a_random_one_as_predicted() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let spec = "socket:4x8,distance:16";
    let (planned, random) = (d.join("plan.csv"), d.join("random.csv"));
    let p = plan_session(&planned, spec, "d", &[]);
    let r = plan_session(&random, spec, "random", &[]);
    assert_eq!(p["rows"], 64);
    assert_eq!(p["pool_rows"], 256);
    let (p_sigma, r_sigma) = (
        p["predicted_tool_mm"].as_f64().unwrap(),
        r["predicted_tool_mm"].as_f64().unwrap(),
    );
    // The same candidates: the random plan is the planner's starting point.
    assert_eq!(p["random_tool_mm"], r["predicted_tool_mm"]);
    assert!(p_sigma < 0.8 * r_sigma, "{p_sigma} vs {r_sigma}");
    for b in BASE {
        assert!(
            names(&p["cannot_determine"]).contains(&b.to_string()),
            "{b}: {p}"
        );
    }
    // Each plan measured on three robots with different errors, identified, and judged on
    // fresh poses against the truth (aligned: the base is not seen).
    let robot = data_file("er20.toml");
    let mut realised = [0.0f64; 2];
    for seed in 1..=3u64 {
        for (k, plan) in [&planned, &random].into_iter().enumerate() {
            let (data, truth, model) = (
                d.join(format!("s{k}{seed}.csv")),
                d.join(format!("t{k}{seed}.toml")),
                d.join(format!("m{k}{seed}.toml")),
            );
            let seed_text = seed.to_string();
            kinecal_ok(&[
                "simulate",
                "--robot",
                s(&robot),
                "--plan",
                s(plan),
                "--geom-errors",
                "--noise-mm",
                "0.01",
                "--seed",
                &seed_text,
                "--out",
                s(&data),
                "--truth",
                s(&truth),
            ]);
            identify(&data, &["--out", s(&model)]);
            let e = tool_point_rms(&model, &truth, false);
            println!("seed {seed}: {} plan: {e:.5} mm", ["planned", "random"][k]);
            realised[k] += e * e / 3.0;
        }
    }
    let (pe, re) = (realised[0].sqrt(), realised[1].sqrt());
    println!(
        "planned: predicted {p_sigma:.5} mm, realised {pe:.5} mm; random: predicted {r_sigma:.5} \
         mm, realised {re:.5} mm"
    );
    assert!(pe < re, "planned {pe} mm, random {re} mm");
    for (what, predicted, got) in [("planned", p_sigma, pe), ("random", r_sigma, re)] {
        assert!(
            got > 0.4 * predicted && got < 2.5 * predicted,
            "{what}: realised {got} mm, predicted {predicted} mm"
        );
    }
    // The accuracy a user asks for: how many times the groups it takes, planned.
    let a = plan_session(&d.join("more.csv"), spec, "d", &["--accuracy-mm", "0.006"]);
    let need = &a["accuracy"];
    assert_eq!(need["reached"], true, "{a}");
    assert!(need["times_the_groups"].as_u64().unwrap() >= 2, "{a}");
    assert!(need["predicted_tool_mm"].as_f64().unwrap() <= 0.006, "{a}");
}

/// A planned session with no more equations than the parameters it is for is refused (exit 2)
/// with its count, as `identify` refuses such a session measured, and one with fewer than 10 to
/// spare is warned about (identify's warning); the count is a socket's row 3, a plane's row and
/// a distance 1, less 3 for each socket centre and plane.
#[test]
fn a_plan_that_any_robot_meets_exactly_is_refused_and_a_thin_one_warned_about() {
    let dir = tempfile::tempdir().unwrap();
    let (robot, out) = (data_file("er20.toml"), dir.path().join("p.csv"));
    let plan = |spec: &str, criterion: &str| {
        let args = ["plan", "--robot", s(&robot), "--constraints", spec];
        kinecal(&[&args[..], &["--criterion", criterion, "--out", s(&out)]].concat())
    };
    for (spec, equations) in [("distance:16", 16), ("plane:2x5", 4), ("socket:1x4", 9)] {
        for criterion in ["random", "d"] {
            let o = plan(spec, criterion);
            let err = stderr(&o);
            assert_eq!(o.status.code(), Some(2), "{spec} {criterion}: {err}");
            assert!(
                err.contains(&format!("give {equations} equations"))
                    && err.contains("identify refuses it"),
                "{spec}: {err}"
            );
        }
    }
    let warned = |spec: &str| {
        let o = plan(spec, "d");
        assert!(o.status.success(), "{spec}: {}", stderr(&o));
        stderr(&o).contains("to spare")
    };
    // The ER20's distance sessions are for 18 parameters, socket sessions for 16.
    assert!(warned("distance:22") && warned("socket:2x4"));
    assert!(!warned("distance:28") && !warned("socket:3x4"));
    // The refused plan's session, measured, is refused by identify as well.
    let (data, truth) = (dir.path().join("d.csv"), dir.path().join("t.toml"));
    let sim = [
        "simulate",
        "--robot",
        s(&robot),
        "--constraints",
        "distance:16",
    ];
    let more = [
        "--geom-errors",
        "--noise-mm",
        "0.01",
        "--out",
        s(&data),
        "--truth",
        s(&truth),
    ];
    kinecal_ok(&[&sim[..], &more[..]].concat());
    let o = kinecal(&["identify", "--robot", s(&robot), "--data", s(&data)]);
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
}

/// `diagnose --json` on the constraint session `data` (extra flags appended), asserting exit 0.
fn diagnose(data: &Path, extra: &[&str]) -> serde_json::Value {
    json_on("diagnose", data, extra)
}

#[test]
fn diagnose_finds_a_cyclic_error_in_a_socket_session_and_nothing_in_a_geometric_one() {
    let dir = tempfile::tempdir().unwrap();
    let split = ["--holdout", "0.25", "--split", "random"];
    // Joint 2's cyclic error (a = 0.002, b = -0.001 rad) and no other error.
    let cyclic = dir.path().join("cyclic");
    std::fs::create_dir(&cyclic).unwrap();
    let (data, _) = session_of(
        &cyclic,
        "socket:4x10,distance:40",
        7,
        &["--effect", "joint-cyclic:2:0.002,-0.001:1"],
    );
    let model = dir.path().join("model.toml");
    let mut args = split.to_vec();
    args.extend_from_slice(&["--out", s(&model)]);
    let v = diagnose(&data, &args);
    println!("{v}");
    assert_eq!(v["count_unit"], "groups");
    // The keys of diagnose on tracker points: found in the order added, each with its
    // effect, joint, values and validation RMS.
    let found = v["found"].as_array().unwrap();
    assert_eq!(found.len(), 1, "{v}");
    assert_eq!(found[0]["effect"], "joint-cyclic");
    assert_eq!(found[0]["joint"], 2);
    assert_eq!(found[0]["request"], "joint-cyclic:2:1");
    let (a, b) = (
        found[0]["values"]["joint-cyclic2.n1.a"].as_f64().unwrap(),
        found[0]["values"]["joint-cyclic2.n1.b"].as_f64().unwrap(),
    );
    assert!(
        (a - 0.002).abs() < 2e-4 && (b + 0.001).abs() < 2e-4,
        "a = {a}, b = {b}"
    );
    // The held-out groups' gap shrinks to the noise (0.01 mm per contact).
    let h = &v["held_out"];
    let (geometric, extended) = (
        h["geometric_mm"].as_f64().unwrap(),
        h["extended_mm"].as_f64().unwrap(),
    );
    assert!(extended * 10.0 < geometric, "{h}");
    assert!(extended < 0.03, "{h}");
    assert_eq!(v["validation"], "held-out groups");
    assert_eq!(v["baseline_validation_rms_mm"], h["geometric_mm"]);
    assert_eq!(v["final_validation_rms_mm"], h["extended_mm"]);
    // Down to what the stated σ leaves.
    let floor = v["noise_floor_mm"].as_f64().unwrap();
    assert!(
        extended < 2.0 * floor && floor > 0.005,
        "{extended} mm, floor {floor} mm"
    );
    assert_eq!(v["held_out_worse"], false);
    // The model written carries the effect: identify on it starts at the noise.
    let text = std::fs::read_to_string(&model).unwrap();
    assert!(text.contains("joint-cyclic"), "{text}");
    // Geometry alone: nothing is found, the best candidate is named and refused.
    let plain = dir.path().join("plain");
    std::fs::create_dir(&plain).unwrap();
    let (data, _) = session(&plain, "socket:4x10,distance:40", 7);
    let w = diagnose(&data, &split);
    assert!(w["found"].as_array().unwrap().is_empty(), "{w}");
    let rounds = w["rounds"].as_array().unwrap();
    assert_eq!(rounds.len(), 1, "{w}");
    assert_eq!(rounds[0]["accepted"], false);
    // Flags of tracker sessions are refused in one line.
    let out = kinecal(&[
        "diagnose",
        "--robot",
        s(&data_file("er20.toml")),
        "--data",
        s(&data),
        "--plots",
        s(dir.path()),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(stderr(&out).trim().lines().count(), 1, "{}", stderr(&out));
}
