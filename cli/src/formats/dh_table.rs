//! `kinecal export --format dh-table`: one row per geometric parameter of a robot file with
//! its nominal and calibrated value and their difference, as CSV or JSON.

use crate::formats::robot_file::RobotFile;
use serde::Serialize;

/// One row: `parameter, unit, nominal, calibrated, delta` (delta = calibrated - nominal).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DhRow {
    pub parameter: String,
    pub unit: String,
    pub nominal: Option<f64>,
    pub calibrated: Option<f64>,
    pub delta: Option<f64>,
}

/// The parameters of a file in table order: base x, y, z (mm), rx, ry, rz (deg, the
/// `rpy_deg` of `[base]`), per joint alpha, a, theta, d, beta (an `axis-tilt` effect's when the
/// file has one), then the tool point.
/// `None` where the file has no `[base]`.
pub fn parameters(f: &RobotFile) -> Vec<(String, &'static str, Option<f64>)> {
    let mut v = Vec::new();
    let b = f.base.as_ref();
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        v.push((format!("base_{name}_mm"), "mm", b.map(|b| b.xyz_mm[k])));
    }
    for (k, name) in ["rx", "ry", "rz"].iter().enumerate() {
        v.push((format!("base_{name}_deg"), "deg", b.map(|b| b.rpy_deg[k])));
    }
    for (i, j) in f.joints.iter().enumerate() {
        let n = i + 1;
        v.push((format!("joint{n}_alpha_deg"), "deg", Some(j.alpha_deg)));
        v.push((format!("joint{n}_a_mm"), "mm", Some(j.a_mm)));
        v.push((format!("joint{n}_theta_deg"), "deg", Some(j.theta_deg)));
        v.push((format!("joint{n}_d_mm"), "mm", Some(j.d_mm)));
        // A fitted tilt is written as an `axis-tilt` effect (radians), which overrides
        // `beta_deg` (docs/formats.md, "Effects").
        let tilt = f
            .effects
            .iter()
            .find(|e| e.kind == crate::formats::robot_file::AXIS_TILT && e.joint == n)
            .and_then(|e| e.values.first())
            .map(|b| b.to_degrees());
        v.push((
            format!("joint{n}_beta_deg"),
            "deg",
            Some(tilt.unwrap_or(j.beta_deg.unwrap_or(0.0))),
        ));
    }
    for (k, name) in ["x", "y", "z"].iter().enumerate() {
        v.push((format!("tool_{name}_mm"), "mm", Some(f.tool.xyz_mm[k])));
    }
    v
}

/// The table of `model` against `nominal` (same number of joints; checked by the caller).
pub fn table(model: &RobotFile, nominal: Option<&RobotFile>) -> Vec<DhRow> {
    let cal = parameters(model);
    let nom = nominal.map(parameters);
    cal.into_iter()
        .enumerate()
        .map(|(i, (parameter, unit, calibrated))| {
            let nominal = nom.as_ref().and_then(|n| n[i].2);
            let delta = match (nominal, calibrated) {
                (Some(n), Some(c)) => Some(c - n),
                _ => None,
            };
            DhRow {
                parameter,
                unit: unit.to_string(),
                nominal,
                calibrated,
                delta,
            }
        })
        .collect()
}

fn cell(v: Option<f64>) -> String {
    v.map(|v| format!("{v}")).unwrap_or_default()
}

/// CSV text: a header line, then one line per row (numbers as the shortest decimals that read
/// back as the same `f64`; empty cells where a value is unknown).
pub fn to_csv(rows: &[DhRow]) -> String {
    let mut s = String::from("parameter,unit,nominal,calibrated,delta\n");
    for r in rows {
        s.push_str(&format!(
            "{},{},{},{},{}\n",
            r.parameter,
            r.unit,
            cell(r.nominal),
            cell(r.calibrated),
            cell(r.delta)
        ));
    }
    s
}

/// JSON text: an array of objects with the CSV's keys (`null` where a value is unknown).
pub fn to_json(rows: &[DhRow]) -> String {
    serde_json::to_string_pretty(rows).unwrap_or_else(|_| "[]".into()) + "\n"
}
