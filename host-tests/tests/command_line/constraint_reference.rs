//! The constraint fit of `identify` against an independent reference solver
//! (`kinecal_host::constraint_reference`: its own reader, the reference forward kinematics,
//! a dense Levenberg–Marquardt over the model and every socket centre and plane at once).
//!
//! Each case simulates a session of a robot with known geometric errors (`simulate
//! --constraints … --geom-errors`), fits it with `identify` and with the reference (the same
//! parameters: those `identify` reports as estimated), and judges both on the true robot's
//! tool points at 300 fresh random poses, after the best rigid alignment (constraints do not
//! see the base) and, for sockets or planes without a length, the best uniform scale:
//!
//! - the command line, and the library's constraint stepper (`Levenberg::step_constraints`,
//!   the firmware's, from the same candidate parameters, fed in budgets of 7 rows, in `f64`),
//!   are within 1.25× of the reference;
//! - all are far better than the nominal robot (≤ 0.3×);
//! - what the constraints cannot determine is held and named, by the command line and by the
//!   stepper alike: the base always, one more
//!   length (the scale) from sockets or planes alone than from tracker points; and in the
//!   reference, a rigid motion of its fit (base and shapes together) leaves its cost as it is,
//!   every length 0.1 % longer raises it by 1.001² only from sockets and planes alone, by
//!   orders of magnitude once there are distances.

use crate::common::{data_file, json_of, kinecal_ok, s};
use kinecal::identify::lm::{constraint_scratch_len, Levenberg, LmConfig, LmStop};
use kinecal::io::constraint::{ConstraintGroup, ConstraintKind, ConstraintRow};
use kinecal::model::param::Param;
use kinecal_cli::compute::vec_lm::VecLm;
use kinecal_cli::formats::robot_file::{load_robot, RobotFile};
use kinecal_host::constraint_reference::{
    aligned_rms, constraint_fit, read_session, residuals, rigidly_moved, scaled, RefGroup, RefKind,
};
use kinecal_host::reference::RefRobot;
use nalgebra::{Rotation3, Vector3};
use std::path::Path;
use std::time::Instant;

/// The base pose names `identify` prints.
const BASE: [&str; 6] = [
    "base.x", "base.y", "base.z", "base.rx", "base.ry", "base.rz",
];

/// Noise of every contact, length and tracker coordinate (mm), as `sigma_mm` of the rows.
const NOISE_MM: f64 = 0.01;

fn names(v: &serde_json::Value) -> Vec<String> {
    v.as_array()
        .unwrap_or_else(|| panic!("an array: {v}"))
        .iter()
        .map(|n| n.as_str().unwrap().to_string())
        .collect()
}

fn params(names: &[String]) -> Vec<Param> {
    names
        .iter()
        .map(|n| Param::parse(n).unwrap_or_else(|| panic!("parameter name {n}")))
        .collect()
}

/// `identify --json` of `data` on `robot` (extra flags appended), asserting exit 0.
fn identify(robot: &Path, data: &Path, extra: &[&str]) -> serde_json::Value {
    let mut args = vec!["identify", "--robot", s(robot), "--data", s(data), "--json"];
    args.extend_from_slice(extra);
    json_of(&kinecal_ok(&args))
}

/// The reference model of a robot file.
fn reference_of(path: &Path) -> RefRobot {
    RefRobot::from_file(&RobotFile::load(path).unwrap())
}

/// 300 random poses of `truth` (the draw of `simulate`, seed 1234), rad.
fn fresh_poses<const N: usize>(truth: &Path) -> Vec<Vec<f64>> {
    let (_, t) = load_robot::<N>(truth).unwrap();
    let mut rng = kinecal_cli::simulation::Streams::new(1234).configs;
    kinecal_cli::simulation::random_configurations(&t, 300, &mut rng)
        .iter()
        .map(|q| q.to_vec())
        .collect()
}

/// Tool-point RMS (mm) of `model` against `truth` at `poses`, aligned (see the module).
fn tool_point_rms(model: &RefRobot, truth: &RefRobot, poses: &[Vec<f64>], scale: bool) -> f64 {
    let a: Vec<Vector3<f64>> = poses.iter().map(|q| model.point(q)).collect();
    let b: Vec<Vector3<f64>> = poses.iter().map(|q| truth.point(q)).collect();
    aligned_rms(&a, &b, scale)
}

/// The non-base parameters `identify` holds on tracker points of the same robot (the model's
/// own redundancies, which constraints share).
fn held_with_points(dir: &Path, robot: &Path) -> Vec<String> {
    let data = dir.join("points.csv");
    crate::common::simulate(
        robot,
        Some(60),
        Some(NOISE_MM),
        Some(3),
        &["--geom-errors"],
        &data,
    );
    names(&identify(robot, &data, &[])["unidentifiable"])
        .into_iter()
        .filter(|n| !n.starts_with("base."))
        .collect()
}

