//! `check`, the residual table and `report` on a constraint session: each agrees with what
//! `identify` judged.

use super::*;

/// `check --json` of `data` on the ER20, asserting exit 0.
fn check(data: &Path) -> serde_json::Value {
    json_on("check", data, &[])
}

#[test]
fn check_reads_a_constraint_session_as_identify_starts_from_it() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10,plane:3x15,distance:30", 3);
    let c = check(&data);
    assert_eq!(c["count_unit"], "groups");
    assert_eq!(c["groups"], 4 + 3 + 30, "{c}");
    assert_eq!(c["rows"], 40 + 45 + 60, "{c}");
    assert_eq!(c["joint_ranges_deg"].as_array().unwrap().len(), 6);
    // The nominal figures per kind are identify's "before" on the same rows.
    let v = identify(&data, &[]);
    let kinds = c["kinds"].as_array().unwrap();
    let before = v["constraints"]["kinds"].as_array().unwrap();
    assert_eq!(kinds.len(), 3);
    for (k, b) in kinds.iter().zip(before) {
        assert_eq!(k["kind"], b["kind"]);
        assert_eq!(k["groups"], b["groups"]);
        assert_eq!(k["rows"], b["rows"]);
        let (x, y) = (
            k["nominal_rms_mm"].as_f64().unwrap(),
            b["before_rms_mm"].as_f64().unwrap(),
        );
        assert!((x - y).abs() <= 1e-9 * y, "{}: {x} against {y}", k["kind"]);
        assert!(x > 0.1, "{k}: the geometric errors are millimetres");
    }
    let blind = names(&c["cannot_determine"]);
    for b in BASE {
        assert!(blind.contains(&b.to_string()), "{b}: {blind:?}");
    }
    // Identify holds at the end what check found it cannot determine at the start.
    let held = names(&v["unidentifiable"]);
    assert_eq!(
        blind.len(),
        held.len(),
        "check {blind:?}, identify {held:?}"
    );
}

#[test]
fn check_names_the_scale_that_sockets_alone_cannot_see() {
    let dir = tempfile::tempdir().unwrap();
    let non_base = |spec: &str| {
        let (data, _) = session(dir.path(), spec, 5);
        let blind = names(&check(&data)["cannot_determine"]);
        for b in BASE {
            assert!(blind.contains(&b.to_string()), "{spec}: {b}: {blind:?}");
        }
        blind.iter().filter(|n| !n.starts_with("base.")).count()
    };
    let (sockets, distances) = (non_base("socket:8x10"), non_base("distance:60"));
    assert_eq!(
        sockets,
        distances + 1,
        "sockets {sockets}, distances {distances}"
    );
}

#[test]
fn residuals_of_a_constraint_fit_add_up_to_its_report() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10,plane:3x15,distance:30", 3);
    let table = dir.path().join("residuals.csv");
    let v = identify(
        &data,
        &[
            "--holdout",
            "0.25",
            "--split",
            "random",
            "--residuals",
            s(&table),
        ],
    );
    let text = std::fs::read_to_string(&table).unwrap();
    let mut lines = text.lines();
    assert_eq!(
        lines.next(),
        Some("set,kind,group,line,nominal_mm,model_mm")
    );
    // (set, group) → the nominal and model values of its rows.
    let mut groups: std::collections::BTreeMap<(String, String), Vec<(f64, f64)>> =
        Default::default();
    let mut ident_rows = Vec::new();
    for l in lines {
        let c: Vec<&str> = l.split(',').collect();
        assert_eq!(c.len(), 6, "{l}");
        let line: usize = c[3].parse().unwrap();
        assert!(line >= 2, "{l}");
        let (a, b): (f64, f64) = (c[4].parse().unwrap(), c[5].parse().unwrap());
        if c[0] == "identification" {
            ident_rows.push((a, b));
        } else {
            assert_eq!(c[0], "held-out", "{l}");
        }
        groups
            .entry((c[0].to_string(), c[2].to_string()))
            .or_default()
            .push((a, b));
    }
    let rms = |e: &[f64]| (e.iter().map(|x| x * x).sum::<f64>() / e.len() as f64).sqrt();
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-6 + 1e-5 * y.abs();
    let (before, after) = (&v["before"], &v["after"]);
    let a: Vec<f64> = ident_rows.iter().map(|r| r.0).collect();
    let b: Vec<f64> = ident_rows.iter().map(|r| r.1).collect();
    let f = |x: &serde_json::Value| x.as_f64().unwrap();
    assert!(
        close(rms(&a), f(&before["identification_rms_mm"])),
        "{}",
        rms(&a)
    );
    assert!(
        close(rms(&b), f(&after["identification_rms_mm"])),
        "{}",
        rms(&b)
    );
    // A held-out group's residual is the RMS of its rows against its own refitted shape.
    let held: Vec<&Vec<(f64, f64)>> = groups
        .iter()
        .filter(|((set, _), _)| set == "held-out")
        .map(|(_, r)| r)
        .collect();
    assert_eq!(held.len(), v["n_validation"].as_u64().unwrap() as usize);
    let per_group = |k: fn(&(f64, f64)) -> f64| {
        let g: Vec<f64> = held
            .iter()
            .map(|r| rms(&r.iter().map(k).collect::<Vec<_>>()))
            .collect();
        rms(&g)
    };
    assert!(close(per_group(|r| r.0), f(&before["validation_rms_mm"])));
    assert!(close(per_group(|r| r.1), f(&after["validation_rms_mm"])));
    let idg = groups
        .keys()
        .filter(|(set, _)| set == "identification")
        .count();
    assert_eq!(idg, v["n_identification"].as_u64().unwrap() as usize);
}

