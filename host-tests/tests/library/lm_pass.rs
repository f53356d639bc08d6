//! Levenberg–Marquardt passes spread over parts (`kinecal::identify::lm`, the host's
//! `parallel::run_lm`): the same run as one `step` loop up to the order of summation, and every
//! misuse refused with a typed error.

use kinecal::identify::lm::{Levenberg, LmConfig, LmError, PassKind, PassPart};
use kinecal::model::param::{Param, ParamSet};
use kinecal::{ForwardKinematics, Measurement, Robot};
use kinecal_cli::compute::vec_lm::VecLm;
use kinecal_cli::simulation;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

type Lm = Levenberg<f64, 6, kinecal::Inline<64>, VecLm<f64>>;

/// The ER20 stand-in with the base estimated too (6 base parameters, some confounded and
/// held), a perturbed truth ([`simulation::perturb_geometry`]), and noisy poses of it.
fn problem(
    n: usize,
    seed: u64,
) -> (
    Robot<f64, 6, kinecal::Inline<64>>,
    Vec<Param>,
    Vec<Measurement<f64, 6>>,
) {
    let nominal = simulation::er20_c10()
        .with_capacity::<kinecal::Inline<64>>()
        .unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let (_, data) = simulation::perturbed_measurements(&nominal, n, 0.01, &mut rng);
    let params = ParamSet::<64>::full(6, true).unwrap().to_vec();
    (nominal, params, data)
}

fn solver(start: &Robot<f64, 6, kinecal::Inline<64>>, params: &[Param]) -> Lm {
    Levenberg::new(start.clone(), VecLm::new(params), LmConfig::default()).unwrap()
}

/// Runs `lm` with every pass cut into `parts` pieces, accumulated in reverse order (so that
/// nothing depends on the order the workers finish in).
fn run_in_parts(lm: &mut Lm, data: &[Measurement<f64, 6>], parts: usize) -> u32 {
    let chunks: Vec<_> = data.chunks(data.len().div_ceil(parts)).collect();
    let mut store: Vec<PassPart<f64, VecLm<f64>>> = chunks
        .iter()
        .map(|_| PassPart::new(VecLm::for_pass(lm.params())))
        .collect();
    let mut passes = 0;
    loop {
        let p = match lm.pass() {
            Some(pass) => {
                let mut fk = ForwardKinematics::new();
                for (part, poses) in store.iter_mut().zip(&chunks).rev() {
                    pass.accumulate(&mut fk, poses, part).unwrap();
                }
                passes += 1;
                lm.complete_pass(&store).unwrap()
            }
            None => lm.step(data, 1).unwrap(),
        };
        if p.stopped.is_some() {
            return passes;
        }
    }
}

/// The largest distance (mm) between the points two models predict at the poses of `data`.
fn model_gap(a: &Lm, b: &Lm, data: &[Measurement<f64, 6>]) -> f64 {
    let (mut fa, mut fb) = (ForwardKinematics::new(), ForwardKinematics::new());
    data.iter()
        .map(|m| (fa.compute(a.robot(), &m.q) - fb.compute(b.robot(), &m.q)).norm())
        .fold(0.0, f64::max)
}

/// Both runs ended at a minimum (not at a limit) with the same cost, the same held set and the
/// same model. Summation order moves the costs in the 13th digit, which can decide whether one
/// more tiny step is taken at the end: iteration counts may differ, the outcome may not.
fn same_outcome(a: &Lm, b: &Lm, data: &[Measurement<f64, 6>]) {
    use kinecal::identify::lm::LmStop::{Converged, SmallStep};
    let (pa, pb) = (a.progress(), b.progress());
    assert!(matches!(pa.stopped, Some(Converged | SmallStep)), "{pa:?}");
    assert!(matches!(pb.stopped, Some(Converged | SmallStep)), "{pb:?}");
    assert!(
        (pa.cost - pb.cost).abs() <= 1e-9 * pb.cost,
        "cost {} vs {}",
        pa.cost,
        pb.cost
    );
    let held = |lm: &Lm| lm.unidentifiable().collect::<Vec<_>>();
    assert_eq!(held(a), held(b));
    assert!(!held(b).is_empty(), "the base confounds some parameters");
    let gap = model_gap(a, b, data);
    assert!(gap < 1e-6, "the models differ by {gap} mm");
}