/// The session of the reference's reader as the library's rows and groups.
fn library_session<const N: usize>(
    groups: &[RefGroup],
) -> (Vec<ConstraintRow<f64, N>>, Vec<ConstraintGroup<f64>>) {
    let (mut rows, mut out) = (Vec::new(), Vec::new());
    for g in groups {
        let first = rows.len() as u32;
        for r in &g.rows {
            rows.push(ConstraintRow::new(
                <[f64; N]>::try_from(r.q.as_slice()).unwrap(),
                r.sigma_mm,
            ));
        }
        let kind = match g.kind {
            RefKind::Socket => ConstraintKind::Socket,
            RefKind::Plane => ConstraintKind::Plane,
            RefKind::Distance => ConstraintKind::Distance {
                length_mm: g.length_mm.unwrap(),
            },
            RefKind::Point => ConstraintKind::Point {
                at: g.rows[0].xyz.unwrap(),
            },
        };
        out.push(ConstraintGroup {
            kind,
            first,
            len: g.rows.len() as u32,
        });
    }
    (rows, out)
}

/// The library's constraint stepper on `groups` from the nominal robot of `robot`, estimating
/// what it can of `candidates`, fed 7 rows per call: the fitted robot and what it held.
fn library_fit<const N: usize>(
    robot: &Path,
    groups: &[RefGroup],
    candidates: &[Param],
) -> (RefRobot, Vec<String>) {
    let (_, nominal) = load_robot::<N>(robot).unwrap();
    let (rows, session) = library_session::<N>(groups);
    let mut lm =
        Levenberg::new(nominal, VecLm::new(candidates), LmConfig::for_constraints()).unwrap();
    let mut scratch = vec![0.0; constraint_scratch_len(candidates.len())];
    let stop = loop {
        let p = lm
            .step_constraints(&rows, &session, &mut scratch, 7)
            .unwrap();
        if let Some(stop) = p.stopped {
            break stop;
        }
    };
    assert!(
        matches!(stop, LmStop::Converged | LmStop::SmallStep),
        "the stepper stopped: {stop:?}"
    );
    let held = lm
        .unidentifiable()
        .map(|p| p.name(lm.robot()).to_string())
        .collect();
    (RefRobot::from_robot(lm.robot()), held)
}

