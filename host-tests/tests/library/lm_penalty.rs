//! The library's Levenberg–Marquardt with a penalty (prior) on the scaled parameters and with
//! caller-held parameters (`kinecal::identify::lm`, `Levenberg::with_penalty`,
//! `Levenberg::hold`): the optimum is the closed-form penalised least-squares solution of an
//! independent dense solve, held parameters stay put, bad penalties get typed errors, and a
//! penalised run survives snapshots bit for bit.

use kinecal::identify::lm::{
    FixedLm, FixedPenalty, Levenberg, LmConfig, LmError, LmStop, PenaltyError, PenaltyTerm,
};
use kinecal::io::snapshot::Snapshot;
use kinecal::model::effects::EffectKind;
use kinecal::model::param::{apply_delta, value, Param, ParamSet};
use kinecal::{ForwardKinematics, Measurement, Robot};
use kinecal_cli::compute::vec_lm::{VecLm, VecPenalty};
use kinecal_cli::simulation;
use nalgebra::{DMatrix, DVector, Vector3};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

fn er20() -> Robot<f64, 6, kinecal::Inline<64>> {
    simulation::er20_c10()
        .with_capacity::<kinecal::Inline<64>>()
        .unwrap()
}

/// Noisy poses of a perturbed ER20 (the truth).
fn poses(n: usize, seed: u64) -> (Robot<f64, 6, kinecal::Inline<64>>, Vec<Measurement<f64, 6>>) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    simulation::perturbed_measurements(&er20(), n, 0.01, &mut rng)
}

/// Base and tool translations: the model is exactly affine in them (the tool point is a
/// fixed vector in the flange frame, the base origin a translation), and their scale is 1.
const LINEAR: [Param; 6] = [
    Param::BaseX,
    Param::BaseY,
    Param::BaseZ,
    Param::ToolX,
    Param::ToolY,
    Param::ToolZ,
];

/// The penalised least-squares solution of the affine problem by an independent dense solve:
/// `J` by central differences of the forward kinematics, the penalty matrix written out by
/// hand (ridge `I`, second differences `DᵀD` of the three tool coordinates), then
/// `(JᵀJ + Π) δ = Jᵀr₀ − Π u₀`.
fn closed_form(
    start: &Robot<f64, 6, kinecal::Inline<64>>,
    data: &[Measurement<f64, 6>],
    prior: &[f64; 6],
    (base_ridge, tool_ridge, tool_smooth): (f64, f64, f64),
) -> [f64; 6] {
    let n = data.len();
    let mut fk = ForwardKinematics::new();
    let mut j = DMatrix::zeros(3 * n, 6);
    let mut r0 = DVector::zeros(3 * n);
    let h = 1.0;
    for (c, p) in LINEAR.iter().enumerate() {
        let mut plus = start.clone();
        let mut minus = start.clone();
        apply_delta(&mut plus, &[*p], &[h]).unwrap();
        apply_delta(&mut minus, &[*p], &[-h]).unwrap();
        for (i, m) in data.iter().enumerate() {
            let d = (fk.compute(&plus, &m.q) - fk.compute(&minus, &m.q)) / (2.0 * h);
            j.fixed_view_mut::<3, 1>(3 * i, c).copy_from(&d);
        }
    }
    for (i, m) in data.iter().enumerate() {
        let r: Vector3<f64> = m.point - fk.compute(start, &m.q);
        r0.fixed_rows_mut::<3>(3 * i).copy_from(&r);
    }
    let a = j.transpose() * &j;
    // The tool term is relative: its weight is the mean diagonal of JᵀJ over the tool block.
    let w_tool = (a[(3, 3)] + a[(4, 4)] + a[(5, 5)]) / 3.0;
    let mut pen = DMatrix::zeros(6, 6);
    for k in 0..3 {
        pen[(k, k)] += base_ridge;
    }
    let d2 = nalgebra::RowVector3::new(1.0, -2.0, 1.0);
    let dtd = d2.transpose() * d2;
    for a_ in 0..3 {
        pen[(3 + a_, 3 + a_)] += w_tool * tool_ridge;
        for b_ in 0..3 {
            pen[(3 + a_, 3 + b_)] += w_tool * tool_smooth * dtd[(a_, b_)];
        }
    }
    let u0 = DVector::from_iterator(
        6,
        LINEAR
            .iter()
            .zip(prior)
            .map(|(p, x0)| value(start, *p).unwrap() - x0),
    );
    let rhs = j.transpose() * &r0 - &pen * &u0;
    let delta = (a + &pen).lu().solve(&rhs).unwrap();
    core::array::from_fn(|k| value(start, LINEAR[k]).unwrap() + delta[k])
}

