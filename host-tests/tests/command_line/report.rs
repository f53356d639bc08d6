//! `kinecal report`: the calibration report as one self-contained HTML page. Its
//! numbers are identify's (the same functions on the same files), every parameter of the model
//! is in its table, what was held is listed with the reason, the diagnose findings appear with
//! their figures, and the page holds no script and no URL.

use crate::common::{
    json_of, kinecal, kinecal_ok, s, stderr, ur10_dir, write, ER20_PLACED, LBR7_PLACED,
};
use kinecal_cli::output::numfmt::sig;
use scraper::{Html, Selector};
use std::path::{Path, PathBuf};

fn sel(css: &str) -> Selector {
    Selector::parse(css).unwrap()
}

/// The text of the single element matching `css`.
fn text(doc: &Html, css: &str) -> String {
    let all: Vec<String> = doc
        .select(&sel(css))
        .map(|e| e.text().collect::<String>().trim().to_string())
        .collect();
    assert_eq!(all.len(), 1, "{css}: {} elements", all.len());
    all[0].clone()
}

/// The printed cell of a statistic (`after.validation.total.rms`).
fn cell(doc: &Html, key: &str) -> String {
    text(doc, &format!("td[data-key=\"{key}\"]"))
}

fn num(v: &serde_json::Value, path: &[&str]) -> f64 {
    let mut v = v;
    for k in path {
        v = &v[*k];
    }
    v.as_f64()
        .unwrap_or_else(|| panic!("{path:?} is not a number: {v}"))
}

/// What every page must be: one document, self-contained, readable without a network or a
/// script, printable on A4 and readable on a phone.
fn assert_self_contained(html: &str) -> Html {
    let lower = html.to_ascii_lowercase();
    assert!(!lower.contains("<script"), "a script in the page");
    for url in ["http://", "https://", "//cdn", "url("] {
        assert!(
            !lower.contains(url),
            "an external reference `{url}` in the page"
        );
    }
    assert!(
        !lower.contains(" src=") && !lower.contains(" href="),
        "a link in the page"
    );
    assert!(lower.starts_with("<!doctype html>"));
    assert!(lower.contains("@page { size: a4"), "A4 print rule");
    let doc = Html::parse_document(html);
    assert!(
        doc.errors.is_empty() || doc.errors.len() < 3,
        "{:?}",
        doc.errors
    );
    assert_eq!(doc.select(&sel("html")).count(), 1);
    assert_eq!(doc.select(&sel("h1")).count(), 1);
    assert_eq!(
        doc.select(&sel("meta[name=viewport]")).count(),
        1,
        "viewport meta"
    );
    let svgs: Vec<_> = doc.select(&sel("figure svg")).collect();
    assert!(svgs.len() >= 3, "{} figures", svgs.len());
    for svg in &svgs {
        assert!(svg
            .value()
            .attr("viewbox")
            .or(svg.value().attr("viewBox"))
            .is_some());
    }
    // Every table scrolls sideways on a narrow screen.
    for t in doc.select(&sel("main table")) {
        let parent = t.parent().and_then(scraper::ElementRef::wrap).unwrap();
        let class = parent.value().attr("class").unwrap_or_default();
        assert!(class.split(' ').any(|c| c == "scroll"), "{class}");
    }
    doc
}

/// The first `n` data rows and the rest of a CSV file, as two files with its header.
fn split_csv(src: &Path, n: usize, dir: &Path) -> (PathBuf, PathBuf) {
    let text = std::fs::read_to_string(src).unwrap();
    let mut lines = text.lines();
    let header = lines.next().unwrap();
    let rows: Vec<&str> = lines.collect();
    let join = |r: &[&str]| format!("{header}\n{}\n", r.join("\n"));
    (
        write(dir, "ident.csv", &join(&rows[..n])),
        write(dir, "valid.csv", &join(&rows[n..])),
    )
}

/// Runs identify and report on the same files; returns identify's JSON, report's JSON and
/// the page.
fn identify_and_report(
    robot: &Path,
    data: &Path,
    split: &[&str],
    extra_report: &[&str],
    dir: &Path,
) -> (serde_json::Value, serde_json::Value, String) {
    let model = dir.join("model.toml");
    let mut args = vec!["identify", "--robot", s(robot), "--data", s(data)];
    args.extend_from_slice(split);
    args.extend(["--out", s(&model), "--json"]);
    let ident = json_of(&kinecal_ok(&args));
    let out = dir.join("report.html");
    let mut args = vec![
        "report",
        "--robot",
        s(robot),
        "--model",
        s(&model),
        "--data",
        s(data),
        "--out",
        s(&out),
        "--json",
    ];
    args.extend_from_slice(split);
    args.extend_from_slice(extra_report);
    let t = std::time::Instant::now();
    let rep = json_of(&kinecal_ok(&args));
    let html = std::fs::read_to_string(&out).unwrap();
    eprintln!(
        "report: {} bytes in {:.2} s (command {:.2} s)",
        html.len(),
        num(&rep, &["seconds"]),
        t.elapsed().as_secs_f64()
    );
    assert_eq!(rep["bytes"].as_u64(), Some(html.len() as u64));
    (ident, rep, html)
}