#[test]
fn a_run_in_parts_is_the_run_of_step() {
    for (seed, parts) in [(1, 2), (2, 3), (3, 7)] {
        let (start, params, data) = problem(400, seed);
        let mut whole = solver(&start, &params);
        let end = whole.run(&data).unwrap();
        let mut split = solver(&start, &params);
        let passes = run_in_parts(&mut split, &data, parts);
        assert!(end.stopped.is_some());
        assert_eq!(
            passes,
            split.progress().evaluations,
            "every pass went through the parts"
        );
        same_outcome(&split, &whole, &data);
    }
}

/// The host's passes (8 parts on both cores, each part's rows added in blocks of 16 poses) end
/// where `step` does. Seed 8: a problem whose identifiability analysis is not on a knife edge.
/// With seeds 4 to 7 the weakly determined wrist parameters (`d5`, `α6`, `θ5`) are held or
/// estimated according to the order of summation alone: 3, 7 or 8 parts, rows in blocks or
/// one pose at a time each choose one of them, minima within 0.3 % in cost of each other.
#[test]
fn the_host_runs_large_data_in_parts_with_the_same_outcome() {
    let n = kinecal_cli::compute::parallel::PARALLEL_MIN_POSES + 1000;
    let (start, params, data) = problem(n, 8);
    let mut whole = solver(&start, &params);
    let end = whole.run(&data).unwrap();
    let mut host = solver(&start, &params);
    let mut calls = 0;
    let p = kinecal_cli::compute::parallel::run_lm(&mut host, &data, |_, _| calls += 1).unwrap();
    assert!(end.stopped.is_some());
    assert!(
        calls >= p.evaluations as usize,
        "one call per pass at least"
    );
    same_outcome(&host, &whole, &data);
}

#[test]
fn parts_that_do_not_cover_the_data_once_are_refused() {
    let (start, params, data) = problem(60, 5);
    let mut lm = solver(&start, &params);
    let mut part = PassPart::new(VecLm::new(&params));
    let pass = lm.pass().unwrap();
    assert_eq!(pass.kind(), PassKind::Estimate);
    pass.accumulate(&mut ForwardKinematics::new(), &data, &mut part)
        .unwrap();
    assert_eq!(part.poses(), 60);
    lm.complete_pass(&[part.clone()]).unwrap();
    // The first pass fixed the data at 60 poses; now a solve is due, not a pass.
    assert!(lm.pass().is_none());
    assert_eq!(
        lm.complete_pass(&[part.clone()]),
        Err(LmError::PassMismatch)
    );
    lm.step(&data, 1).unwrap();
    let pass = lm.pass().unwrap();
    assert_eq!(pass.kind(), PassKind::Candidate);
    // A part still holding the last pass's sums is not of this pass.
    assert_eq!(
        lm.complete_pass(&[part.clone()]),
        Err(LmError::PassMismatch)
    );
    // Half the poses: the data changed.
    let pass = lm.pass().unwrap();
    pass.accumulate(&mut ForwardKinematics::new(), &data[..30], &mut part)
        .unwrap();
    assert_eq!(lm.complete_pass(&[part.clone()]), Err(LmError::DataChanged));
    // The refusals left the run where it was: the whole pass completes it.
    let pass = lm.pass().unwrap();
    let mut whole = PassPart::new(VecLm::new(&params));
    pass.accumulate(&mut ForwardKinematics::new(), &data, &mut whole)
        .unwrap();
    lm.complete_pass(&[whole]).unwrap();
    assert_eq!(lm.progress().evaluations, 2);
}

