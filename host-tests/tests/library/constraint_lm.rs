//! The library's constraint stepper (`Levenberg::step_constraints`) on sessions built here
//! without rounding: sockets reached exactly by Newton steps of the true robot, distances
//! between its exact tool points. Known truth: from a noise-free session it finds the true
//! joint rows (what constraints see of them) and holds exactly what they cannot see; a run
//! resumed from a snapshot ends bit for bit as the uninterrupted one; bad sessions are refused
//! with a typed error and leave the solver usable. (Accuracy against an independent solver on
//! noisy sessions: `command_line constraint_reference`.)

use kinecal::identify::lm::{
    constraint_scratch_len, constraint_shape, ConstraintShape, Levenberg, LmConfig, LmError,
    LmProgress, LmStop,
};
use kinecal::io::constraint::{ConstraintGroup, ConstraintKind, ConstraintRow};
use kinecal::io::snapshot::Snapshot;
use kinecal::model::param::{Param, ParamSet};
use kinecal::Measurement;
use kinecal::{ForwardKinematics, Robot};
use kinecal_cli::compute::vec_lm::VecLm;
use kinecal_cli::simulation::{self, GeomErrors};
use kinecal_host::constraint_reference::aligned_rms;
use nalgebra::{SMatrix, Vector3};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

type Arm = Robot<f64, 6>;
type Lm = Levenberg<f64, 6, kinecal::Inline<0>, VecLm<f64>>;

/// Joint readings near `q0` (wrist turned by up to ±40°, joints 2–3 by ±8°) that put `truth`'s
/// tool point exactly at `target`: minimum-norm Newton steps of all joints.
fn reach(
    truth: &Arm,
    q0: [f64; 6],
    target: Vector3<f64>,
    rng: &mut Xoshiro256PlusPlus,
) -> [f64; 6] {
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let mut q = q0;
    for (j, v) in q.iter_mut().enumerate() {
        let deg: f64 = match j {
            1 | 2 => 8.0,
            3..=5 => 40.0,
            _ => 0.0,
        };
        *v += rng.random_range(-deg..=deg).to_radians();
    }
    for _ in 0..60 {
        let e = target - fk.compute(truth, &q);
        if e.norm() < 1e-11 {
            return q;
        }
        let cols: [Vector3<f64>; 6] = std::array::from_fn(|j| fk.reading_column(truth, j));
        let jac = SMatrix::<f64, 3, 6>::from_columns(&cols);
        let step = jac.transpose() * (jac * jac.transpose()).try_inverse().unwrap() * e;
        for (v, d) in q.iter_mut().zip(step.iter()) {
            *v += d;
        }
    }
    panic!("Newton steps did not reach the socket");
}

/// A session of `truth`: `sockets` sockets of `per` rows, then `distances` distances between
/// random poses (exact lengths), all σ 0.01 mm.
fn session(
    truth: &Arm,
    sockets: usize,
    per: usize,
    distances: usize,
    seed: u64,
) -> (Vec<ConstraintRow<f64, 6>>, Vec<ConstraintGroup<f64>>) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let (mut rows, mut groups) = (Vec::new(), Vec::new());
    let starts = simulation::random_configurations(truth, sockets + 2 * distances, &mut rng);
    for q0 in &starts[..sockets] {
        let centre = fk.compute(truth, q0);
        groups.push(ConstraintGroup {
            kind: ConstraintKind::Socket,
            first: rows.len() as u32,
            len: per as u32,
        });
        for _ in 0..per {
            rows.push(ConstraintRow::new(
                reach(truth, *q0, centre, &mut rng),
                0.01,
            ));
        }
    }
    for pair in starts[sockets..].chunks(2) {
        let length_mm = (fk.compute(truth, &pair[0]) - fk.compute(truth, &pair[1])).norm();
        groups.push(ConstraintGroup {
            kind: ConstraintKind::Distance { length_mm },
            first: rows.len() as u32,
            len: 2,
        });
        rows.extend(pair.iter().map(|q| ConstraintRow::new(*q, 0.01)));
    }
    (rows, groups)
}

/// The ER20 and a truth with the default geometric errors; every MDH parameter and the base.
fn problem() -> (Arm, Arm, Vec<Param>) {
    let nominal: Arm = simulation::er20_c10().with_capacity().unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(17);
    let truth = simulation::perturb_geometry(&nominal, &GeomErrors::default(), &mut rng);
    (
        nominal,
        truth,
        ParamSet::<64>::full(6, true).unwrap().to_vec(),
    )
}

fn solver(start: &Arm, params: &[Param]) -> Lm {
    Levenberg::new(
        start.clone(),
        VecLm::new(params),
        LmConfig::for_constraints(),
    )
    .unwrap()
}