/// The page's numbers against identify's JSON: before/after totals (to the printed digits,
/// and the report's JSON to the bit), every parameter, the held ones with their reasons.
fn assert_numbers_are_identifys(ident: &serde_json::Value, rep: &serde_json::Value, doc: &Html) {
    // Before: the same nominal robot, bit for bit. After: the model as read back from the file
    // identify wrote (degrees with the shortest round-tripping decimals: an ulp of an angle).
    assert_eq!(
        ident["before"], rep["before"],
        "before: report JSON = identify JSON"
    );
    let keys = ident["after"].as_object().unwrap();
    assert_eq!(keys.len(), rep["after"].as_object().unwrap().len());
    for (k, v) in keys {
        let (a, b) = (v.as_f64().unwrap(), num(&rep["after"], &[k]));
        assert!(
            (a - b).abs() <= 1e-9 * a.abs(),
            "after.{k}: identify {a}, report {b}"
        );
    }
    for model in ["before", "after"] {
        let i = &ident[model];
        for (key, id) in [
            ("identification.total.rms", "identification_rms_mm"),
            ("validation.total.rms", "validation_rms_mm"),
            ("validation.total.mean", "validation_mean_mm"),
            ("validation.total.max", "validation_max_mm"),
        ] {
            assert_eq!(
                cell(doc, &format!("{model}.{key}")),
                sig(num(i, &[id]), 4),
                "{model}.{key}"
            );
        }
        if let Some(deg) = i.get("validation_rms_deg") {
            assert_eq!(
                cell(doc, &format!("{model}.validation.orientation.rms")),
                sig(deg.as_f64().unwrap(), 4)
            );
        }
    }
    // ISO 9283: the nominal model commands, so the mean distance is identify's mean "before".
    assert_eq!(
        cell(doc, "iso.held_out.before.mean"),
        sig(num(ident, &["before", "validation_mean_mm"]), 4)
    );
    // Every parameter of the model, with identify's values.
    let params = ident["parameters"].as_object().unwrap();
    let rows = doc.select(&sel("table#params tbody tr")).count();
    assert_eq!(rows, params.len(), "one row per parameter of the model");
    for (name, v) in params {
        let row = format!("table#params tr[data-param=\"{name}\"]");
        assert_eq!(
            text(doc, &format!("{row} td.calibrated")),
            sig(v.as_f64().unwrap(), 7),
            "{name}"
        );
    }
    for (name, c) in ident["changes"].as_object().unwrap() {
        let row = format!("table#params tr[data-param=\"{name}\"]");
        assert_eq!(
            text(doc, &format!("{row} td.nominal")),
            sig(num(c, &["nominal"]), 7)
        );
        assert_eq!(
            text(doc, &format!("{row} td.change")),
            sig(num(c, &["change"]), 3)
        );
        // 1-σ: identify's own fit over the same data, printed with identify's digits.
        if let Some(sd) = c["sigma"].as_f64() {
            assert_eq!(text(doc, &format!("{row} td.sigma")), sig(sd, 2), "{name}");
            let r = &rep["parameters"][name];
            assert_eq!(r["status"], "estimated", "{name}");
        }
    }
    // What identify held, listed with the reason; nothing else held.
    let held = ident["held"].as_object().unwrap();
    assert_eq!(doc.select(&sel("ul#held li")).count(), held.len());
    for (name, h) in held {
        let li = text(doc, &format!("ul#held li[data-param=\"{name}\"]"));
        let with: Vec<&str> = h["confounded_with"]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| v.as_str().unwrap())
            .collect();
        if with.is_empty() {
            assert!(li.contains("no observation moves with it"), "{li}");
        } else {
            for w in &with {
                assert!(li.contains(w), "{name}: {li} lacks {w}");
            }
        }
        assert_eq!(
            text(
                doc,
                &format!("table#params tr[data-param=\"{name}\"] td.status")
            ),
            "held"
        );
    }
    // Correlations are coefficients.
    for c in rep["correlations"].as_array().unwrap() {
        let r = num(c, &["r"]);
        assert!((-1.0..=1.0).contains(&r), "{r}");
    }
}