#[test]
fn bad_parts_and_bad_poses_get_typed_errors() {
    let (start, params, mut data) = problem(60, 6);
    let lm = solver(&start, &params);
    let pass = lm.pass().unwrap();
    let mut fk = ForwardKinematics::new();
    // Storage for other parameters.
    let mut other = PassPart::new(VecLm::new(&params[1..]));
    assert_eq!(
        pass.accumulate(&mut fk, &data, &mut other),
        Err(LmError::PassMismatch)
    );
    // A non-finite pose.
    data[7].point.x = f64::NAN;
    let mut part = PassPart::new(VecLm::new(&params));
    assert_eq!(
        pass.accumulate(&mut fk, &data, &mut part),
        Err(LmError::NonFiniteMeasurement)
    );
    // Too few poses for the parameters, on the first pass.
    let mut lm = solver(&start, &params);
    let pass = lm.pass().unwrap();
    let mut part = PassPart::new(VecLm::new(&params));
    pass.accumulate(&mut fk, &data[..3], &mut part).unwrap();
    assert_eq!(lm.complete_pass(&[part]), Err(LmError::TooFewMeasurements));
}

/// A pass in parts reads a table's columns from one segment look-up per pose when its knots
/// follow in order (decided once for the pass) and knot by knot otherwise: either way its
/// normal matrix is `JᵀJ` of the columns [`ForwardKinematics::column`] gives. Orders: the
/// usual one; the knots reversed (the first knot last); a geometric parameter between two
/// knots; the first knot alone at the front; some knots held (gaps in the run of knots).
#[test]
fn a_pass_in_parts_reads_table_knots_in_any_order() {
    use kinecal::model::effects::EffectKind;
    let (mut robot, geometric, data) = problem(150, 9);
    let (lo, hi) = (robot.joints()[1].lower, robot.joints()[1].upper);
    let values: Vec<f64> = (0..12).map(|i| 1e-4 * (i as f64 - 5.5)).collect();
    robot
        .effects_mut()
        .push(EffectKind::Table, 1, 6, 1, lo, (hi - lo) / 11.0, &values)
        .unwrap();
    let mut base: Vec<Param> = geometric.clone();
    base.retain(|p| !matches!(p, Param::Theta(1)));
    let knots = |r: std::ops::Range<u16>| r.map(Param::Effect).collect::<Vec<_>>();
    let split = |at: usize| {
        let mut p = base[..base.len() - 1].to_vec();
        p.extend(knots(0..at as u16));
        p.push(*base.last().unwrap());
        p.extend(knots(at as u16..12));
        p
    };
    let orders = [
        [base.clone(), knots(0..12)].concat(),
        [base.clone(), knots(0..12).into_iter().rev().collect()].concat(),
        split(5),
        [knots(0..1), base.clone(), knots(1..12)].concat(),
        // Knots held (not estimated): the first, two in the middle, the last.
        [base.clone(), knots(1..12)].concat(),
        [base.clone(), knots(0..4), knots(6..12)].concat(),
        [base.clone(), knots(0..11)].concat(),
    ];
    let reach = robot.reach();
    for params in orders {
        let mut lm = solver(&robot, &params);
        let mut part = PassPart::new(VecLm::for_pass(lm.params()));
        let pass = lm.pass().unwrap();
        pass.accumulate(&mut ForwardKinematics::new(), &data, &mut part)
            .unwrap();
        lm.complete_pass(&[part]).unwrap();
        let mut fk = ForwardKinematics::new();
        let n = params.len();
        let mut a = vec![0.0; n * n];
        for m in &data {
            fk.compute(&robot, &m.q);
            let cols: Vec<_> = params
                .iter()
                .map(|p| fk.column(&robot, *p).unwrap() / p.scale(reach))
                .collect();
            for i in 0..n {
                for k in 0..=i {
                    a[i * n + k] += cols[i].dot(&cols[k]);
                }
            }
        }
        for i in 0..n {
            for k in 0..=i {
                let (got, want) = (lm.normal_matrix(i, k), a[i * n + k]);
                assert!(
                    (got - want).abs() <= 1e-9 * (1.0 + want.abs()),
                    "{:?} and {:?}: {got} against {want}",
                    params[i],
                    params[k]
                );
            }
        }
    }
}
