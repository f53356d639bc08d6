//! A tracker that drifts during a session, against known truth: the library's `base-drift`
//! term (kinematics, Jacobian columns, its checks) and `kinecal diagnose` on simulated
//! sessions with a `t_s` on every row, told apart from thermal expansion in a warm-up.
//!
//! How the two are told apart: a drift moves every point alike (the base translates), an
//! expansion moves each point in proportion to its distance from the base origin; and a drift
//! grows with the time, a base error is the same in every row.

use super::evidence::{er20, warm_robot};
use kinecal_cli::HostRobot;

use kinecal::model::effects::{EffectError, EffectKind};
use kinecal::model::param::Param;
use kinecal::{Conditions, ForwardKinematics, Measurement};
use kinecal_cli::diagnose::candidates::CandidateKind;
use kinecal_cli::simulation::{simulate_session, GeomErrors, Simulation};
use nalgebra::Vector3;

const Q: [f64; 6] = [0.3, -0.5, 0.4, 1.1, -0.7, 0.9];
/// A session's reference time in Unix seconds.
const T0: f64 = 1.7e9;
const V: [f64; 3] = [4e-5, -2e-5, 1e-5];

/// The placed, warm ER20 of `evidence` with a base-drift term.
fn drifting_robot() -> HostRobot<6> {
    let mut r = warm_robot();
    r.effects_mut()
        .push(EffectKind::Drift, 0, 6, 1, T0, 0.0, &V)
        .unwrap();
    r
}

/// At time t the base, every joint frame and the point are where they are at t0, moved by
/// v·(t − t0); orientations do not change; without a time nothing moves.
#[test]
fn kinematics_translate_everything_by_the_drift() {
    let r = drifting_robot();
    let mut fk = ForwardKinematics::new();
    let still = fk.compute_at(&r, &Q, 0, Some(30.0)).unwrap();
    let frames = fk.frames;
    let at = |t: Option<f64>| Conditions {
        temp_c: Some(30.0),
        time_s: t,
    };
    assert_eq!(fk.compute_at(&r, &Q, 0, at(Some(T0))).unwrap(), still);
    let dt = 900.0;
    let moved = fk.compute_at(&r, &Q, 0, at(Some(T0 + dt))).unwrap();
    let d = Vector3::from(V) * dt;
    assert!(
        (moved - still - d).norm() < 1e-6,
        "{moved} vs {still} + {d}"
    );
    for (f, g) in fk.frames.iter().zip(&frames) {
        assert!((f.o - g.o - d).norm() < 1e-6);
        assert_eq!((f.x, f.y, f.z), (g.x, g.y, g.z));
    }
    // A temperature alone is the old call: no time, no drift.
    assert_eq!(fk.compute_at(&r, &Q, 0, Some(30.0)).unwrap(), still);
}

/// The drift's columns and the geometry's beside them match central differences at a time
/// and temperature away from the references; the drift turns nothing.
#[test]
fn columns_match_finite_differences_at_a_time() {
    let r = drifting_robot();
    let at = Conditions {
        temp_c: Some(38.0),
        time_s: Some(T0 - 1234.5),
    };
    let mut fk = ForwardKinematics::new();
    fk.compute_at(&r, &Q, 0, at);
    let (first, ..) = r.effects().drift().unwrap();
    let thermal = r.effects().thermal().unwrap().0 as u16;
    for (p, h) in [
        (Param::Effect(first as u16), 1e-6),
        (Param::Effect(first as u16 + 1), 1e-6),
        (Param::Effect(first as u16 + 2), 1e-6),
        (Param::Effect(thermal), 1e-7),
        (Param::BaseX, 1e-3),
        (Param::BaseRx, 1e-6),
        (Param::BaseRy, 1e-6),
        (Param::BaseRz, 1e-6),
        (Param::Alpha(3), 1e-6),
        (Param::Beta(1), 1e-6),
        (Param::D(3), 1e-3),
        (Param::A(2), 1e-3),
        (Param::Theta(2), 1e-6),
        (Param::ToolZ, 1e-3),
    ] {
        let col = fk.column(&r, p).unwrap();
        let moved = |d: f64| {
            let mut x = r.clone();
            kinecal::model::param::apply_delta(&mut x, &[p], &[d]).unwrap();
            ForwardKinematics::new().compute_at(&x, &Q, 0, at).unwrap()
        };
        let fd = (moved(h) - moved(-h)) / (2.0 * h);
        assert!(
            (fd - col).norm() <= 1e-6 * col.norm().max(1.0),
            "{p:?}: column {col} vs differences {fd}"
        );
    }
    for k in 0..3 {
        let p = Param::Effect((first + k) as u16);
        assert_eq!(fk.rotation_column(&r, p).unwrap(), Vector3::zeros());
    }
    // Without a time the drift has no column (and moves nothing).
    fk.compute_at(&r, &Q, 0, Some(38.0));
    assert_eq!(
        fk.column(&r, Param::Effect(first as u16)).unwrap(),
        Vector3::zeros()
    );
}

