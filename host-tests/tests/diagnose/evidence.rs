//! Evidence beyond joint angles against known truth: the thermal expansion of every length
//! (the library's kinematics, Jacobian column and compensation at a temperature, the robot
//! file, `kinecal diagnose` on a simulated warm-up).

use crate::common::effect;
use kinecal_cli::HostRobot;

use kinecal::compensate::{compensate, Config, Target};
use kinecal::model::effects::EffectKind;
use kinecal::model::param::Param;
use kinecal::{ForwardKinematics, Measurement};
use kinecal_cli::diagnose::candidates::CandidateKind;
use kinecal_cli::diagnose::time_trend::{trend, warning};
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::simulation::{simulate_at, GeomErrors, Simulation};
use nalgebra::Vector3;
use std::path::PathBuf;

pub fn er20() -> HostRobot<6> {
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data");
    RobotFile::load(&dir.join("er20.toml"))
        .unwrap()
        .to_robot::<6>()
        .unwrap()
}

/// Steel: 1.2e-5 per kelvin.
const STEEL: f64 = 1.2e-5;

/// The ER20 placed 2 m from the tracker with a steel thermal-expansion term (T0 = 25 °C).
pub fn warm_robot() -> HostRobot<6> {
    let mut r = er20();
    r.set_base(kinecal::Frame::from_xyz_rpy(
        [2000.0, -300.0, 100.0],
        [0.0, 0.0, 0.4],
    ))
    .unwrap();
    r.effects_mut()
        .push(EffectKind::Thermal, 0, 6, 1, 25.0, 0.0, &[STEEL])
        .unwrap();
    r
}

const Q: [f64; 6] = [0.3, -0.5, 0.4, 1.1, -0.7, 0.9];

/// At temperature T every joint origin and the point move away from the base origin by
/// 1 + c·(T − T0); at T0 (or without a temperature) nothing changes; orientations never do.
#[test]
fn kinematics_scale_every_length_about_the_base() {
    let r = warm_robot();
    let b = r.base().o;
    let mut fk = ForwardKinematics::new();
    let cold = fk.compute(&r, &Q);
    let cold_z = fk.frames[5].z;
    assert_eq!(fk.compute_at(&r, &Q, 0, Some(25.0)).unwrap(), cold);
    let hot = fk.compute_at(&r, &Q, 0, Some(45.0)).unwrap();
    let s = 1.0 + STEEL * 20.0;
    assert!(
        (hot - (b + (cold - b) * s)).norm() < 1e-9,
        "{hot} vs {cold}"
    );
    assert!((fk.frames[5].z - cold_z).norm() < 1e-15);
    // 20 K on a point ~1.5 m from the base: ~0.36 mm.
    assert!((hot - cold).norm() > 0.2, "{}", (hot - cold).norm());
}

/// The Jacobian columns of c and of the lengths match central differences at a temperature.
#[test]
fn columns_match_finite_differences_at_a_temperature() {
    let r = warm_robot();
    let mut fk = ForwardKinematics::new();
    fk.temp_c = Some(38.0);
    fk.compute(&r, &Q);
    let k = r.effects().thermal().unwrap().0 as u16;
    for (p, h) in [
        (Param::Effect(k), 1e-7),
        (Param::A(2), 1e-3),
        (Param::D(3), 1e-3),
        (Param::ToolZ, 1e-3),
        (Param::Beta(1), 1e-6),
        (Param::Theta(2), 1e-6),
    ] {
        let col = fk.column(&r, p).unwrap();
        let moved = |d: f64| {
            let mut x = r.clone();
            kinecal::model::param::apply_delta(&mut x, &[p], &[d]).unwrap();
            let mut f = ForwardKinematics::new();
            f.temp_c = Some(38.0);
            f.compute(&x, &Q)
        };
        let fd = (moved(h) - moved(-h)) / (2.0 * h);
        assert!(
            (fd - col).norm() <= 1e-6 * col.norm().max(1.0),
            "{p:?}: column {col} vs differences {fd}"
        );
        assert_eq!(
            fk.rotation_column(&r, Param::Effect(k)).unwrap(),
            Vector3::zeros()
        );
    }
}

