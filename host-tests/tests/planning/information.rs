//! Information matrix, covariance, observability indices and the planner's rank-3 trial
//! updates, each against a direct dense computation with nalgebra (SVD pseudo-inverse,
//! explicit inverses), on a 6R arm with the full parameter set and its structural
//! redundancies (base against the first joint, the last joint's theta against the tool,
//! d of the parallel axes 2 and 3).

use kinecal::model::param::ParamSet;
use kinecal::planning::information::{
    default_tolerance, scaled_rows, Covariance, Information, PoseRows,
};
use kinecal::planning::observability::{criteria, indices};
use kinecal::planning::selection::{self, Basis, Candidate, Criterion, DesignState};
use kinecal::{ForwardKinematics, Frame, Joint, Robot};
use nalgebra::{DMatrix, Vector3};
use rand::{RngExt, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

const P: usize = 40;

fn robot() -> Robot<f64, 6, kinecal::Inline<0>> {
    let rows = [
        Joint::mdh_deg(0.0, 0.0, 0.0, 504.0),
        Joint::mdh_deg(-90.0, 170.0, -90.0, 0.0),
        Joint::mdh_deg(0.0, 780.0, 0.0, 0.0),
        Joint::mdh_deg(-90.0, 140.0, 0.0, 760.0),
        Joint::mdh_deg(90.0, 0.0, 0.0, 0.0),
        Joint::mdh_deg(-90.0, 0.0, 0.0, 125.0),
    ];
    Robot::new(Frame::identity(), rows, Vector3::new(10.0, -5.0, 100.0)).unwrap()
}

fn configs(n: usize, seed: u64) -> Vec<[f64; 6]> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..n)
        .map(|_| std::array::from_fn(|_| rng.random_range(-2.5..2.5)))
        .collect()
}

fn rows_at(
    r: &Robot<f64, 6, kinecal::Inline<0>>,
    params: &ParamSet<P>,
    q: &[f64; 6],
) -> PoseRows<f64, P> {
    let mut fk = ForwardKinematics::new();
    fk.compute(r, q);
    let mut g = [[0.0; P]; 3];
    scaled_rows(r, &fk, params.as_slice(), &mut g).unwrap();
    g
}

fn dense(rows: &[PoseRows<f64, P>], n: usize) -> DMatrix<f64> {
    DMatrix::from_fn(3 * rows.len(), n, |i, j| rows[i / 3][i % 3][j])
}

/// Moore–Penrose pseudo-inverse by SVD with a relative threshold on the singular values.
fn pinv(a: &DMatrix<f64>, rel: f64) -> DMatrix<f64> {
    let svd = a.clone().svd(true, true);
    let smax = svd.singular_values.max();
    let u = svd.u.unwrap();
    let vt = svd.v_t.unwrap();
    let k = svd.singular_values.len();
    let mut s_inv = DMatrix::zeros(k, k);
    for (k, s) in svd.singular_values.iter().enumerate() {
        if *s > rel * smax {
            s_inv[(k, k)] = 1.0 / s;
        }
    }
    vt.transpose() * s_inv * u.transpose()
}