/// What a drift term cannot be is refused with a typed error, and the list stays as it was.
#[test]
fn a_drift_term_that_cannot_be_right_is_refused() {
    let mut r = er20();
    let before = r.clone();
    for (joint, start, values) in [
        (1, T0, &[0.0, 0.0, 0.0][..]),
        (0, T0, &[0.0, 0.0][..]),
        (0, T0, &[1.5, 0.0, 0.0][..]),
        (0, T0, &[f64::NAN, 0.0, 0.0][..]),
        (0, 1e11, &[0.0, 0.0, 0.0][..]),
        (0, f64::INFINITY, &[0.0, 0.0, 0.0][..]),
    ] {
        let e = r
            .effects_mut()
            .push(EffectKind::Drift, joint, 6, 1, start, 0.0, values);
        assert_eq!(e, Err(EffectError::Shape), "{joint} {start} {values:?}");
        assert_eq!(r, before);
    }
    r.effects_mut()
        .push(EffectKind::Drift, 0, 6, 1, T0, 0.0, &V)
        .unwrap();
    let once = r.clone();
    let e = r
        .effects_mut()
        .push(EffectKind::Drift, 0, 6, 1, T0, 0.0, &V);
    assert_eq!(e, Err(EffectError::Shape));
    assert_eq!(r, once);
    // Names as identify prints them.
    let names: Vec<String> = (0..3)
        .map(|k| Param::Effect(k).name(&r).to_string())
        .collect();
    assert_eq!(names, ["base-drift.vx", "base-drift.vy", "base-drift.vz"]);
}

/// A simulated session of `n` poses over `session_s` seconds, noise 0.01 mm per axis, with
/// geometric errors, a warm-up `temperature` (with a steel expansion when `expands`) and a
/// tracker drift `drift` (mm/s).
fn session(
    seed: u64,
    temperature: Option<(f64, f64)>,
    expands: bool,
    drift: Option<[f64; 3]>,
) -> Vec<Measurement<f64, 6>> {
    let mut effects = Vec::new();
    if expands {
        effects.push("thermal-expansion:0:1.2e-5".parse().unwrap());
    }
    if let Some(v) = drift {
        effects.push(
            format!("base-drift:0:{},{},{}", v[0], v[1], v[2])
                .parse()
                .unwrap(),
        );
    }
    let s = Simulation {
        poses: 500,
        noise_mm: 0.01,
        seed,
        geom_errors: Some(GeomErrors::default()),
        effects,
    };
    let (_, d) = simulate_session(&er20(), &s, temperature, Some(3600.0)).unwrap();
    d.measurements()
}

fn named(d: &kinecal_cli::diagnose::Diagnosis<6>) -> (bool, bool) {
    let thermal = d
        .found
        .iter()
        .any(|f| matches!(f.candidate.kind, CandidateKind::Thermal { .. }));
    let drift = d
        .found
        .iter()
        .any(|f| matches!(f.candidate.kind, CandidateKind::Drift { .. }));
    (thermal, drift)
}

/// A tracker drifting 0.16 mm per hour during a warm-up of an arm that does not expand:
/// diagnose names the drift (not thermal expansion), gives its velocity back and ends at the
/// noise floor; the same warm-up of an expanding arm with the same drift gets both named, and
/// the expanding arm without a drift gets thermal expansion only.
#[test]
fn diagnose_tells_a_drifting_tracker_from_a_warming_arm() {
    let floor = 0.01 * 3f64.sqrt();
    let cases = [
        (false, Some(V), (false, true)),
        (true, Some(V), (true, true)),
        (true, None, (true, false)),
    ];
    for (expands, drift, want) in cases {
        let data = session(31, Some((15.0, 35.0)), expands, drift);
        let d = kinecal_cli::diagnose::diagnose(&er20(), true, &[], &data, &Default::default())
            .unwrap();
        let found: Vec<String> = d.found.iter().map(|f| f.candidate.label()).collect();
        eprintln!(
            "expands {expands}, drift {drift:?}: geometry {:.4} mm, final {:.4} mm, floor {:.4} mm \
             (truth {floor:.4}), found {found:?}",
            d.baseline_validation_rms_mm, d.final_validation_rms_mm, d.noise_floor_mm,
        );
        assert_eq!(named(&d), want, "{found:?}");
        assert!(d.final_validation_rms_mm < 1.15 * floor, "{found:?}");
        if let Some(v) = drift {
            let (_, got, _) = d.model.effects().drift().expect("the drift in the model");
            let err = (Vector3::from(got) - Vector3::from(v)).norm();
            eprintln!("  drift {got:?} mm/s against {v:?}");
            assert!(err < 0.03 * Vector3::from(v).norm(), "{got:?} vs {v:?}");
        }
    }
}

/// Rows with times but neither drift nor warm-up: nothing is named (the drift candidate does
/// not raise false alarms), for several sessions.
#[test]
fn a_still_tracker_with_times_names_nothing() {
    for seed in [41, 42, 43] {
        let data = session(seed, None, false, None);
        let d = kinecal_cli::diagnose::diagnose(&er20(), true, &[], &data, &Default::default())
            .unwrap();
        let found: Vec<String> = d.found.iter().map(|f| f.candidate.label()).collect();
        assert!(found.is_empty(), "seed {seed}: {found:?}");
    }
}