/// Compensation at the sensor's temperature commands the joints that put the warm arm on the
/// target; at the reference temperature it would miss by the expansion.
#[test]
fn compensation_takes_the_temperature() {
    let r = warm_robot();
    let mut fk = ForwardKinematics::new();
    let target = fk.compute(&r, &Q);
    let cfg = Config {
        temperature_c: Some(40.0),
        ..Config::default()
    };
    let seed = Q.map(|q| q + 0.002);
    let sol = compensate(&r, &Target::Point(target), &seed, &cfg).unwrap();
    let reached = fk.compute_at(&r, &sol.q, 0, Some(40.0)).unwrap();
    assert!(
        (reached - target).norm() < 1e-4,
        "{}",
        (reached - target).norm()
    );
    let cold = compensate(&r, &Target::Point(target), &seed, &Config::default()).unwrap();
    let missed = fk.compute_at(&r, &cold.q, 0, Some(40.0)).unwrap();
    assert!(
        (missed - target).norm() > 0.1,
        "{}",
        (missed - target).norm()
    );
}

/// The robot file keeps c and T0 (`joint = 0`, `reference_c`) and reads them back exactly.
#[test]
fn robot_file_round_trips_the_term() {
    let r = warm_robot();
    let f = RobotFile::from_robot("warm", &r, true, &[]);
    let text = toml::to_string(&f).unwrap();
    assert!(
        text.contains("thermal-expansion") && text.contains("reference_c = 25"),
        "{text}"
    );
    let back: RobotFile = toml::from_str(&text).unwrap();
    let r2 = back.to_robot::<6>().unwrap();
    assert_eq!(r2.effects().thermal(), r.effects().thermal());
}

fn warm_up(c: f64, temps: (f64, f64), seed: u64) -> (HostRobot<6>, Vec<Measurement<f64, 6>>) {
    let s = Simulation {
        poses: 300,
        noise_mm: 0.01,
        seed,
        geom_errors: Some(GeomErrors::default()),
        effects: if c != 0.0 {
            vec![effect("thermal-expansion", 1, &[c], 1)]
        } else {
            Vec::new()
        },
    };
    let (truth, d) = simulate_at(&er20(), &s, Some(temps)).unwrap();
    assert_eq!(d.extra_names, vec!["temp_c"]);
    (truth, d.measurements())
}

/// A warm-up from 15 to 35 °C of a steel arm: the geometry alone leaves several times the
/// noise; diagnose names thermal expansion with c within 5 % and ends at the noise floor.
#[test]
fn diagnose_finds_thermal_expansion_in_a_warm_up() {
    let (truth, data) = warm_up(STEEL, (15.0, 35.0), 11);
    let t0 = truth.effects().thermal().unwrap().2;
    assert!((t0 - 25.0).abs() < 1e-9, "{t0}");
    let d =
        kinecal_cli::diagnose::diagnose(&er20(), true, &[], &data, &Default::default()).unwrap();
    // Noise 0.01 mm per axis: a held-out floor near 0.0173 mm.
    let floor = 0.01 * 3f64.sqrt();
    eprintln!(
        "warm-up: geometry {:.4} mm, final {:.4} mm, floor {:.4}, found {:?}",
        d.baseline_validation_rms_mm,
        d.final_validation_rms_mm,
        d.noise_floor_mm,
        d.found
            .iter()
            .map(|f| f.candidate.label())
            .collect::<Vec<_>>()
    );
    assert!(d.baseline_validation_rms_mm > 3.0 * floor);
    let f = d
        .found
        .iter()
        .find(|f| matches!(f.candidate.kind, CandidateKind::Thermal { .. }))
        .expect("thermal expansion named");
    let c = f.candidate.values(&d.model)[0];
    assert!((c - STEEL).abs() < 0.05 * STEEL, "c = {c:e}");
    assert!(
        d.final_validation_rms_mm < 1.2 * floor,
        "final {} vs floor {floor}",
        d.final_validation_rms_mm
    );
}