#[test]
fn covariance_criteria_and_indices_match_dense_svd() {
    let r = robot();
    let params = ParamSet::<P>::full(6, true).unwrap();
    let n = params.len();
    let qs = configs(40, 3);
    let rows: Vec<_> = qs.iter().map(|q| rows_at(&r, &params, q)).collect();
    let mut info = Information::<f64, P>::new(n).unwrap();
    for g in &rows {
        info.add_pose(g).unwrap();
    }
    let j = dense(&rows, n);
    let jtj = j.transpose() * &j;
    for a in 0..n {
        for b in 0..n {
            assert!(
                (info.matrix()[a][b] - jtj[(a, b)]).abs()
                    <= 1e-9 * jtj[(a, a)].max(jtj[(b, b)]).max(1.0)
            );
        }
    }
    // Removing a pose undoes its update.
    let mut less = info.clone();
    less.remove_pose(&rows[0]).unwrap();
    less.add_pose(&rows[0]).unwrap();
    assert!(
        (0..n).all(|a| (0..n).all(|b| (less.matrix()[a][b] - info.matrix()[a][b]).abs() < 1e-6))
    );

    let sigma = 0.02;
    let cov = Covariance::new(&info, sigma, default_tolerance()).unwrap();
    // Structural redundancies of this arm with base, geometry and tool: base vs alpha1, a1,
    // theta1, d1 (4), theta6 and d6 vs the tool (2), d2/d3 of the parallel axes (1).
    assert_eq!(cov.rank(), n - 7, "identifiable directions");
    let svd = j.clone().svd(false, false);
    let smax = svd.singular_values.max();
    let mut s: Vec<f64> = svd
        .singular_values
        .iter()
        .copied()
        .filter(|v| *v > 1e-6 * smax)
        .collect();
    s.sort_by(|a, b| b.total_cmp(a));
    assert_eq!(s.len(), cov.rank());
    let m = s.len() as f64;
    let o1 = s.iter().map(|v| v.ln()).sum::<f64>() / m;
    let o1 = o1.exp() / (qs.len() as f64).sqrt();
    let (s1, sm) = (s[0], s[s.len() - 1]);
    let ix = indices(&cov, qs.len());
    let close =
        |a: f64, b: f64, what: &str| assert!((a - b).abs() <= 1e-6 * b.abs(), "{what}: {a} vs {b}");
    close(ix.o1, o1, "O1");
    close(ix.o2, s1 / sm, "O2");
    close(ix.o3, sm, "O3");
    close(ix.o4, sm * sm / s1, "O4");
    close(ix.o5, 1.0 / s.iter().map(|v| 1.0 / v).sum::<f64>(), "O5");

    // C = σ² (JᵀJ)⁺ = σ² J⁺ J⁺ᵀ.
    let jp = pinv(&j, 1e-6);
    let c_ref = (&jp * jp.transpose()) * (sigma * sigma);
    let mut c = [[0.0; P]; P];
    cov.matrix(&mut c);
    let cmax = c_ref.amax();
    for a in 0..n {
        for b in 0..n {
            assert!(
                (c[a][b] - c_ref[(a, b)]).abs() <= 1e-6 * cmax,
                "C[{a}][{b}]"
            );
        }
    }
    // Tool covariance at two working configurations, and the criteria.
    let work: Vec<_> = configs(2, 99)
        .iter()
        .map(|q| rows_at(&r, &params, q))
        .collect();
    let mut kpi_ref = 0.0;
    for w in &work {
        let js = DMatrix::from_fn(3, n, |i, k| w[i][k]);
        let cs_ref = &js * &c_ref * js.transpose();
        let cs = cov.tool_covariance(w);
        for a in 0..3 {
            for b in 0..3 {
                assert!((cs[a][b] - cs_ref[(a, b)]).abs() <= 1e-6 * cs_ref.amax());
            }
        }
        kpi_ref += cs_ref.trace();
    }
    let cr = criteria(&cov, &work);
    close(cr.kpi, kpi_ref, "KPI-A");
    close(cr.a, c_ref.trace(), "A");
    close(cr.e, sigma * sigma / (sm * sm), "E");
    let log_d = s
        .iter()
        .map(|v| (sigma * sigma / (v * v)).ln())
        .sum::<f64>()
        / m;
    close(cr.d, log_d.exp(), "D");
}