/// Runs `lm` to its end in calls of `budget` rows.
fn finish(
    lm: &mut Lm,
    rows: &[ConstraintRow<f64, 6>],
    groups: &[ConstraintGroup<f64>],
    budget: usize,
) -> LmProgress<f64> {
    let mut scratch = vec![0.0; constraint_scratch_len(lm.params().len())];
    for _ in 0..100_000 {
        let p = lm
            .step_constraints(rows, groups, &mut scratch, budget)
            .unwrap();
        if p.stopped.is_some() {
            return p;
        }
    }
    panic!("the run did not end");
}

/// Tool points of `robot` at `poses`.
fn points(robot: &Arm, poses: &[[f64; 6]]) -> Vec<Vector3<f64>> {
    let mut fk = ForwardKinematics::<f64, 6>::new();
    poses.iter().map(|q| fk.compute(robot, q)).collect()
}

#[test]
fn sockets_and_distances_calibrate_as_tracker_points_of_the_same_poses() {
    let (nominal, truth, params) = problem();
    let (rows, groups) = session(&truth, 6, 8, 20, 3);
    let mut lm = solver(&nominal, &params);
    let end = finish(&mut lm, &rows, &groups, 5);
    assert!(
        matches!(end.stopped, Some(LmStop::Converged | LmStop::SmallStep)),
        "{end:?}"
    );
    // The tracker LM on the true tool points at the same joint readings, from the same start.
    let data: Vec<Measurement<f64, 6>> = rows
        .iter()
        .zip(points(
            &truth,
            &rows.iter().map(|r| r.q).collect::<Vec<_>>(),
        ))
        .map(|(r, p)| Measurement::new(r.q, p))
        .collect();
    let mut tracker = Levenberg::new(
        nominal.clone(),
        VecLm::new(&params),
        LmConfig {
            complete_passes: true,
            ..LmConfig::default()
        },
    )
    .unwrap();
    tracker.run(&data).unwrap();
    // Both on 300 fresh poses against the truth, after the best rigid alignment (the
    // constraints do not see where the robot stands).
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(99);
    let fresh = simulation::random_configurations(&truth, 300, &mut rng);
    let want = points(&truth, &fresh);
    let rms = |r: &Arm| aligned_rms(&points(r, &fresh), &want, false);
    let (nominal_rms, constraint_rms, tracker_rms) =
        (rms(&nominal), rms(lm.robot()), rms(tracker.robot()));
    let held: Vec<Param> = lm.unidentifiable().collect();
    let tracker_held: Vec<Param> = tracker.unidentifiable().collect();
    println!(
        "68 rows noise-free, tool-point RMS on 300 fresh poses (rigid): nominal {nominal_rms:.4} mm, \
         sockets and distances {constraint_rms:.2e} mm, tracker points {tracker_rms:.2e} mm; \
         held {held:?}, by the tracker LM {tracker_held:?}"
    );
    // Noise-free: what is left is the structure's (parameters held at the nominal model, where
    // the tool point is on the flange axis), for both (measured 2.4e-4 and 1.5e-4 mm).
    assert!(
        constraint_rms <= 1e-3 * nominal_rms,
        "{constraint_rms} vs nominal {nominal_rms}"
    );
    assert!(
        constraint_rms <= 2.0 * tracker_rms,
        "{constraint_rms} vs {tracker_rms}"
    );
    // A rigid motion of the whole robot changes no socket residual nor distance: the base pose
    // is held, and the first joint's row (which the base's motion mixes with, as for tracker
    // points); otherwise the same number as tracker points hold.
    let base: Vec<Param> = params.iter().copied().filter(|p| p.is_base()).collect();
    assert_eq!(base.len(), 6);
    for p in base {
        assert!(held.contains(&p), "{p:?} not held: {held:?}");
        assert!(!tracker_held.contains(&p), "{p:?} held by the tracker LM");
    }
    let beyond_base = |h: &[Param]| {
        h.iter()
            .filter(|p| p.joint().is_some_and(|j| j > 0) || p.is_tool())
            .count()
    };
    assert_eq!(
        beyond_base(&held),
        beyond_base(&tracker_held),
        "{held:?} vs {tracker_held:?}"
    );
    // The sockets' centres at the result are the truth's points moved rigidly: their distances
    // agree.
    let mut fk = ForwardKinematics::<f64, 6>::new();
    let centre =
        |g: &ConstraintGroup<f64>, fk: &mut ForwardKinematics<f64, 6>| match constraint_shape(
            fk,
            lm.robot(),
            &rows,
            g,
        ) {
            Some(ConstraintShape::Centre(c)) => c,
            other => panic!("a socket's centre: {other:?}"),
        };
    let (c0, c1) = (centre(&groups[0], &mut fk), centre(&groups[1], &mut fk));
    let t0 = fk.compute(&truth, &rows[0].q);
    let t1 = fk.compute(&truth, &rows[groups[1].first as usize].q);
    let gap = ((c0 - c1).norm() - (t0 - t1).norm()).abs();
    assert!(gap < 10.0 * constraint_rms.max(1e-6), "{gap} mm");
}

