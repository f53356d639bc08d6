//! `kinecal_cli::formats::units` (cli/src/formats/units.rs) on its own.

use kinecal::forward::ForwardKinematics;
use kinecal::Joint;
use kinecal::{Frame, Robot};
use kinecal_cli::formats::measurements::{Dataset, Record};
use kinecal_cli::formats::units::*;
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::f64::consts::PI;

/// A 6R arm of ~1.8 m reach with limits `lim` (deg) on every joint, placed at `base`.
fn arm(lim: f64, base: Frame<f64>) -> Robot<f64, 6, kinecal::Inline<0>> {
    let rows = [
        (0.0, 0.0, 0.0, 450.0),
        (-90.0, 150.0, -90.0, 0.0),
        (0.0, 610.0, 0.0, 0.0),
        (-90.0, 110.0, 0.0, 660.0),
        (90.0, 0.0, 0.0, 0.0),
        (-90.0, 0.0, 0.0, 100.0),
    ];
    let joints = rows.map(|(al, a, th, d): (f64, f64, f64, f64)| Joint {
        alpha: al.to_radians(),
        a,
        theta: th.to_radians(),
        d,
        beta: 0.0,
        lower: -lim.to_radians(),
        upper: lim.to_radians(),
    });
    Robot::new(base, joints, Vector3::new(10.0, 0.0, 80.0)).unwrap()
}

fn placed() -> Frame<f64> {
    Frame::from_xyz_rpy([2400.0, -900.0, -250.0], [0.01, -0.02, 2.4])
}

/// Records of `robot` at `qs` (deg), with noise σ mm, written in `units`.
fn records(
    robot: &Robot<f64, 6, kinecal::Inline<0>>,
    qs: &[[f64; 6]],
    sigma: f64,
    units: (LengthUnit, AngleUnit),
    seed: u64,
) -> Vec<Record<6>> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    qs.iter()
        .map(|q| {
            let p = fk.compute(robot, &q.map(f64::to_radians));
            let noise = Vector3::from_fn(|_, _| sigma * (rng.random::<f64>() * 2.0 - 1.0));
            let p = (p + noise) / units.0.mm_per_unit();
            Record::new(q.map(|x| units.1.from_deg(x)), [p.x, p.y, p.z])
        })
        .collect()
}

fn random_q(n: usize, half_range: f64, seed: u64) -> Vec<[f64; 6]> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..n)
        .map(|_| std::array::from_fn(|_| (rng.random::<f64>() * 2.0 - 1.0) * half_range))
        .collect()
}

const DEFAULTS: UnitArgs = UnitArgs {
    length_unit: None,
    angle_unit: None,
    map: None,
};
use AngleUnit::{Deg, Rad};
use LengthUnit::{Mm, M};

#[test]
fn right_units_are_accepted_wrong_ones_named() {
    for base_known in [true, false] {
        let r = arm(170.0, placed());
        let qs = random_q(40, 150.0, 1);
        for (truth, expect) in [
            ((Mm, Deg), (None, None)),
            ((M, Deg), (Some(M), None)),
            ((Mm, Rad), (None, Some(Rad))),
            ((M, Rad), (Some(M), Some(Rad))),
        ] {
            let rec = records(&r, &qs, 0.05, truth, 2);
            let s = suspect(&rec, &DEFAULTS, &r, base_known);
            assert_eq!(
                s.as_ref().map(|s| (s.length, s.angle)),
                (expect != (None, None)).then_some(expect),
                "truth {truth:?}, base known {base_known}: {s:?}"
            );
            // The true units given explicitly: nothing left to question.
            let given = UnitArgs::new(truth.0, truth.1);
            assert!(suspect(&rec, &given, &r, base_known).is_none());
            // One unit given (right), the other free: only the free one is named.
            let half = UnitArgs {
                length_unit: Some(truth.0),
                angle_unit: None,
                map: None,
            };
            let s = suspect(&rec, &half, &r, base_known);
            assert_eq!(
                s.map(|s| (s.length, s.angle)),
                expect.1.map(|a| (None, Some(a)))
            );
        }
    }
}