fn terms(weights: (f64, f64, f64)) -> Vec<PenaltyTerm<f64>> {
    vec![
        PenaltyTerm {
            first: 0,
            len: 3,
            ridge: weights.0,
            smoothness: 0.0,
            relative: false,
        },
        PenaltyTerm::relative(3, 3, weights.1, weights.2),
    ]
}

fn exact_config() -> LmConfig<f64> {
    LmConfig {
        // No ridge of its own: the run's optimum is exactly the penalised one; converged to
        // rounding.
        ridge: 0.0,
        max_analyses: 0,
        cost_tolerance: 1e-15,
        step_tolerance: 1e-12,
        ..LmConfig::default()
    }
}

#[test]
fn penalised_optimum_is_the_closed_form_penalised_least_squares_solution() {
    let (_, data) = poses(60, 3);
    let start = er20();
    // Priors away from the start and from the data's answer, so that the penalty pulls.
    let prior = [5.0, -3.0, 2.0, 10.0, 40.0, 150.0];
    // Also with the curvature kept while steps succeed (gradient-only passes): the same
    // fixed point.
    let cases = [
        (0.0, 0.0, 0.0),
        (50.0, 1e-3, 0.0),
        (2e3, 0.05, 0.2),
        (1e5, 1.0, 3.0),
    ];
    for (weights, keep_curvature) in cases.iter().flat_map(|w| [(*w, false), (*w, true)]) {
        let mut pen = VecPenalty::new(6, terms(weights));
        pen.prior_mut().copy_from_slice(&prior);
        let cfg = LmConfig {
            keep_curvature,
            ..exact_config()
        };
        let mut lm = Levenberg::with_penalty(start.clone(), VecLm::new(&LINEAR), pen, cfg).unwrap();
        let p = lm.run(&data).unwrap();
        assert!(
            matches!(p.stopped, Some(LmStop::Converged | LmStop::SmallStep)),
            "{p:?}"
        );
        let expected = closed_form(&start, &data, &prior, weights);
        for (k, param) in LINEAR.iter().enumerate() {
            let got = value(lm.robot(), *param).unwrap();
            assert!(
                (got - expected[k]).abs() < 1e-7,
                "{weights:?} {param:?}: LM {got} vs closed form {}",
                expected[k]
            );
        }
        // The penalty it reports is uᵀΠu at the solution, and it pulled (when present).
        if weights.0 > 0.0 {
            assert!(lm.penalty() > 0.0);
            let unpenalised = closed_form(&start, &data, &prior, (0.0, 0.0, 0.0));
            let moved = |x: &[f64; 6]| (x[0] - prior[0]).abs();
            assert!(moved(&expected) < moved(&unpenalised));
        } else {
            assert_eq!(lm.penalty(), 0.0);
        }
    }
}

#[test]
fn f32_and_fixed_storage_reach_the_same_penalised_optimum() {
    let (_, data) = poses(60, 4);
    let data32: Vec<Measurement<f32, 6>> = data
        .iter()
        .map(|m| Measurement::new(m.q.map(|v| v as f32), m.point.cast::<f32>()))
        .collect();
    let start = er20();
    let weights = (2e3, 0.05, 0.2);
    let prior = [5.0, -3.0, 2.0, 10.0, 40.0, 150.0];
    let expected = closed_form(&start, &data, &prior, weights);
    let t32: Vec<PenaltyTerm<f32>> = terms(weights)
        .iter()
        .map(|t| PenaltyTerm {
            first: t.first,
            len: t.len,
            ridge: t.ridge as f32,
            smoothness: t.smoothness as f32,
            relative: t.relative,
        })
        .collect();
    let mut pen = FixedPenalty::<f32, 8, 2>::new(&t32).unwrap();
    for (k, x) in prior.iter().enumerate() {
        pen.prior_mut()[k] = *x as f32;
    }
    let cfg = LmConfig::<f32> {
        ridge: 0.0,
        max_analyses: 0,
        ..LmConfig::default()
    };
    let storage = FixedLm::<f32, 8>::from_slice(&LINEAR).unwrap();
    let start32: Robot<f32, 6, kinecal::Inline<64>> = start.cast().unwrap();
    let mut lm = Levenberg::with_penalty(start32, storage, pen, cfg).unwrap();
    lm.run(&data32).unwrap();
    for (k, param) in LINEAR.iter().enumerate() {
        let got = value(lm.robot(), *param).unwrap() as f64;
        assert!(
            (got - expected[k]).abs() < 2e-2,
            "{param:?}: f32 {got} vs {}",
            expected[k]
        );
    }
}

