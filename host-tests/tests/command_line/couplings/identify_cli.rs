//! `identify` on a coupled file equals `identify` on data converted to model angles beforehand.

use super::*;

/// The model angles (rad) of a row's readings (deg), computed as the library's pipeline does
/// (degrees → radians, then the couplings), each as degrees that read back as those very
/// radians; `None` when some angle has no such degree value (a few per cent do not: the
/// degree → radian map skips some doubles).
fn exact_model_deg(f: &RobotFile, q_deg: &[f64]) -> Option<Vec<f64>> {
    let rad: Vec<f64> = q_deg.iter().map(|d| d.to_radians()).collect();
    to_model(f, &rad)
        .into_iter()
        .map(|x| {
            let d = deg_exact(x);
            (d.to_radians() == x).then_some(d)
        })
        .collect()
}

/// Writes `ds` with every row converted from readings to model angles. `exact = false`: as a
/// user would, in degrees (for ratio ±1 the decimal sum of the readings); `exact = true`: the
/// model angles in radians written as degrees that read back bit-exact (see
/// [`exact_model_deg`]; a ratio like −1.3 otherwise rounds differently in degrees and radians,
/// by an ulp, and the comparison would measure the LM's stopping tolerance rather than the
/// couplings).
fn preconvert<const N: usize>(f: &RobotFile, ds: &Dataset<N>, path: &Path, exact: bool) {
    let mut text: String = (1..=N).map(|i| format!("q{i},")).collect();
    text.push_str("x,y,z\n");
    for r in &ds.records {
        let q: Vec<f64> = if exact {
            exact_model_deg(f, &r.q_deg).expect("rows filtered to exact ones")
        } else {
            to_model(f, &r.q_deg)
        };
        for q in q {
            text.push_str(&format!("{q},"));
        }
        let [x, y, z] = r.xyz_mm;
        text.push_str(&format!("{x},{y},{z}\n"));
    }
    std::fs::write(path, text).unwrap();
}

fn identify_equivalence<const N: usize>(text: &str, tag: &str, exact: bool) {
    let dir = tempfile::tempdir().unwrap();
    let f = parse(text);
    let coupled = write(dir.path(), &format!("{tag}.toml"), text);
    let plain = write(
        dir.path(),
        &format!("{tag}-plain.toml"),
        &uncoupled(&f).to_toml().unwrap(),
    );
    let id = dir.path().join("id.csv");
    simulate(
        &coupled,
        Some(140),
        Some(0.01),
        Some(3),
        &["--geom-errors"],
        &id,
    );
    let mut ds = measurements::load::<N>(&id).unwrap();
    if exact {
        ds.records
            .retain(|r| exact_model_deg(&f, &r.q_deg).is_some());
        assert!(ds.len() >= 100, "{} exact rows", ds.len());
        measurements::write(&id, &ds).unwrap();
    }
    let id_m = dir.path().join("id_m.csv");
    preconvert(&f, &ds, &id_m, exact);
    let (m1, m2) = (dir.path().join("m1.toml"), dir.path().join("m2.toml"));
    let a = json_of(&run_on(
        "identify",
        &coupled,
        &id,
        &["--holdout", "0.3", "--json", "--out", s(&m1)],
    ));
    let b = json_of(&run_on(
        "identify",
        &plain,
        &id_m,
        &["--holdout", "0.3", "--json", "--out", s(&m2)],
    ));
    assert_eq!(a["n_validation"], b["n_validation"]);
    assert!(a["n_validation"].as_u64().unwrap() >= 30, "{a}");
    for k in [
        "identification_rms_mm",
        "validation_rms_mm",
        "validation_max_mm",
    ] {
        for phase in ["before", "after"] {
            let (x, y) = (a[phase][k].as_f64().unwrap(), b[phase][k].as_f64().unwrap());
            assert!((x - y).abs() <= 1e-9, "{tag} {phase}.{k}: {x} vs {y}");
        }
    }
    assert!(a["after"]["validation_rms_mm"].as_f64().unwrap() < 0.05);
    assert!(a["before"]["validation_rms_mm"].as_f64().unwrap() > 0.5);
    let (pa, pb) = (
        a["parameters"].as_object().unwrap(),
        b["parameters"].as_object().unwrap(),
    );
    assert_eq!(pa.len(), pb.len());
    for (name, x) in pa {
        let (x, y) = (x.as_f64().unwrap(), pb[name].as_f64().unwrap());
        assert!(
            (x - y).abs() <= 1e-9 * (1.0 + y.abs()),
            "{tag} {name}: {x} vs {y}"
        );
    }
    // The identified model keeps its couplings; the plain one has none.
    let m1f = RobotFile::load(&m1).unwrap();
    assert_eq!(m1f.couplings, f.couplings);
    assert!(RobotFile::load(&m2).unwrap().couplings.is_empty());
}

#[test]
fn identify_on_coupled_file_equals_identify_on_preconverted_data() {
    identify_equivalence::<6>(&fanuc_text(), "fanuc", false);
    identify_equivalence::<7>(ARM7, "arm7", true);
}
