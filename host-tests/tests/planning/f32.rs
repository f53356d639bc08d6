//! Planning in `f32` (the controller's scalar) against `f64`, and refusal of bad input
//! without panics: the library's planning code is generic and allocation-free, so the same
//! selection and online stepper run on a Cortex-M4F.

use kinecal::model::param::ParamSet;
use kinecal::num::real::Real;
use kinecal::planning::capsule::Capsule;
use kinecal::planning::cell::{Scene, SceneError, Tracker};
use kinecal::planning::information::{
    default_tolerance, scaled_rows, Covariance, Information, PoseRows,
};
use kinecal::planning::observability::criteria;
use kinecal::planning::online_design::OnlineDesign;
use kinecal::planning::selection::{self, Basis, Candidate, Criterion, DesignState, PlanError};
use kinecal::{ForwardKinematics, Frame, Joint, Robot};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

const P: usize = 33;

fn robot() -> Robot<f64, 6, kinecal::Inline<0>> {
    let rows = [
        Joint::mdh_deg(0.0, 0.0, 0.0, 504.0),
        Joint::mdh_deg(-90.0, 170.0, -90.0, 0.0),
        Joint::mdh_deg(0.0, 780.0, 0.0, 0.0),
        Joint::mdh_deg(-90.0, 140.0, 0.0, 760.0),
        Joint::mdh_deg(90.0, 0.0, 0.0, 0.0),
        Joint::mdh_deg(-90.0, 0.0, 0.0, 125.0),
    ];
    Robot::new(Frame::identity(), rows, Vector3::new(0.0, 0.0, 100.0)).unwrap()
}

fn rows<T: Real>(
    r: &Robot<T, 6, kinecal::Inline<0>>,
    params: &ParamSet<P>,
    q: &[T; 6],
) -> PoseRows<T, P> {
    let mut fk = ForwardKinematics::new();
    fk.compute(r, q);
    let mut g = [[T::zero(); P]; 3];
    scaled_rows(r, &fk, params.as_slice(), &mut g).unwrap();
    g
}

/// Pool → identifiable basis → KPI selection, in scalar T; returns the chosen pool indices
/// and the basis rank.
fn design<T: Real>(qs: &[[f64; 6]], work: &[[f64; 6]], n: usize) -> (Vec<usize>, usize) {
    let r: Robot<T, 6, kinecal::Inline<0>> = robot().cast().unwrap();
    let params = ParamSet::<P>::full(6, true).unwrap();
    let mut pool: Vec<Candidate<T, 6, P>> = qs
        .iter()
        .map(|q| {
            let q = q.map(T::of);
            Candidate {
                q,
                rows: rows(&r, &params, &q),
                incidence: T::zero(),
                clearance: T::one(),
                selected: false,
            }
        })
        .collect();
    let mut info = Information::<T, P>::new(params.len()).unwrap();
    for c in &pool {
        info.add_pose(&c.rows).unwrap();
    }
    let basis = Basis::new(&info, default_tolerance()).unwrap();
    basis.reduce_pool(&mut pool);
    let w: Vec<_> = work
        .iter()
        .map(|q| basis.reduce(&rows(&r, &params, &q.map(T::of))))
        .collect();
    let ridge = basis.per_pose() * T::EPS.sqrt();
    let mut state = DesignState::<T, P, 2>::new(basis.rank(), &w, ridge).unwrap();
    let mut d = vec![0; n];
    selection::select(&mut state, Criterion::Kpi, &mut pool, &mut d, 20).unwrap();
    (d, basis.rank())
}

fn kpi64(qs: &[[f64; 6]], work: &[[f64; 6]]) -> f64 {
    let r = robot();
    let params = ParamSet::<P>::full(6, true).unwrap();
    let mut info = Information::<f64, P>::new(params.len()).unwrap();
    for q in qs {
        info.add_pose(&rows(&r, &params, q)).unwrap();
    }
    let cov = Covariance::new(&info, 1.0, default_tolerance()).unwrap();
    let w: Vec<_> = work.iter().map(|q| rows(&r, &params, q)).collect();
    criteria(&cov, &w).kpi
}

fn configs(n: usize, seed: u64) -> Vec<[f64; 6]> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..n)
        .map(|_| std::array::from_fn(|_| rng.random_range(-2.5..2.5)))
        .collect()
}