/// The same warm-up of an arm that does not expand: thermal expansion is offered and not
/// named; at a constant temperature it is not even offered.
#[test]
fn diagnose_does_not_name_thermal_expansion_without_one() {
    for temps in [(15.0, 35.0), (22.0, 22.0)] {
        let (_, data) = warm_up(0.0, temps, 12);
        let d = kinecal_cli::diagnose::diagnose(&er20(), true, &[], &data, &Default::default())
            .unwrap();
        assert!(
            !d.found
                .iter()
                .any(|f| matches!(f.candidate.kind, CandidateKind::Thermal { .. })),
            "{temps:?}: {:?}",
            d.found
                .iter()
                .map(|f| f.candidate.label())
                .collect::<Vec<_>>()
        );
        let offered =
            kinecal_cli::diagnose::candidates::catalogue(&er20(), true, &data, &Default::default())
                .iter()
                .any(|c| matches!(c.kind, CandidateKind::Thermal { .. }));
        assert_eq!(offered, temps.0 != temps.1);
    }
}

/// The sizes the users saw refused with their reasons (a 17° peak-to-peak table on
/// joint 6, a compliance of 12.9° per m), and real-sized effects accepted.
#[test]
fn implausible_sizes_are_named() {
    use kinecal_cli::diagnose::candidates::Candidate;
    use kinecal_cli::diagnose::plausibility::{implausible, Limits};
    let lim = Limits::default();
    let table = Candidate {
        kind: CandidateKind::Table {
            start: -3.0,
            step: 0.1,
            knots: 4,
        },
        joint: 5,
    };
    let why = implausible(&table, &[0.0, 0.15, -0.147, 0.02], &lim).unwrap();
    assert!(
        why.contains("joint 6") && why.contains("17") && why.contains("peak to peak"),
        "{why}"
    );
    assert_eq!(implausible(&table, &[0.0, 2e-4, -3e-4, 1e-4], &lim), None);
    let compliance = Candidate {
        kind: CandidateKind::Compliance,
        joint: 0,
    };
    let why = implausible(&compliance, &[12.9f64.to_radians()], &lim).unwrap();
    assert!(why.contains("12.9") && why.contains("per m"), "{why}");
    assert_eq!(implausible(&compliance, &[3e-4], &lim), None);
    let thermal = Candidate {
        kind: CandidateKind::Thermal { reference: 25.0 },
        joint: 0,
    };
    assert_eq!(implausible(&thermal, &[STEEL], &lim), None);
    assert!(implausible(&thermal, &[5e-4], &lim).is_some());
}

/// A joint-angle table of 8° peak to peak (no gearbox does that) is significant and refused:
/// the round says why, nothing is added for the joint's table family, and the search goes on.
#[test]
fn an_implausible_table_is_refused_with_its_reason() {
    // Knots every 40° over ±170° on joint 2: ±4°.
    let knots: Vec<f64> = (0..9)
        .map(|k| 4f64.to_radians() * if k % 2 == 0 { 1.0 } else { -1.0 })
        .collect();
    let s = Simulation {
        poses: 300,
        noise_mm: 0.01,
        seed: 13,
        geom_errors: Some(GeomErrors::default()),
        effects: vec![effect("joint-table", 2, &knots, 1)],
    };
    let (_, d) = simulate_at(&er20(), &s, None).unwrap();
    let data = d.measurements();
    let r =
        kinecal_cli::diagnose::diagnose(&er20(), true, &[], &data, &Default::default()).unwrap();
    let refused: Vec<&String> = r.rounds.iter().filter_map(|x| x.refused.as_ref()).collect();
    eprintln!(
        "refused {refused:?}; found {:?}",
        r.found
            .iter()
            .map(|f| f.candidate.label())
            .collect::<Vec<_>>()
    );
    assert!(
        refused
            .iter()
            .any(|w| w.contains("joint 2") && w.contains("peak to peak")),
        "{refused:?}"
    );
    assert!(
        !r.found
            .iter()
            .any(|f| f.candidate.joint == 1
                && matches!(f.candidate.kind, CandidateKind::Table { .. }))
    );
    // The report's rounds carry the refusal (its text stops early here: a table of ±4°
    // is beyond what the geometric model's stall check lets it call a fit).
    let report = kinecal_cli::reports::diagnose::DiagnoseReport::of(&r);
    let json = serde_json::to_string(&report.rounds).unwrap();
    assert!(
        json.contains("\"refused\":{\"candidate\":\"joint-table"),
        "{json}"
    );
}