/// The UR10 series: the first 1,000 poses identify, the 1,773 others are held out (as split
/// files and `--validate`, and again with `--holdout 1773` on the whole file).
#[test]
fn ur10_report_shows_identifys_numbers() {
    let d = ur10_dir();
    let robot = d.join("robot.toml");
    let tmp = tempfile::tempdir().unwrap();
    let (ident_csv, valid_csv) = split_csv(&d.join("ur10_random_poses.csv"), 1000, tmp.path());
    let (ident, rep, html) = identify_and_report(
        &robot,
        &ident_csv,
        &["--validate", s(&valid_csv)],
        &[],
        tmp.path(),
    );
    assert_eq!(rep["n_identification"], 1000);
    assert_eq!(rep["n_validation"], 1773);
    let doc = assert_self_contained(&html);
    assert_numbers_are_identifys(&ident, &rep, &doc);
    // The data section: joint coverage of six joints.
    assert_eq!(doc.select(&sel("table#joint-coverage tbody tr")).count(), 6);
    // The figures: histogram, error against each joint (six panels), workspace.
    for id in ["histogram", "joints", "workspace"] {
        assert_eq!(doc.select(&sel(&format!("figure#fig-{id} svg"))).count(), 1);
    }
    // The headline says before and after on the held-out poses.
    let headline = text(&doc, "p.headline");
    assert!(
        headline.contains(&sig(num(&ident, &["after", "validation_rms_mm"]), 4)),
        "{headline}"
    );
    assert_eq!(text(&doc, "#verdict"), "calibrated");
    // `--holdout 1773` on the whole file: the same split, the same figures.
    let model = tmp.path().join("model.toml");
    let out2 = tmp.path().join("r2.html");
    let again = json_of(&kinecal_ok(&[
        "report",
        "--robot",
        s(&robot),
        "--model",
        s(&model),
        "--data",
        s(&d.join("ur10_random_poses.csv")),
        "--holdout",
        "1773",
        "--out",
        s(&out2),
        "--json",
    ]));
    assert_eq!(again["before"], rep["before"]);
    assert_eq!(again["after"], rep["after"]);
    assert!(html.len() < 1_500_000, "{} bytes", html.len());
}

/// 6-D rows with σ (the UR10 series with its probe's orientations): the orientation RMS before
/// and after is identify's too, and the 1-σ come from the same weighting.
#[test]
fn ur10_six_d_report_shows_identifys_numbers() {
    let d = ur10_dir();
    let tmp = tempfile::tempdir().unwrap();
    let (ident, rep, html) = identify_and_report(
        &d.join("robot.toml"),
        &d.join("ur10_random_poses_6d.csv"),
        &["--holdout", "1773"],
        &[],
        tmp.path(),
    );
    assert!(ident["after"]["validation_rms_deg"].is_number());
    let doc = assert_self_contained(&html);
    assert_numbers_are_identifys(&ident, &rep, &doc);
    assert!(text(&doc, "#data p").contains("6-D poses with the tracker"));
}

/// A simulated robot with a hidden cyclic error on joint 2: the diagnose JSON's findings
/// appear on the page with their figures, and user strings are escaped.
#[test]
fn diagnose_findings_appear_with_their_plots() {
    let tmp = tempfile::tempdir().unwrap();
    let named = ER20_PLACED.replacen(
        "name = \"ER20-C10-like 6R\"",
        "name = \"ER20 <b>&</b> \\\"co\\\"\"",
        1,
    );
    assert_ne!(named, ER20_PLACED, "the name line");
    let robot = write(tmp.path(), "robot.toml", &named);
    let data = tmp.path().join("d.csv");
    crate::common::simulate(
        &robot,
        Some(300),
        Some(0.01),
        Some(7),
        &["--effect", "joint-cyclic:2:0.001,0.0005"],
        &data,
    );
    let diag = kinecal(&[
        "diagnose",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--json",
    ]);
    let dj = json_of(&diag);
    let found = dj["found"].as_array().unwrap();
    assert!(
        found
            .iter()
            .any(|f| f["effect"] == "joint-cyclic" && f["joint"] == 2),
        "diagnose finds the hidden effect: {found:?}"
    );
    let j = write(
        tmp.path(),
        "diagnose.json",
        &serde_json::to_string(&dj).unwrap(),
    );
    let (ident, rep, html) = identify_and_report(
        &robot,
        &data,
        &["--holdout", "0.3"],
        &["--diagnose", s(&j)],
        tmp.path(),
    );
    let doc = assert_self_contained(&html);
    assert_numbers_are_identifys(&ident, &rep, &doc);
    assert_eq!(rep["findings"].as_u64(), Some(found.len() as u64));
    let items = doc.select(&sel("ul#findings li")).count();
    assert_eq!(items, found.len());
    for (k, f) in found.iter().enumerate() {
        let li = format!(
            "ul#findings li[data-effect=\"{}\"][data-joint=\"{}\"]",
            f["effect"].as_str().unwrap(),
            f["joint"]
        );
        let t = text(&doc, &li);
        assert!(t.contains(f["sentence"].as_str().unwrap()), "{t}");
        assert!(t.contains(&sig(num(f, &["validation_rms_mm"]), 4)));
        if f["effect"] == "joint-cyclic" {
            let fig = format!("figure#fig-finding-{} svg", k + 1);
            assert_eq!(doc.select(&sel(&fig)).count(), 1, "{fig}");
        }
    }
    assert_eq!(doc.select(&sel("figure#fig-diagnose-steps svg")).count(), 1);
    // The robot's name is shown as text, escaped: no element made of it.
    assert_eq!(text(&doc, "h1"), "ER20 <b>&</b> \"co\"");
    assert!(html.contains("ER20 &lt;b&gt;&amp;&lt;"), "escaped");
    assert_eq!(doc.select(&sel("h1 b")).count(), 0);
}