/// The Woodbury gains the optimiser ranks candidates by equal the change of the objective
/// computed by actually adding the pose; the KPI in identifiable coordinates equals the
/// pseudo-inverse KPI of the full parameters.
#[test]
fn rank_three_gains_equal_objective_changes_and_reduction_keeps_the_kpi() {
    let r = robot();
    let params = ParamSet::<P>::full(6, true).unwrap();
    let n = params.len();
    let qs = configs(200, 5);
    let mut pool: Vec<Candidate<f64, 6, P>> = qs
        .iter()
        .map(|q| Candidate {
            q: *q,
            rows: rows_at(&r, &params, q),
            incidence: 0.0,
            clearance: 1.0,
            selected: false,
        })
        .collect();
    let mut info = Information::<f64, P>::new(n).unwrap();
    for c in &pool {
        info.add_pose(&c.rows).unwrap();
    }
    let basis = Basis::new(&info, default_tolerance()).unwrap();
    assert_eq!(basis.rank(), n - 7);
    basis.reduce_pool(&mut pool);
    let work_q = configs(2, 77);
    let work_full: Vec<_> = work_q.iter().map(|q| rows_at(&r, &params, q)).collect();
    let work: Vec<_> = work_full.iter().map(|g| basis.reduce(g)).collect();
    let ridge = basis.per_pose() * 1e-8;
    let mut state = DesignState::<f64, P, 4>::new(basis.rank(), &work, ridge).unwrap();
    for c in pool.iter().take(30) {
        state.add(&c.rows).unwrap();
    }
    for criterion in [Criterion::D, Criterion::A, Criterion::Kpi] {
        let before = state.objective(criterion);
        for c in pool.iter().skip(100).take(5) {
            let gain = state.gain(criterion, &c.rows);
            let mut s2 = state.clone();
            s2.add(&c.rows).unwrap();
            let after = s2.objective(criterion);
            assert!(gain >= 0.0);
            assert!(
                (gain - (before - after)).abs() <= 1e-7 * before.abs().max(gain),
                "{criterion:?}: gain {gain} vs {}",
                before - after
            );
        }
    }
    // KPI of the 30 poses: reduced coordinates (ridge negligible) vs full pseudo-inverse.
    let mut full = Information::<f64, P>::new(n).unwrap();
    for q in qs.iter().take(30) {
        full.add_pose(&rows_at(&r, &params, q)).unwrap();
    }
    let cov = Covariance::new(&full, 1.0, default_tolerance()).unwrap();
    let kpi_full = criteria(&cov, &work_full).kpi;
    let kpi_reduced = state.objective(Criterion::Kpi);
    assert!(
        (kpi_full - kpi_reduced).abs() <= 1e-5 * kpi_full,
        "{kpi_full} vs {kpi_reduced}"
    );
    let mut var = [0.0; 2];
    assert!(state.tool_variances(1.0, &mut var));
    assert!((var[0] + var[1] - kpi_full).abs() <= 1e-5 * kpi_full);

    // Selection: greedy + exchange never ends worse than greedy, and a KPI design beats the
    // D design on the KPI while the D design beats it on D.
    let mut sk = DesignState::<f64, P, 4>::new(basis.rank(), &work, ridge).unwrap();
    let mut design_k = vec![0; 30];
    let ok = selection::select(&mut sk, Criterion::Kpi, &mut pool, &mut design_k, 20).unwrap();
    assert!(ok.objective <= ok.greedy_objective * (1.0 + 1e-12));
    assert_eq!(pool.iter().filter(|c| c.selected).count(), 30);
    let mut sd = DesignState::<f64, P, 4>::new(basis.rank(), &work, ridge).unwrap();
    let mut design_d = vec![0; 30];
    let od = selection::select(&mut sd, Criterion::D, &mut pool, &mut design_d, 20).unwrap();
    assert!(od.objective <= od.greedy_objective + 1e-9);
    assert!(sk.objective(Criterion::Kpi) < sd.objective(Criterion::Kpi));
    assert!(sd.objective(Criterion::D) < sk.objective(Criterion::D));
    let mut sorted = design_k.clone();
    sorted.sort_unstable();
    sorted.dedup();
    assert_eq!(sorted.len(), 30, "no pose twice");
}