/// A tracker that drifts during a warm-up is not taken for thermal expansion. The arm does not
/// expand; the measured points move along one direction over the session, linearly in time
/// (0.06 mm and 0.3 mm end to end), while the temperature rises from 15 to 35 °C. Expansion
/// would move every point away from the base in proportion to its distance, a drift moves all
/// of them alike: the search must not name `thermal-expansion` (a fit of it would read a
/// plausible few 1e-6 per kelvin). It has no drift term either, so the drift stays in the
/// noise floor it estimates; `time_trend` measures it (size within 10 % and 0.005 mm, direction
/// within 18°) and warns. The rows shuffled, or no drift: no warning.
#[test]
fn a_drifting_tracker_in_a_warm_up_is_not_taken_for_thermal_expansion() {
    for drift_mm in [0.06, 0.3] {
        let (_, mut data) = warm_up(0.0, (15.0, 35.0), 13);
        let n = data.len();
        let dir = Vector3::new(1.0, 0.5, 0.2).normalize();
        for (i, m) in data.iter_mut().enumerate() {
            m.point += dir * (drift_mm * (i as f64 / (n - 1) as f64 - 0.5));
        }
        let d = kinecal_cli::diagnose::diagnose(&er20(), true, &[], &data, &Default::default())
            .unwrap();
        let found: Vec<String> = d.found.iter().map(|f| f.candidate.label()).collect();
        eprintln!(
            "tracker drifting {drift_mm} mm: geometry {:.4} mm, final {:.4} mm, floor {:.4} mm, found {found:?}",
            d.baseline_validation_rms_mm, d.final_validation_rms_mm, d.noise_floor_mm,
        );
        assert!(
            !d.found
                .iter()
                .any(|f| matches!(f.candidate.kind, CandidateKind::Thermal { .. })),
            "{drift_mm} mm: {found:?}"
        );
        // The drift is measured and named in a warning.
        let t = trend(&d.model, &data, d.effective_parameters).unwrap();
        let est = t.drift_mm.norm();
        assert!(t.p < 1e-6, "{drift_mm} mm: p {}", t.p);
        assert!(
            (est - drift_mm).abs() < 0.1 * drift_mm + 0.005,
            "{est} vs {drift_mm}"
        );
        assert!(t.drift_mm.normalize().dot(&dir) > 0.95, "{}", t.drift_mm);
        let w = warning(
            &d.model,
            &data,
            d.effective_parameters,
            (d.noise_floor_mm, "a noise floor"),
        )
        .expect("a warning");
        eprintln!("  warning: {w}");
        assert!(w.contains("drift") && w.contains("tracker"), "{w}");
        // Without the size threshold (a floor that is not a number) it warns too.
        assert!(warning(
            &d.model,
            &data,
            d.effective_parameters,
            (f64::NAN, "a noise floor")
        )
        .is_some());
    }
    // The rows of a drifting session shuffled (a seeded random order): no trend left.
    let (_, mut data) = warm_up(0.0, (15.0, 35.0), 13);
    let n = data.len();
    for (i, m) in data.iter_mut().enumerate() {
        m.point += Vector3::new(0.3 * (i as f64 / (n - 1) as f64 - 0.5), 0.0, 0.0);
    }
    let mut shuffled = data.clone();
    {
        use rand::seq::SliceRandom;
        use rand::SeedableRng;
        shuffled.shuffle(&mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(5));
    }
    let d = kinecal_cli::diagnose::diagnose(&er20(), true, &[], &shuffled, &Default::default())
        .unwrap();
    let fitted = d.effective_parameters;
    let p = trend(&d.model, &shuffled, fitted).unwrap().p;
    assert!(p > 1e-3, "shuffled: p {p}");
    assert_eq!(
        warning(
            &d.model,
            &shuffled,
            fitted,
            (d.noise_floor_mm, "a noise floor")
        ),
        None
    );
    // Without a drift: no warning.
    let (_, still) = warm_up(0.0, (15.0, 35.0), 13);
    let d =
        kinecal_cli::diagnose::diagnose(&er20(), true, &[], &still, &Default::default()).unwrap();
    let fitted = d.effective_parameters;
    assert_eq!(
        warning(
            &d.model,
            &still,
            fitted,
            (d.noise_floor_mm, "a noise floor")
        ),
        None
    );
    assert!(trend(&d.model, &still, fitted).unwrap().p > 1e-3);
}