#[test]
fn a_wrong_unit_given_explicitly_is_not_second_guessed() {
    let r = arm(170.0, placed());
    let rec = records(&r, &random_q(30, 150.0, 3), 0.05, (Mm, Deg), 4);
    for units in [
        UnitArgs::new(M, Deg),
        UnitArgs::new(Mm, Rad),
        UnitArgs::new(M, Rad),
    ] {
        assert!(suspect(&rec, &units, &r, true).is_none());
    }
}

#[test]
fn small_degree_sweeps_and_tiny_sets_are_not_mistaken_for_radians() {
    for base_known in [true, false] {
        let r = arm(170.0, placed());
        // A sweep of joint 2 over ±2° around the zero pose: every reading within ±π.
        let qs: Vec<[f64; 6]> = (0..9)
            .map(|k| {
                let mut q = [0.0; 6];
                q[1] = -2.0 + 0.5 * k as f64;
                q[4] = 1.0; // off the wrist singularity, still tiny
                q
            })
            .collect();
        let rec = records(&r, &qs, 0.01, (Mm, Deg), 5);
        let s = suspect(&rec, &DEFAULTS, &r, base_known);
        assert!(s.is_none(), "±2° sweep, base known {base_known}: {s:?}");
        // Small random jogs of every joint within ±3° (several joints span > 5°).
        let rec = records(&r, &random_q(12, 3.0, 6), 0.01, (Mm, Deg), 7);
        let s = suspect(&rec, &DEFAULTS, &r, base_known);
        assert!(s.is_none(), "±3° jogs, base known {base_known}: {s:?}");
        // Three and two poses.
        for n in [2, 3] {
            let rec = records(&r, &random_q(n, 150.0, 8), 0.05, (Mm, Deg), 9);
            assert!(suspect(&rec, &DEFAULTS, &r, base_known).is_none());
        }
    }
}

#[test]
fn a_poor_nominal_model_is_not_blamed_on_units() {
    // Data of an arm whose upper arm is 60 mm longer than the model's: every hypothesis
    // fits poorly, none clearly better.
    let model = arm(170.0, placed());
    let mut truth = model.clone();
    let mut j = *truth.joints();
    j[2].a += 60.0;
    j[1].theta += 0.05;
    truth = Robot::new(*truth.base(), j, *truth.tool()).unwrap();
    for base_known in [true, false] {
        let rec = records(&truth, &random_q(50, 150.0, 10), 0.05, (Mm, Deg), 11);
        let s = suspect(&rec, &DEFAULTS, &model, base_known);
        assert!(s.is_none(), "{s:?}");
    }
}

#[test]
fn radians_of_a_poorly_known_arm_are_caught_by_the_patterns() {
    // A model so far off that no fit is 10× better, data in radians covering most of a
    // turn on every joint: P1 and P2 decide.
    let model = arm(170.0, placed());
    let mut j = *model.joints();
    j[2].a += 200.0;
    j[3].d -= 150.0;
    let truth = Robot::new(*model.base(), j, *model.tool()).unwrap();
    let rec = records(&truth, &random_q(60, 165.0, 12), 0.05, (Mm, Rad), 13);
    let s = suspect(&rec, &DEFAULTS, &model, false).expect("radians named");
    assert_eq!((s.length, s.angle), (None, Some(Rad)));
    assert!(s.within_pi && s.near_turn.len() >= 2, "{s:?}");
    let msg = s.message("D.csv", FileKind::Measurements);
    assert!(
        msg.starts_with("D.csv: joint readings look like radians ("),
        "{msg}"
    );
    assert!(msg.contains("pass --angle-unit rad (or --angle-unit deg to keep them)"));
    assert!(
        msg.contains("±π") && !msg.contains("inf") && !msg.contains('\n'),
        "{msg}"
    );
    // The pattern alone, without any fit (two poses, base unknown: no rigid placement):
    // four joints spanning nearly a turn in radians name them; one joint does not.
    let a = [150.0, -150.0, 160.0, -160.0, 100.0, 0.0];
    let b = [-150.0, 150.0, -160.0, 160.0, -100.0, 10.0];
    let rec2 = records(&truth, &[a, b], 0.05, (Mm, Rad), 14);
    let s = suspect(&rec2, &DEFAULTS, &model, false).expect("pattern P2 alone");
    assert_eq!(
        (s.angle, s.near_turn.clone()),
        (Some(Rad), vec![0, 1, 2, 3])
    );
    assert_eq!(s.assumed_score, Score::Unknown);
    let c = [150.0, 10.0, 20.0, -30.0, 40.0, 0.0];
    let d = [-150.0, 12.0, 25.0, -35.0, 45.0, 10.0];
    let rec2 = records(&truth, &[c, d], 0.05, (Mm, Rad), 15);
    assert!(suspect(&rec2, &DEFAULTS, &model, false).is_none());
}