#[test]
fn a_held_parameter_stays_put_and_the_others_are_fitted() {
    let (truth, data) = poses(80, 5);
    let start = er20();
    let params = ParamSet::<64>::full(6, false).unwrap().to_vec();
    let run = |held: &[Param]| {
        let mut lm =
            Levenberg::new(start.clone(), VecLm::new(&params), LmConfig::default()).unwrap();
        for p in held {
            lm.hold(*p).unwrap();
        }
        lm.run(&data).unwrap();
        lm
    };
    let free = run(&[]);
    let lm = run(&[Param::A(2), Param::Theta(1)]);
    for p in [Param::A(2), Param::Theta(1)] {
        assert_eq!(value(lm.robot(), p), value(&start, p), "{p:?} moved");
        let k = params.iter().position(|q| *q == p).unwrap();
        assert!(lm.is_held(k) && !lm.is_active(k));
        // Held by the caller is not "unidentifiable".
        assert!(!lm.unidentifiable().any(|q| q == p));
    }
    // The free run moves them towards the truth; the others still move in the held run.
    for p in [Param::A(2), Param::Theta(1)] {
        assert_ne!(value(free.robot(), p), value(&start, p));
    }
    assert_ne!(value(lm.robot(), Param::D(0)), value(&start, Param::D(0)));
    // The free run's fit is better than the held run's (the held pair was off).
    let err = |r: &Robot<f64, 6, kinecal::Inline<64>>| kinecal::identify::lm::rms_error(r, &data);
    assert!(
        err(free.robot()) < err(lm.robot()),
        "{} vs {}",
        err(free.robot()),
        err(lm.robot())
    );
    let _ = truth;

    // Holding after the run started, or a parameter not estimated, is refused.
    let mut lm = Levenberg::new(start.clone(), VecLm::new(&params), LmConfig::default()).unwrap();
    assert_eq!(
        lm.hold(Param::Effect(3)),
        Err(LmError::Params(
            kinecal::model::param::ParamError::OutOfRange
        ))
    );
    lm.step(&data, 10).unwrap();
    assert_eq!(lm.hold(Param::A(2)), Err(LmError::Started));
}

#[test]
fn bad_penalties_are_refused_with_typed_errors() {
    let start = er20();
    let make = |terms: Vec<PenaltyTerm<f64>>, prior: f64| {
        let mut pen = VecPenalty::new(6, terms);
        pen.prior_mut()[4] = prior;
        Levenberg::with_penalty(start.clone(), VecLm::new(&LINEAR), pen, LmConfig::default()).err()
    };
    let ok = PenaltyTerm::relative(3, 3, 1e-3, 0.1);
    assert_eq!(make(vec![ok], 0.0), None);
    let cases = [
        (PenaltyTerm { len: 4, ..ok }, PenaltyError::Size),
        (PenaltyTerm { len: 0, ..ok }, PenaltyError::Size),
        (
            PenaltyTerm {
                first: usize::MAX,
                ..ok
            },
            PenaltyError::Size,
        ),
        (PenaltyTerm { ridge: -1.0, ..ok }, PenaltyError::NonFinite),
        (
            PenaltyTerm {
                ridge: f64::INFINITY,
                ..ok
            },
            PenaltyError::NonFinite,
        ),
        (
            PenaltyTerm {
                smoothness: f64::NAN,
                ..ok
            },
            PenaltyError::NonFinite,
        ),
    ];
    for (t, e) in cases {
        assert_eq!(make(vec![ok, t], 0.0), Some(LmError::Penalty(e)), "{t:?}");
    }
    assert_eq!(
        make(vec![ok], f64::NAN),
        Some(LmError::Penalty(PenaltyError::NonFinite))
    );
    // Fixed storage: more terms than room.
    assert_eq!(
        FixedPenalty::<f64, 8, 1>::new(&[ok, ok]).err(),
        Some(PenaltyError::Size)
    );
}

/// ER20 with a 12-knot table on joint 2 (values no pose reaches are left to the penalty).
fn with_table() -> (Robot<f64, 6, kinecal::Inline<64>>, Vec<Param>) {
    let mut robot = er20();
    let j = &robot.joints()[1];
    let (lo, hi) = (j.lower, j.upper);
    robot
        .effects_mut()
        .push(EffectKind::Table, 1, 6, 1, lo, (hi - lo) / 11.0, &[0.0; 12])
        .unwrap();
    let mut params = ParamSet::<64>::full(6, false).unwrap().to_vec();
    params.retain(|p| !matches!(p, Param::Theta(1)));
    params.extend((0..12).map(Param::Effect));
    (robot, params)
}