/// One case: `spec` simulated on `robot_name` (N joints) with `seed`; `scale_blind` when the
/// session has no length (sockets or planes alone).
fn compare<const N: usize>(robot_name: &str, spec: &str, seed: u64, scale_blind: bool) {
    let dir = tempfile::tempdir().unwrap();
    let robot = data_file(robot_name);
    let (data, truth, model) = (
        dir.path().join("session.csv"),
        dir.path().join("truth.toml"),
        dir.path().join("model.toml"),
    );
    let noise = NOISE_MM.to_string();
    let seed_text = seed.to_string();
    kinecal_ok(&[
        "simulate",
        "--robot",
        s(&robot),
        "--constraints",
        spec,
        "--geom-errors",
        "--noise-mm",
        &noise,
        "--seed",
        &seed_text,
        "--out",
        s(&data),
        "--truth",
        s(&truth),
    ]);
    let t0 = Instant::now();
    let v = identify(&robot, &data, &["--out", s(&model)]);
    let cli_seconds = t0.elapsed().as_secs_f64();
    let case = format!("{robot_name} {spec} seed {seed}");
    assert_eq!(v["converged"], true, "{case}: {v}");
    let estimated = names(&v["estimated"]);
    let held = names(&v["unidentifiable"]);

    // The reference, on the parameters identify estimated (the others held at the file's).
    let groups: Vec<RefGroup> = read_session(&std::fs::read_to_string(&data).unwrap(), N).unwrap();
    let nominal = reference_of(&robot);
    let t0 = Instant::now();
    let fit = constraint_fit(&nominal, &params(&estimated), &groups);
    let ref_seconds = t0.elapsed().as_secs_f64();
    assert!(fit.converged, "{case}: the reference did not converge");

    let poses = fresh_poses::<N>(&truth);
    let truth_ref = reference_of(&truth);
    let nominal_rms = tool_point_rms(&nominal, &truth_ref, &poses, scale_blind);
    let cli_rms = tool_point_rms(&reference_of(&model), &truth_ref, &poses, scale_blind);
    let ref_rms = tool_point_rms(&fit.robot, &truth_ref, &poses, scale_blind);
    let cli_ident = v["after"]["identification_rms_mm"].as_f64().unwrap();
    let ref_ident = fit.rms_mm(&groups);

    // What the reference says the constraints cannot see: its cost at its fit moved rigidly
    // (base and shapes together), and with every length 0.1 % longer.
    let cost = fit.cost;
    let rot = Rotation3::from_scaled_axis(Vector3::new(0.02, -0.01, 0.03)).into_inner();
    let (moved, moved_shapes) = rigidly_moved(
        &fit.robot,
        &fit.shapes,
        &rot,
        &Vector3::new(25.0, -40.0, 10.0),
    );
    let rigid = residuals(&moved, &groups, &moved_shapes).norm_squared() / cost;
    let (longer, longer_shapes) = scaled(&fit.robot, &fit.shapes, 1.001);
    let scale = residuals(&longer, &groups, &longer_shapes).norm_squared() / cost;
    let mut candidates = params(&estimated);
    candidates.extend(params(&held));
    let (stepper, stepper_held) = library_fit::<N>(&robot, &groups, &candidates);
    let stepper_rms = tool_point_rms(&stepper, &truth_ref, &poses, scale_blind);
    let sv = &fit.singular_values;
    let weakest = sv[sv.len() - 1] / sv[0];
    let points = held_with_points(dir.path(), &robot);
    println!(
        "{case}: tool-point RMS on 300 fresh poses{}: nominal {nominal_rms:.4} mm, \
         command line {cli_rms:.5} mm, stepper {stepper_rms:.5} mm, reference {ref_rms:.5} mm \
         (ratio {:.4}, stepper {:.4}); stepper held {stepper_held:?}; \
         identification RMS command line {cli_ident:.5} mm, reference {ref_ident:.5} mm; \
         {} estimated, held {held:?} (with tracker points {points:?}); \
         reference {} steps {ref_seconds:.2} s, command line {} iterations {cli_seconds:.2} s; \
         reference's weakest direction {weakest:.1e} of the strongest; its cost ×{rigid:.9} \
         moved rigidly, ×{scale:.4} with every length 0.1 % longer",
        if scale_blind {
            " (rigid + scale)"
        } else {
            " (rigid)"
        },
        cli_rms / ref_rms,
        stepper_rms / ref_rms,
        estimated.len(),
        fit.iterations,
        v["iterations"],
    );

    assert!(
        cli_rms <= 1.25 * ref_rms,
        "{case}: command line {cli_rms} mm against reference {ref_rms} mm"
    );
    assert!(
        stepper_rms <= 1.25 * ref_rms,
        "{case}: stepper {stepper_rms} mm against reference {ref_rms} mm"
    );
    for (who, e) in [
        ("command line", cli_rms),
        ("stepper", stepper_rms),
        ("reference", ref_rms),
    ] {
        assert!(
            e <= 0.3 * nominal_rms,
            "{case}: {who} {e} mm against nominal {nominal_rms} mm"
        );
    }
    for b in BASE {
        assert!(
            held.contains(&b.to_string()),
            "{case}: {b} not held: {held:?}"
        );
    }
    assert!(
        (rigid - 1.0).abs() < 1e-6,
        "{case}: a rigid motion changes the reference's cost ×{rigid}"
    );
    if scale_blind {
        // Rows proportional to the lengths: the cost grows by 1.001² only.
        assert!(
            scale < 1.01,
            "{case}: 0.1 % longer changes the reference's cost ×{scale}"
        );
    } else {
        assert!(
            scale > 100.0,
            "{case}: 0.1 % longer changes the reference's cost only ×{scale}"
        );
    }
    for (who, held) in [("command line", &held), ("stepper", &stepper_held)] {
        for b in BASE {
            assert!(
                held.contains(&b.to_string()),
                "{case}: {who}: {b} not held: {held:?}"
            );
        }
        let model_held = held.iter().filter(|n| !n.starts_with("base.")).count();
        assert_eq!(
            model_held,
            points.len() + usize::from(scale_blind),
            "{case}: {who} held {held:?}, with tracker points {points:?}"
        );
    }
}

#[test]
fn ur10_sockets_match_the_reference() {
    compare::<6>("ur10.toml", "socket:8x10", 5, true);
}

#[test]
fn ur10_planes_match_the_reference() {
    compare::<6>("ur10.toml", "plane:6x12", 5, true);
}

#[test]
fn ur10_distances_match_the_reference() {
    compare::<6>("ur10.toml", "distance:60", 5, false);
}

#[test]
fn ur10_mixed_session_matches_the_reference() {
    compare::<6>("ur10.toml", "socket:4x10,plane:3x15,distance:30", 3, false);
}

#[test]
fn arm7_mixed_session_matches_the_reference() {
    compare::<7>("arm7.toml", "socket:4x10,plane:3x15,distance:30", 3, false);
}

#[test]
fn arm7_sockets_match_the_reference() {
    compare::<7>("arm7.toml", "socket:8x10", 5, true);
}

#[test]
fn arm7_planes_match_the_reference() {
    compare::<7>("arm7.toml", "plane:6x12", 5, true);
}

#[test]
fn arm7_distances_match_the_reference() {
    compare::<7>("arm7.toml", "distance:60", 5, false);
}