/// The trend test's F distribution against table values: the upper 5 % and 1 % points of
/// F(3, 6) are 4.757 and 9.780, the 5 % point of F(3, 60) is 2.758.
#[test]
fn the_trend_tests_f_tail_matches_the_tables() {
    use kinecal_cli::diagnose::significance::f_sf;
    for (f, d1, d2, p) in [
        (4.757, 3.0, 6.0, 0.05),
        (9.780, 3.0, 6.0, 0.01),
        (2.758, 3.0, 60.0, 0.05),
    ] {
        let got = f_sf(f, d1, d2);
        assert!((got - p).abs() < 2e-4, "F({d1}, {d2}) > {f}: {got} vs {p}");
    }
    assert_eq!(f_sf(0.0, 3.0, 6.0), 1.0);
    assert!(f_sf(1e9, 3.0, 6.0) < 1e-12);
}

/// A large effect a robot can have leaves the geometry above `--stall-rms-mm` (5 mm) where
/// the data are right: a joint-1 gear ratio 0.3 % off (a third of the plausible 1 %) on the
/// ER20 leaves it 5.5 mm, and diagnose found the scale and reached the noise floor, then said
/// "nothing is diagnosed, check the units" (exit 3, no model). Named and written now; data
/// that no model of the catalogue fits (8 mm of noise in every coordinate) stay refused, and
/// so does a missing coupling the search takes up only in part (the KR16's joint 3 following
/// joint 2 by 1 %: 7.24 mm, a joint-2 scale leaving 2.68 mm, 37 % of it; the newcomer's
/// review found it passed with exit 0 under a first version that asked only for the limit).
#[test]
fn a_large_plausible_effect_beyond_the_stall_limit_is_named_not_refused() {
    use crate::common::{data_file, json_of, run_on, s, simulate, stderr};
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let robot = data_file("er20.toml");
    let (data, model) = (d.join("d.csv"), d.join("m.toml"));
    let scale = ["--geom-errors", "--effect", "joint-scale:1:0.003"];
    simulate(&robot, Some(150), Some(0.02), Some(80), &scale, &data);
    let j = json_of(&run_on(
        "diagnose",
        &robot,
        &data,
        &["--json", "--out", s(&model)],
    ));
    assert!(
        j["baseline_validation_rms_mm"].as_f64().unwrap() > 5.0,
        "{j}"
    );
    assert_eq!(j["converged"], true, "{j}");
    let found = &j["found"][0];
    assert_eq!(
        (&found["effect"], &found["joint"]),
        (&"joint-scale".into(), &1.into())
    );
    let value = found["values"][0].as_f64().unwrap();
    assert!((value / 0.003 - 1.0).abs() < 0.01, "{value}");
    assert!(model.exists(), "the model is written");
    // At 0.4 mm of noise the scale leaves the noise (0.67 mm, 12 % of the geometry's): found
    // all the same, and counted (a first version asked for a tenth and refused it).
    let noisy_scale = d.join("noisy_scale.csv");
    simulate(&robot, Some(150), Some(0.4), Some(80), &scale, &noisy_scale);
    let j = json_of(&run_on("diagnose", &robot, &noisy_scale, &["--json"]));
    assert_eq!(j["converged"], true, "{j}");
    assert_eq!(j["found"][0]["effect"], "joint-scale", "{j}");
    // Should not fire: noise no effect explains stays refused as a geometry that does not fit.
    let noisy = d.join("noisy.csv");
    simulate(
        &robot,
        Some(150),
        Some(8.0),
        Some(80),
        &["--geom-errors"],
        &noisy,
    );
    let out = run_on("diagnose", &robot, &noisy, &[]);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
    let kr16 = data_file("kr16.toml");
    let coupled = std::fs::read_to_string(&kr16).unwrap()
        + "\n[[couplings]]\njoint = 3\nfrom = 2\nratio = 0.01\n";
    let truth = d.join("coupled.toml");
    std::fs::write(&truth, coupled).unwrap();
    let data = d.join("coupled.csv");
    simulate(
        &truth,
        Some(200),
        Some(0.02),
        Some(7),
        &["--geom-errors"],
        &data,
    );
    let out = run_on("diagnose", &kr16, &data, &["--out", s(&model)]);
    assert_eq!(out.status.code(), Some(3), "{}", stderr(&out));
}