#[test]
fn the_message_names_file_unit_evidence_and_flag() {
    let r = arm(170.0, placed());
    let rec = records(&r, &random_q(30, 150.0, 14), 0.05, (M, Deg), 15);
    let s = suspect(&rec, &DEFAULTS, &r, false).unwrap();
    let msg = s.message("D.csv", FileKind::Measurements);
    assert!(
        msg.starts_with("D.csv: positions look like metres (nominal RMS "),
        "{msg}"
    );
    assert!(
        msg.contains(" % of the spread as millimetres, ") && msg.contains(" % as metres)"),
        "{msg}"
    );
    assert!(msg.ends_with("pass --length-unit m (or --length-unit mm to keep them)"));
    let rec = records(&r, &random_q(30, 150.0, 16), 0.05, (M, Rad), 17);
    let msg = suspect(&rec, &DEFAULTS, &r, true)
        .unwrap()
        .message("T.csv", FileKind::Targets);
    assert!(
        msg.starts_with("T.csv: target points look like metres and seed joints like radians (model at the seeds misses the targets by RMS "),
        "{msg}"
    );
    // A known base: absolute figures, no spread.
    assert!(
        !msg.contains("spread") && msg.contains(" mm as metres and radians"),
        "{msg}"
    );
    assert!(msg.contains(
        "pass --length-unit m --angle-unit rad (or --length-unit mm --angle-unit deg to keep them)"
    ));
}

#[test]
fn conversion_gives_millimetres_and_degrees() {
    let mut ds = Dataset::<2> {
        records: vec![Record::new([PI, -PI / 2.0], [1.5, -0.25, 2e-3])],
        extra_names: Vec::new(),
    };
    convert(&mut ds, &UnitArgs::new(M, Rad));
    let r = &ds.records[0];
    assert_eq!(r.q_deg, [180.0, -90.0]);
    assert_eq!(r.xyz_mm, [1500.0, -250.0, 2.0]);
    // Exact: metres give the millimetre file's numbers, radians the same radians.
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(20);
    for _ in 0..20000 {
        let mm: f64 = format!("{:.8}", rng.random_range(-4000.0..4000.0))
            .parse()
            .unwrap();
        // The same decimal number in metres (as a tracker exporting metres writes it).
        let m: f64 = format!("{mm}e-3").parse().unwrap();
        assert_eq!(mm_of_m(m), mm, "{m}");
        // Radians written from degrees (as a controller or a script would) read back to
        // degrees that give exactly those radians.
        let deg: f64 = format!("{:.6}", rng.random_range(-400.0..400.0))
            .parse()
            .unwrap();
        let rad: f64 = format!("{}", deg.to_radians()).parse().unwrap();
        assert_eq!(deg_of_rad(rad).to_radians(), rad);
    }
    assert_eq!(mm_of_m(-0.0), 0.0);
    assert!(mm_of_m(f64::NAN).is_nan());
}