/// Refused (exit 2, one line saying what to give): a model of another robot, a diagnose file
/// that is not one, a page over an input. Never exit 0 on nonsense.
#[test]
fn refuses_what_does_not_belong_together() {
    let tmp = tempfile::tempdir().unwrap();
    let robot = write(tmp.path(), "robot.toml", ER20_PLACED);
    let data = tmp.path().join("d.csv");
    crate::common::simulate(
        &robot,
        Some(60),
        Some(0.01),
        Some(3),
        &["--geom-errors"],
        &data,
    );
    let model = tmp.path().join("m.toml");
    kinecal_ok(&[
        "identify",
        "--robot",
        s(&robot),
        "--data",
        s(&data),
        "--out",
        s(&model),
    ]);
    let out = tmp.path().join("r.html");
    let report = |model: &Path, extra: &[&str]| {
        let mut a = vec![
            "report",
            "--robot",
            s(&robot),
            "--model",
            s(model),
            "--data",
            s(&data),
            "--out",
            s(&out),
        ];
        a.extend_from_slice(extra);
        kinecal(&a)
    };
    let refused = |o: std::process::Output, needle: &str| {
        assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
        let e = stderr(&o);
        assert_eq!(e.trim().lines().count(), 1, "{e}");
        assert!(e.contains(needle), "{e}");
    };
    // A 7-joint model for a 6-joint robot.
    let lbr = write(tmp.path(), "lbr.toml", LBR7_PLACED);
    refused(report(&lbr, &[]), "7-joint");
    // Another 6-joint robot (the UR10) is not an identified model of the ER20.
    refused(
        report(&ur10_dir().join("robot.toml"), &[]),
        "not an identified model",
    );
    // A JSON that is not diagnose's.
    let j = write(tmp.path(), "j.json", "{\"poses\": 3}");
    refused(report(&model, &["--diagnose", s(&j)]), "kinecal diagnose");
    // A finding on a joint the robot does not have.
    let j = write(
        tmp.path(),
        "j9.json",
        "{\"baseline_validation_rms_mm\":1,\"final_validation_rms_mm\":1,\"noise_floor_mm\":0.1,\
         \"found\":[{\"effect\":\"joint-scale\",\"joint\":9,\"values\":[0.001],\"validation_rms_mm\":1}]}",
    );
    refused(report(&model, &["--diagnose", s(&j)]), "joint 9");
    // The page over the data file.
    let o = kinecal(&[
        "report",
        "--robot",
        s(&robot),
        "--model",
        s(&model),
        "--data",
        s(&data),
        "--out",
        s(&data),
    ]);
    refused(o, "data file");
    assert!(!out.exists(), "nothing written when refused");
    // And a fine run exits 0 with the page written.
    let o = report(&model, &[]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(out.exists());
    // A model of this robot that misses the data by centimetres (d2 off by 60 mm) is not a
    // calibration of them: the page is written and says so, exit 3.
    let mut m: toml::Value = toml::from_str(&std::fs::read_to_string(&model).unwrap()).unwrap();
    let d2 = &mut m["joints"][1]["d_mm"];
    let v = d2.as_float().or(d2.as_integer().map(|i| i as f64)).unwrap();
    *d2 = toml::Value::Float(v + 60.0);
    let off = write(tmp.path(), "off.toml", &toml::to_string(&m).unwrap());
    let o = report(&off, &[]);
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let doc = Html::parse_document(&std::fs::read_to_string(&out).unwrap());
    assert_eq!(text(&doc, "#verdict"), "not a calibration of these data");
}