#[test]
fn table_columns_equal_the_jacobian_and_a_table_penalty_holds_unexcited_knots() {
    let (robot, params) = with_table();
    // Poses that keep joint 2 in the lower half of its range: the upper knots see nothing.
    let (_, mut data) = poses(120, 6);
    let mid = 0.5 * (robot.joints()[1].lower + robot.joints()[1].upper);
    data.retain(|m| m.q[1] < mid);
    // The first pass's normal matrix equals JᵀJ of the columns `ForwardKinematics::column`
    // gives (the pass reads the tables' columns from one segment look-up per pose).
    let mut lm = Levenberg::new(robot.clone(), VecLm::new(&params), LmConfig::default()).unwrap();
    lm.step(&data, data.len()).unwrap();
    let reach = robot.reach();
    let mut fk = ForwardKinematics::new();
    let n = params.len();
    let mut a = DMatrix::<f64>::zeros(n, n);
    for m in &data {
        fk.compute(&robot, &m.q);
        let cols: Vec<Vector3<f64>> = params
            .iter()
            .map(|p| fk.column(&robot, *p).unwrap() / p.scale(reach))
            .collect();
        for i in 0..n {
            for k in 0..=i {
                a[(i, k)] += cols[i].dot(&cols[k]);
            }
        }
    }
    for i in 0..n {
        for k in 0..=i {
            assert!(
                (lm.normal_matrix(i, k) - a[(i, k)]).abs() <= 1e-9 * (1.0 + a[(i, k)].abs()),
                "({i}, {k})"
            );
        }
    }
    // With a ridge on the knots every knot is determined: nothing is held, the unexcited knots
    // stay at zero and the fit reaches the noise.
    let first = params.iter().position(|p| *p == Param::Effect(0)).unwrap();
    let pen = VecPenalty::new(n, vec![PenaltyTerm::relative(first, 12, 1e-3, 0.0)]);
    let cfg = LmConfig::default();
    let mut lm = Levenberg::with_penalty(robot.clone(), VecLm::new(&params), pen, cfg).unwrap();
    lm.run(&data).unwrap();
    assert_eq!(
        lm.unidentifiable()
            .filter(|p| matches!(p, Param::Effect(_)))
            .count(),
        0
    );
    let values = lm.robot().effects().values();
    assert!(values[9..12].iter().all(|v| v.abs() < 1e-12), "{values:?}");
    let rms = (lm.progress().cost / data.len() as f64).sqrt();
    assert!(rms < 0.03, "{rms}");
}

#[test]
fn penalised_snapshots_restore_bit_identically_and_only_into_a_like_solver() {
    let (robot, params) = with_table();
    let (_, data) = poses(60, 7);
    let first = params.iter().position(|p| *p == Param::Effect(0)).unwrap();
    let n = params.len();
    let make = || {
        let pen = VecPenalty::new(n, vec![PenaltyTerm::relative(first, 12, 1e-3, 0.05)]);
        let mut lm =
            Levenberg::with_penalty(robot.clone(), VecLm::new(&params), pen, LmConfig::default())
                .unwrap();
        lm.hold(Param::D(0)).unwrap();
        lm
    };
    let mut reference = make();
    reference.run(&data).unwrap();
    let mut lm = make();
    let mut restores = 0;
    loop {
        let p = lm.step(&data, 13).unwrap();
        if p.stopped.is_some() {
            break;
        }
        let mut buf = Vec::new();
        lm.save(&mut buf).unwrap();
        let mut fresh = make();
        fresh.restore(&mut buf.as_slice()).unwrap();
        lm = fresh;
        restores += 1;
    }
    assert!(restores > 5);
    assert_eq!(lm.robot(), reference.robot());
    assert_eq!(lm.progress(), reference.progress());
    assert_eq!(lm.penalty(), reference.penalty());

    // A penalised snapshot does not restore into a solver without the penalty or the hold,
    // nor a plain one into a penalised solver.
    let mut buf = Vec::new();
    lm.save(&mut buf).unwrap();
    let mut plain =
        Levenberg::new(robot.clone(), VecLm::new(&params), LmConfig::default()).unwrap();
    assert!(plain.restore(&mut buf.as_slice()).is_err());
    let mut plain_buf = Vec::new();
    plain.save(&mut plain_buf).unwrap();
    let mut target = make();
    assert!(target.restore(&mut plain_buf.as_slice()).is_err());
    let pen = VecPenalty::new(n, vec![PenaltyTerm::relative(first, 12, 1e-3, 0.05)]);
    let mut no_hold =
        Levenberg::with_penalty(robot.clone(), VecLm::new(&params), pen, LmConfig::default())
            .unwrap();
    assert!(no_hold.restore(&mut buf.as_slice()).is_err());
}