#[test]
fn report_on_a_constraint_session_shows_each_kind_as_identify_judged_it() {
    let dir = tempfile::tempdir().unwrap();
    let (data, _) = session(dir.path(), "socket:4x10,plane:3x15,distance:30", 3);
    let robot = data_file("er20.toml");
    let (model, page) = (dir.path().join("model.toml"), dir.path().join("page.html"));
    let split = ["--holdout", "0.25", "--split", "random", "--seed", "4"];
    let mut args = vec!["--out", s(&model)];
    args.extend_from_slice(&split);
    let v = identify(&data, &args);
    let report = |model: &Path, page: &Path| {
        let mut a = vec![
            "report",
            "--robot",
            s(&robot),
            "--data",
            s(&data),
            "--model",
            s(model),
            "--out",
            s(page),
            "--json",
        ];
        a.extend_from_slice(&split);
        kinecal(&a)
    };
    let out = report(&model, &page);
    assert!(out.status.success(), "{}", stderr(&out));
    let r = json_of(&out);
    // The page's figures are identify's: the same split, the same model.
    let close = |a: &serde_json::Value, b: &serde_json::Value| {
        let (a, b) = (a.as_f64().unwrap(), b.as_f64().unwrap());
        (a - b).abs() <= 1e-9 * b.abs().max(1.0)
    };
    for set in ["before", "after"] {
        for key in [
            "identification_rms_mm",
            "validation_rms_mm",
            "validation_max_mm",
        ] {
            assert!(close(&r[set][key], &v[set][key]), "{set}.{key}: {r} vs {v}");
        }
    }
    for key in ["n_identification", "n_validation", "n_identification_rows"] {
        assert_eq!(r[key], v[key], "{key}");
    }
    let kinds = r["constraints"]["kinds"].as_array().unwrap();
    let want = v["constraints"]["kinds"].as_array().unwrap();
    assert_eq!(kinds.len(), 3);
    for (a, b) in kinds.iter().zip(want) {
        assert_eq!(a["kind"], b["kind"]);
        assert!(close(&a["after_rms_mm"], &b["after_rms_mm"]), "{a} vs {b}");
    }
    // Held out per kind: the groups add up, and the calibrated model is better on each kind.
    let held = r["held_out"].as_array().unwrap();
    let groups: u64 = held.iter().map(|k| k["groups"].as_u64().unwrap()).sum();
    assert_eq!(groups, v["n_validation"].as_u64().unwrap());
    for k in held {
        assert!(
            k["after_rms_mm"].as_f64().unwrap() * 3.0 < k["before_rms_mm"].as_f64().unwrap(),
            "{k}"
        );
    }
    assert_eq!(r["converged"], true);
    let base: Vec<String> = r["cannot_determine"]
        .as_array()
        .unwrap()
        .iter()
        .map(|n| n.as_str().unwrap().to_string())
        .collect();
    for b in BASE {
        assert!(base.contains(&b.to_string()), "{b}: {base:?}");
    }
    assert!(!r["changed"].as_array().unwrap().is_empty());
    let html = std::fs::read_to_string(&page).unwrap();
    assert_eq!(r["bytes"].as_u64().unwrap() as usize, html.len());
    for needle in ["Held-out", "socket", "plane", "distance", "<svg", "base.x"] {
        assert!(html.contains(needle), "{needle} not on the page");
    }
    // Another robot's truth as the "model": worse than the nominal robot on the held-out
    // groups, exit 3, and the page says so.
    let other = dir.path().join("other");
    std::fs::create_dir(&other).unwrap();
    let (_, wrong) = session(&other, "socket:2x4", 11);
    let bad_page = dir.path().join("bad.html");
    let out = report(&wrong, &bad_page);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(r["held_out_worse"], true, "{r}");
    let html = std::fs::read_to_string(&bad_page).unwrap();
    assert!(
        html.contains("Not a calibration"),
        "the page hides the verdict"
    );
    // Flags that belong to tracker sessions are refused in one line.
    let out = kinecal(&[
        "report",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--model",
        s(&model),
        "--out",
        s(&dir.path().join("x.html")),
        "--validate",
        s(&data),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(stderr(&out).trim().lines().count(), 1, "{}", stderr(&out));
}