#[test]
fn f32_selection_and_online_stepper_match_f64() {
    let qs = configs(500, 8);
    let work = configs(2, 9);
    let (d64, r64) = design::<f64>(&qs, &work, 40);
    let (d32, r32) = design::<f32>(&qs, &work, 40);
    assert_eq!(r32, r64, "identifiable directions");
    let k64 = kpi64(&d64.iter().map(|i| qs[*i]).collect::<Vec<_>>(), &work);
    let k32 = kpi64(&d32.iter().map(|i| qs[*i]).collect::<Vec<_>>(), &work);
    eprintln!("KPI of the f64 design {k64:.4e}, of the f32 design {k32:.4e}");
    assert!(k32 <= 1.05 * k64 && k64 <= 1.05 * k32);

    // The online stepper in f32 predicts what f64 linear algebra predicts.
    let r32: Robot<f32, 6, kinecal::Inline<0>> = robot().cast().unwrap();
    let params = ParamSet::<P>::full(6, true).unwrap();
    let mut info = Information::<f32, P>::new(params.len()).unwrap();
    for q in &qs {
        info.add_pose(&rows(&r32, &params, &q.map(|v| v as f32)))
            .unwrap();
    }
    let basis = Basis::new(&info, default_tolerance()).unwrap();
    let w32: Vec<[f32; 6]> = work.iter().map(|q| q.map(|v| v as f32)).collect();
    let mut online =
        OnlineDesign::<f32, 6, kinecal::Inline<0>, P, 2>::new(r32, params, basis, &w32, 0.01, 0.0)
            .unwrap();
    let measured = &qs[..30];
    let mut status = None;
    for q in measured {
        status = Some(online.add_measurement(&q.map(|v| v as f32)).unwrap());
    }
    let status = status.unwrap();
    let std = status
        .tool_std
        .expect("30 random poses determine the model");
    let k = kpi64(measured, &work) * 1e-4;
    let s32: f64 = std.iter().map(|s| (*s as f64).powi(2)).sum();
    assert!(
        (s32 - k).abs() <= 0.01 * k,
        "f32 online {s32:.5e} vs f64 {k:.5e}"
    );
    assert!(!status.reached, "a target of 0 is never reached");
    // NaN readings are refused and change nothing.
    assert_eq!(online.add_measurement(&[f32::NAN; 6]), Err(PlanError::Size));
    assert_eq!(online.status(), status);
}

#[test]
fn bad_input_is_refused_without_panics() {
    let work = [[[0.0f64; P]; 3]];
    assert_eq!(
        DesignState::<f64, P, 1>::new(10, &work, 0.0).unwrap_err(),
        PlanError::Numerical
    );
    assert_eq!(
        DesignState::<f64, P, 1>::new(P + 1, &work, 1.0).unwrap_err(),
        PlanError::Size
    );
    assert_eq!(
        DesignState::<f64, P, 0>::new(10, &work, 1.0).unwrap_err(),
        PlanError::WorkConfigurations
    );
    let mut state = DesignState::<f64, P, 1>::new(3, &work, 1e-6).unwrap();
    let mut g = [[0.0; P]; 3];
    g[0][0] = f64::NAN;
    assert_eq!(state.add(&g), Err(PlanError::Size));
    assert_eq!(state.poses(), 0);
    assert!(state.gain(Criterion::Kpi, &g) < 0.0);
    let mut pool: Vec<Candidate<f64, 6, P>> = Vec::new();
    let mut d = [0usize; 4];
    assert_eq!(
        selection::select(&mut state, Criterion::D, &mut pool, &mut d, 5).unwrap_err(),
        PlanError::PoolTooSmall
    );
    let t = Tracker {
        position: Vector3::new(f64::NAN, 0.0, 0.0),
        max_incidence: 0.5,
        beam_radius: 1.0,
    };
    assert_eq!(
        Scene::<f64, 2, 2>::new(t, None).unwrap_err(),
        SceneError::Invalid
    );
    let t = Tracker {
        position: Vector3::zeros(),
        max_incidence: 0.0,
        beam_radius: 1.0,
    };
    assert_eq!(
        Scene::<f64, 2, 2>::new(t, None).unwrap_err(),
        SceneError::Invalid
    );
    let t = Tracker {
        position: Vector3::zeros(),
        max_incidence: 0.5,
        beam_radius: 1.0,
    };
    let mut s = Scene::<f64, 1, 1>::new(t, Some(0.0)).unwrap();
    let c = Capsule::new(Vector3::zeros(), Vector3::x(), 1.0);
    assert_eq!(
        s.add_link_capsule(0, Capsule { radius: -1.0, ..c }),
        Err(SceneError::Invalid)
    );
    s.add_link_capsule(0, c).unwrap();
    assert_eq!(s.add_link_capsule(1, c), Err(SceneError::Capacity));
    s.add_obstacle(c).unwrap();
    assert_eq!(s.add_obstacle(c), Err(SceneError::Capacity));
    // A capsule on a frame the robot lacks makes every pose infeasible, with a reason.
    let mut s2 = Scene::<f64, 2, 1>::new(
        Tracker {
            position: Vector3::new(0.0, 0.0, 5000.0),
            ..t
        },
        None,
    )
    .unwrap();
    s2.add_link_capsule(9, c).unwrap();
    let r = robot();
    let mut fk = ForwardKinematics::new();
    fk.compute(&r, &[0.0, 0.0, 0.0, 0.0, -std::f64::consts::FRAC_PI_2, 0.0]);
    let a = s2.check(&r, &fk, true);
    assert!(!a.feasible());
    // NaN joint readings: a limits violation, not a panic.
    fk.compute(&r, &[f64::NAN; 6]);
    assert!(!s2.check(&r, &fk, true).feasible());
}