#[test]
fn a_resumed_constraint_run_ends_bit_for_bit_as_the_uninterrupted_one() {
    let (nominal, truth, params) = problem();
    let (rows, groups) = session(&truth, 4, 6, 12, 5);
    let mut whole = solver(&nominal, &params);
    let end = finish(&mut whole, &rows, &groups, 7);

    let mut first = solver(&nominal, &params);
    let mut scratch = vec![0.0; constraint_scratch_len(params.len())];
    // Into the second iteration, then a power cut between two calls (mid-pass).
    while first.progress().iteration < 2 {
        first
            .step_constraints(&rows, &groups, &mut scratch, 7)
            .unwrap();
    }
    first
        .step_constraints(&rows, &groups, &mut scratch, 7)
        .unwrap();
    let mut snap = Vec::new();
    first.save(&mut snap).unwrap();
    let mut resumed = solver(&nominal, &params);
    resumed.restore(&mut snap.as_slice()).unwrap();
    let again = finish(&mut resumed, &rows, &groups, 7);
    assert_eq!(again, end);
    assert_eq!(resumed.robot(), whole.robot());
}

/// A refused session: what is wrong, its rows, groups, scratch length, and the error.
type BadCase = (
    &'static str,
    Vec<ConstraintRow<f64, 6>>,
    Vec<ConstraintGroup<f64>>,
    usize,
    LmError,
);

#[test]
fn a_bad_session_is_refused_with_its_reason_and_the_solver_stays_usable() {
    let (nominal, truth, params) = problem();
    let (rows, groups) = session(&truth, 4, 6, 12, 7);
    let mut lm = solver(&nominal, &params);
    let n = params.len();
    let mut scratch = vec![0.0; constraint_scratch_len(n)];
    let with = |g: ConstraintGroup<f64>| {
        let mut v = groups.clone();
        v[0] = g;
        v
    };
    let socket = groups[0];
    let distance = *groups.last().unwrap();
    let mut bad_row = rows.clone();
    bad_row[3].sigma_mm = 0.0;
    let mut nan_row = rows.clone();
    nan_row[5].q[2] = f64::NAN;
    let mut far_tool = rows.clone();
    far_tool[1].tool = 3;
    let cases: Vec<BadCase> = vec![
        (
            "a group past the rows",
            rows.clone(),
            with(ConstraintGroup {
                first: rows.len() as u32 - 2,
                ..socket
            }),
            scratch.len(),
            LmError::BadGroup,
        ),
        (
            "a socket of one row",
            rows.clone(),
            with(ConstraintGroup { len: 1, ..socket }),
            scratch.len(),
            LmError::BadGroup,
        ),
        (
            "a distance of three rows",
            rows.clone(),
            with(ConstraintGroup { len: 3, ..distance }),
            scratch.len(),
            LmError::BadGroup,
        ),
        (
            "a negative length",
            rows.clone(),
            with(ConstraintGroup {
                kind: ConstraintKind::Distance { length_mm: -5.0 },
                ..distance
            }),
            scratch.len(),
            LmError::BadGroup,
        ),
        (
            "σ 0",
            bad_row,
            groups.clone(),
            scratch.len(),
            LmError::NonFiniteMeasurement,
        ),
        (
            "a NaN reading",
            nan_row,
            groups.clone(),
            scratch.len(),
            LmError::NonFiniteMeasurement,
        ),
        (
            "a tool point the robot lacks",
            far_tool,
            groups.clone(),
            scratch.len(),
            LmError::UnknownToolPoint,
        ),
        (
            "scratch too short",
            rows.clone(),
            groups.clone(),
            scratch.len() - 1,
            LmError::Params(kinecal::model::param::ParamError::Shape),
        ),
        (
            "fewer residuals than parameters",
            rows.clone(),
            groups[..2].to_vec(),
            scratch.len(),
            LmError::TooFewMeasurements,
        ),
        (
            "no groups",
            rows.clone(),
            Vec::new(),
            scratch.len(),
            LmError::TooFewMeasurements,
        ),
    ];
    for (what, r, g, len, want) in cases {
        let got = lm.step_constraints(&r, &g, &mut scratch[..len], 10);
        assert_eq!(got, Err(want), "{what}");
        assert_eq!(lm.progress().iteration, 0, "{what}: the run moved");
    }
    // Once started, another number of groups is refused.
    lm.step_constraints(&rows, &groups, &mut scratch, 10)
        .unwrap();
    assert_eq!(
        lm.step_constraints(&rows, &groups[1..], &mut scratch, 10),
        Err(LmError::DataChanged)
    );
    // The refusals left no trace: the run ends as a fresh solver's.
    let end = finish(&mut lm, &rows, &groups, 10);
    let mut fresh = solver(&nominal, &params);
    assert_eq!(end, finish(&mut fresh, &rows, &groups, 10));
    assert_eq!(lm.robot(), fresh.robot());
}
