//! Observations beyond one point: the orientation and further-point columns against
//! the independent reference's central differences, and identification from 6-D data, from
//! several reflectors and from weighted data against known truth and against the reference's
//! own solver (`kinecal_host::reference::ref_fit`: dense LM on finite-difference Jacobians of
//! its own residuals, nalgebra's rotation logarithm).
//!
//! Data are made by the reference model (not the library's kinematics) from a perturbed truth.
//! Models are compared by what they predict (points and orientations at joint readings): a
//! parameter held by the identifiability analysis leaves a family of equal models (base.rz and
//! theta1, tool.rz and theta6, d6 and tool.z …), and a held rotation is held only to first
//! order (steps about x and y compose to a little about z), so two solvers reach different
//! members of the same family.

use kinecal::forward::ForwardKinematics;
use kinecal::identify::lm::{
    observation_cost, rms_error, rms_orientation_error, FixedLevenberg, Levenberg, LmConfig,
};
use kinecal::model::param::{apply_delta, Param, ParamSet};
use kinecal::{EffectKind, Frame, Joint, Measurement, Robot};
use kinecal_host::reference::{ref_fit, small_angle, RefObservation, RefRobot};
use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::f64::consts::PI;

const V: usize = 64;
const P: usize = 64;
type Lm = FixedLevenberg<f64, 6, V, P>;

/// The UR10's nominal MDH rows (alpha°, a mm, theta°, d mm), as `data/ur10/robot.toml`.
const UR10_ROWS: [[f64; 4]; 6] = [
    [0.0, 0.0, 0.0, 118.0],
    [90.0, 0.0, 180.0, 0.0],
    [0.0, 612.7, 0.0, 0.0],
    [0.0, 571.6, 0.0, 163.9],
    [-90.0, 0.0, 0.0, 115.7],
    [90.0, 0.0, 180.0, 92.2],
];

/// Position noise (mm) and orientation noise (rad: 0.005°) of the simulated tracker.
const SIGMA: f64 = 0.02;
fn sigma_rot() -> f64 {
    0.005f64.to_radians()
}

/// The UR10 seen by a tracker about 3 m away (base turned and tilted), tool point `tool`.
fn ur10(tool: Vector3<f64>) -> Robot<f64, 6, V> {
    let joints = std::array::from_fn(|i| {
        let [alpha, a, theta, d] = UR10_ROWS[i];
        Joint {
            alpha: alpha.to_radians(),
            a,
            theta: theta.to_radians(),
            d,
            beta: 0.0,
            lower: -2.0 * PI,
            upper: 2.0 * PI,
        }
    });
    let base = Frame::from_xyz_rpy([2600.0, -1400.0, -350.0], [0.02, -0.015, 2.4]);
    Robot::new(base, joints, tool).unwrap()
}

fn deg(x: f64) -> f64 {
    x.to_radians()
}

/// Random joint readings over ±170°.
fn random_q(rng: &mut Xoshiro256PlusPlus) -> [f64; 6] {
    std::array::from_fn(|_| rng.random_range(-170f64..170.0).to_radians())
}

/// The truth: `nominal` with every parameter of `set` moved (lengths ±0.8 mm, angles ±0.1°),
/// the base by a few mm and tenths of a degree (the rough tracker alignment the fit starts
/// from), then the extra moves of `extra`.
fn truth_of(
    nominal: &Robot<f64, 6, V>,
    set: &[Param],
    extra: &[(Param, f64)],
    rng: &mut Xoshiro256PlusPlus,
) -> Robot<f64, 6, V> {
    let mut t = nominal.clone();
    let delta: Vec<f64> = set
        .iter()
        .map(|p| match p {
            Param::BaseX | Param::BaseY | Param::BaseZ => rng.random_range(-5.0..5.0),
            Param::BaseRx | Param::BaseRy | Param::BaseRz => deg(rng.random_range(-0.4..0.4)),
            p if p.is_tool_rotation() => 0.0,
            p if p.is_length() => rng.random_range(-0.8..0.8),
            _ => deg(rng.random_range(-0.1..0.1)),
        })
        .collect();
    apply_delta(&mut t, set, &delta).unwrap();
    let (ps, ds): (Vec<Param>, Vec<f64>) = extra.iter().copied().unzip();
    apply_delta(&mut t, &ps, &ds).unwrap();
    t
}

/// An observation of tool point `k` at `q`, made by the reference model of `truth` from six
/// standard normal draws `noise`: the point moved by σ·noise[0..3], weights 1/σ; with
/// `six_d`, the tool frame's orientation turned by the rotation vector σ_rot·noise[3..6],
/// weight 1/σ_rot.
fn observe(
    truth: &RefRobot,
    q: [f64; 6],
    k: usize,
    sigma: f64,
    six_d: bool,
    noise: &[f64; 6],
) -> Measurement<f64, 6> {
    let p = truth.point_at(&q, k);
    let mut m = Measurement::new(q, p + Vector3::new(noise[0], noise[1], noise[2]) * sigma);
    m.tool = k as u8;
    m.weight = Vector3::repeat(1.0 / sigma);
    if six_d {
        let e = Vector3::new(noise[3], noise[4], noise[5]) * sigma_rot();
        let r = Rotation3::from_scaled_axis(e).into_inner() * truth.tool_rotation(&q);
        m.orientation = Some(Frame::from_parts(&r, Vector3::zeros()));
        m.orientation_weight = 1.0 / sigma_rot();
    }
    m
}

/// Six standard normal numbers.
fn normals(rng: &mut Xoshiro256PlusPlus) -> [f64; 6] {
    let n = Normal::new(0.0, 1.0).unwrap();
    std::array::from_fn(|_| n.sample(rng))
}

fn to_ref(m: &Measurement<f64, 6>) -> RefObservation {
    RefObservation {
        q: m.q.to_vec(),
        tool: m.tool as usize,
        point: m.point,
        weight: m.weight,
        orientation: m.orientation.map(|f| f.rotation()),
        orientation_weight: m.orientation_weight,
    }
}

/// The parameters the library estimated (neither held by the caller nor by the analysis).
fn active(lm: &Lm) -> Vec<Param> {
    (0..lm.params().len())
        .filter(|k| lm.is_active(*k))
        .map(|k| lm.params()[k])
        .collect()
}

/// Largest difference of point (mm, over `points` tool points) and tool orientation (rad)
/// that two models predict at `poses`.
fn prediction_gap(a: &RefRobot, b: &RefRobot, poses: &[[f64; 6]], points: usize) -> (f64, f64) {
    let (mut dp, mut dr) = (0f64, 0f64);
    for q in poses {
        for k in 0..points {
            dp = dp.max((a.point_at(q, k) - b.point_at(q, k)).norm());
        }
        dr = dr.max(small_angle(&a.tool_rotation(q), &b.tool_rotation(q)));
    }
    (dp, dr)
}

/// Root-mean-square difference of point (mm) and tool orientation (rad) two models predict at
/// `poses` (tool point 0).
fn prediction_rms(a: &RefRobot, b: &RefRobot, poses: &[[f64; 6]]) -> (f64, f64) {
    let (mut sp, mut sr) = (0f64, 0f64);
    for q in poses {
        sp += (a.point(q) - b.point(q)).norm_squared();
        sr += small_angle(&a.tool_rotation(q), &b.tool_rotation(q)).powi(2);
    }
    let n = poses.len() as f64;
    ((sp / n).sqrt(), (sr / n).sqrt())
}

/// Standard errors of `params` at `robot` for whitened residuals (weights 1/σ): the square
/// roots of the diagonal of `(JᵀJ)⁻¹`, from the reference's difference Jacobian.
fn standard_errors(robot: &RefRobot, params: &[Param], data: &[RefObservation]) -> Vec<f64> {
    let j = robot.residual_jacobian(params, data);
    let cov = (j.transpose() * &j).try_inverse().expect("determined");
    (0..params.len()).map(|k| cov[(k, k)].sqrt()).collect()
}

/// Σ of the library's weighted squared residuals over `data`.
fn library_cost(robot: &Robot<f64, 6, V>, data: &[Measurement<f64, 6>]) -> f64 {
    let mut fk = ForwardKinematics::new();
    data.iter()
        .map(|m| observation_cost(&mut fk, robot, m).unwrap())
        .sum()
}

/// Residual rows of `data` (3 per point, 3 more per orientation).
fn rows(data: &[Measurement<f64, 6>]) -> usize {
    data.iter()
        .map(|m| if m.orientation.is_some() { 6 } else { 3 })
        .sum()
}

fn angle_between(a: &Matrix3<f64>, b: &Matrix3<f64>) -> f64 {
    small_angle(a, b)
}

// ---------------------------------------------------------------------------------------------
// Columns.

/// Every parameter of a robot with three tool points and `nv` effect values.
fn every_param(nv: usize) -> Vec<Param> {
    let mut v = vec![
        Param::BaseX,
        Param::BaseY,
        Param::BaseZ,
        Param::BaseRx,
        Param::BaseRy,
        Param::BaseRz,
    ];
    for i in 0..6u8 {
        v.extend([
            Param::Alpha(i),
            Param::A(i),
            Param::Theta(i),
            Param::D(i),
            Param::Beta(i),
        ]);
    }
    v.extend([Param::ToolX, Param::ToolY, Param::ToolZ]);
    for k in 1..3u8 {
        v.extend((0..3).map(|a| Param::ToolPoint(k, a)));
    }
    v.extend([Param::ToolRx, Param::ToolRy, Param::ToolRz]);
    v.extend((0..nv).map(|k| Param::Effect(k as u16)));
    v
}

/// A UR10 with tilted rows, three tool points, turned tool axes and effects; `coupled`: joint
/// 3 read relative to joint 2 (FANUC style).
fn column_robot(coupled: bool) -> Robot<f64, 6, V> {
    let mut r = ur10(Vector3::new(12.0, -7.0, 109.0));
    for (i, b) in [(1usize, 0.2), (2, -0.3), (4, 0.15)] {
        let mut j = r.joints()[i];
        j.beta = deg(b);
        r.set_joint(i, j).unwrap();
    }
    r.set_tool_point(1, Vector3::new(60.0, 5.0, 95.0)).unwrap();
    r.set_tool_point(2, Vector3::new(-35.0, 48.0, 120.0))
        .unwrap();
    r.set_tool_axes(Frame::from_xyz_rpy(
        [0.0; 3],
        [deg(12.0), deg(-25.0), deg(140.0)],
    ))
    .unwrap();
    let fx = r.effects_mut();
    fx.push(EffectKind::Cyclic, 1, 6, 2, 0.0, 0.0, &[3e-4, -2e-4])
        .unwrap();
    fx.push(EffectKind::Scale, 3, 6, 1, 0.0, 0.0, &[1.5e-3])
        .unwrap();
    fx.push(EffectKind::Cyclic, 5, 6, 1, 0.0, 0.0, &[-1e-4, 4e-4])
        .unwrap();
    if coupled {
        r.set_coupling(2, 1, 1.0).unwrap();
    }
    r
}

/// `column` and `rotation_column` of every parameter kind, for each of the three tool points,
/// at random poses, against the reference's central differences (`dp_dparam_at`: five-point,
/// good to ~1e-8 mm per unit; `dr_dparam`: every parameter turns the tool frame by one factor
/// `exp(h·axis)`, so the two-point difference is exact up to rounding, ~1e-12).
#[test]
fn position_and_rotation_columns_match_reference_differences() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(18);
    let (mut worst_p, mut worst_r, mut checked) = (0f64, 0f64, 0usize);
    for coupled in [false, true] {
        let r = column_robot(coupled);
        let reference = RefRobot::from_robot(&r);
        assert_eq!(reference.more_tools.len(), 2);
        let params = every_param(r.effects().values().len());
        let mut fk = ForwardKinematics::<f64, 6>::new();
        for _ in 0..6 {
            let q = random_q(&mut rng);
            for k in 0..3 {
                let p = fk.compute_point(&r, &q, k).unwrap();
                assert!((p - reference.point_at(&q, k)).norm() < 1e-9);
                let rot = fk.tool_pose(&r).rotation();
                assert!((rot - reference.tool_rotation(&q)).norm() < 1e-12);
                for par in &params {
                    let name = par.name(&r).to_string();
                    let c = fk.column(&r, *par).unwrap();
                    let want = reference.dp_dparam_at(&q, *par, k);
                    let e = (c - want).norm();
                    assert!(
                        e <= 1e-6 * want.norm() + 1e-7,
                        "point {k}, {name} (coupled {coupled}): {c} vs {want}"
                    );
                    let c = fk.rotation_column(&r, *par).unwrap();
                    let want = reference.dr_dparam(&q, *par);
                    let er = (c - want).norm();
                    assert!(
                        er <= 1e-9,
                        "point {k}, {name} (coupled {coupled}): rotation {c} vs {want}"
                    );
                    worst_p = worst_p.max(e / (1.0 + want.norm()));
                    worst_r = worst_r.max(er);
                    checked += 1;
                }
            }
        }
    }
    eprintln!(
        "{checked} columns: worst position {worst_p:.1e} (relative), rotation {worst_r:.1e} rad"
    );
}

// ---------------------------------------------------------------------------------------------
// 6-D data.

/// The set of the 6-D fits: base, alpha/a/theta/d of every row (theta6 among them), the tool
/// point and its orientation. tool.rz is held: turning the measured frame about the flange's z
/// axis and turning joint 6's zero are the same motion, so one of the two is a convention.
fn six_d_set() -> ParamSet<P> {
    let mut s = ParamSet::<P>::full(6, true).unwrap();
    for p in [Param::ToolRx, Param::ToolRy, Param::ToolRz] {
        s.push(p).unwrap();
    }
    s
}

/// The library's fit of `data` over `set` from `nominal`, holding `hold`.
fn fit_with(
    nominal: &Robot<f64, 6, V>,
    set: &ParamSet<P>,
    data: &[Measurement<f64, 6>],
    cfg: LmConfig<f64>,
    hold: &[Param],
) -> Lm {
    let mut lm = Levenberg::fixed(nominal.clone(), set.clone(), cfg).unwrap();
    for p in hold {
        lm.hold(*p).unwrap();
    }
    lm.run(data).unwrap();
    lm
}

fn fit(nominal: &Robot<f64, 6, V>, set: &ParamSet<P>, data: &[Measurement<f64, 6>]) -> Lm {
    fit_with(nominal, set, data, LmConfig::default(), &[Param::ToolRz])
}

/// Settings that run to the exact least-squares minimum: no ridge (the default keeps 1e-9 of
/// the mean curvature on the total step, pulling weak directions towards the start), and
/// stopping only when a step promises less than 1e-15 of the cost (the default: 1e-10, which
/// leaves up to a few 1e-7 mm on the table).
fn exact() -> LmConfig<f64> {
    LmConfig {
        ridge: 0.0,
        cost_tolerance: 1e-15,
        step_tolerance: 1e-13,
        ..LmConfig::default()
    }
}

/// `Rz(theta6)·R_tool`: where the measured frame sits relative to joint 6's axis at reading 0
/// (what 6-D data see of theta6 and the tool axes together).
fn last_link_rotation(r: &RefRobot) -> Matrix3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), r.joints[5].theta).into_inner() * r.tool_axes
}

/// 6-D data (0.02 mm, 0.005°, weighted 1/σ) determine theta6 and the tool orientation; the
/// same poses' points alone do not (no point moves with the tool axes, and turning joint 6's
/// zero only turns the tool point about joint 6's axis, which the tool point's x and y do as
/// well; at the nominal point, on that axis, it moves nothing). The library's fit and the
/// reference solver's agree, and the cost over its degrees of freedom is χ².
#[test]
fn six_d_data_recover_theta6_and_tool_orientation() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(6);
    let mut nominal = ur10(Vector3::new(0.0, 0.0, 109.0));
    nominal
        .set_tool_axes(Frame::from_xyz_rpy(
            [0.0; 3],
            [deg(5.0), deg(-10.0), deg(30.0)],
        ))
        .unwrap();
    let set = six_d_set();
    let truth = truth_of(
        &nominal,
        &set,
        &[
            (Param::Theta(5), deg(0.25)),
            (Param::ToolRx, deg(0.12)),
            (Param::ToolRy, deg(-0.09)),
        ],
        &mut rng,
    );
    let reference_truth = RefRobot::from_robot(&truth);
    let poses: Vec<[f64; 6]> = (0..50).map(|_| random_q(&mut rng)).collect();
    let data: Vec<Measurement<f64, 6>> = poses
        .iter()
        .map(|q| observe(&reference_truth, *q, 0, SIGMA, true, &normals(&mut rng)))
        .collect();
    let points: Vec<Measurement<f64, 6>> = data
        .iter()
        .map(|m| Measurement {
            orientation: None,
            orientation_weight: 0.0,
            ..*m
        })
        .collect();
    let valid: Vec<[f64; 6]> = (0..50).map(|_| random_q(&mut rng)).collect();

    let lm = fit(&nominal, &set, &data);
    let held: Vec<Param> = lm.unidentifiable().collect();
    let fitted = RefRobot::from_robot(lm.robot());
    let theta6_err = (fitted.joints[5].theta - reference_truth.joints[5].theta).abs();
    let axes_err = angle_between(&fitted.tool_axes, &reference_truth.tool_axes);
    let last_err = angle_between(
        &last_link_rotation(&fitted),
        &last_link_rotation(&reference_truth),
    );
    let (gap_p, gap_r) = prediction_rms(&fitted, &reference_truth, &valid);
    let rms = rms_error(lm.robot(), &data);
    let rms_rot = rms_orientation_error(lm.robot(), &data).unwrap();
    // Standard errors at the truth, from the reference's Jacobian (whitened residuals).
    let params = active(&lm);
    let data_ref: Vec<RefObservation> = data.iter().map(to_ref).collect();
    let se = standard_errors(&reference_truth, &params, &data_ref);
    let se_of = |p: Param| se[params.iter().position(|x| *x == p).unwrap()];
    let se_theta6 = se_of(Param::Theta(5));
    let se_axes = se_of(Param::ToolRx).hypot(se_of(Param::ToolRy));
    eprintln!(
        "6-D: held {held:?}; theta6 error {:.2e}° (σ {:.2e}°), tool axes {:.2e}° (σ {:.2e}°), \
         Rz(theta6)·R_tool {:.2e}°; held-out RMS prediction vs truth {gap_p:.4} mm {:.2e}°; \
         fit RMS {rms:.4} mm {:.2e}°",
        theta6_err.to_degrees(),
        se_theta6.to_degrees(),
        axes_err.to_degrees(),
        se_axes.to_degrees(),
        last_err.to_degrees(),
        gap_r.to_degrees(),
        rms_rot.to_degrees()
    );
    assert!(!held.contains(&Param::Theta(5)), "{held:?}");
    assert!(!held.contains(&Param::ToolRx) && !held.contains(&Param::ToolRy));
    // Within four standard errors (theta6 was moved by 0.25°, the tool axes by 0.15°).
    assert!(theta6_err < 4.0 * se_theta6, "theta6 off by {theta6_err}");
    assert!(axes_err < 4.0 * se_axes, "tool axes off by {axes_err}");
    assert!(last_err < 4.0 * se_axes.hypot(se_theta6));
    // Held-out poses, noise-free: better than one reading.
    assert!(gap_p < SIGMA && gap_r < sigma_rot(), "{gap_p} {gap_r}");

    // Positions alone: tool.rx/ry have no column, theta6 none at the start (held at nominal,
    // 0.25° and 0.15° from the truth, and kept held as the model moves: from then on it only
    // repeats tool.x/y), and the rest still fits the points.
    let lp = fit(&nominal, &set, &points);
    let held_p: Vec<Param> = lp.unidentifiable().collect();
    eprintln!("positions only: held {held_p:?}");
    for p in [Param::Theta(5), Param::ToolRx, Param::ToolRy] {
        assert!(held_p.contains(&p), "{p:?} not held: {held_p:?}");
    }
    let fitted_p = RefRobot::from_robot(lp.robot());
    assert_eq!(fitted_p.joints[5].theta, nominal.joints()[5].theta);
    assert_eq!(lp.robot().tool_axes(), nominal.tool_axes());
    assert!(
        angle_between(
            &last_link_rotation(&fitted_p),
            &last_link_rotation(&reference_truth)
        ) > deg(0.2)
    );
    assert!(rms_error(lp.robot(), &points) < 2.0 * SIGMA);

    // The reference solver on the same data and parameters, from the same start. Models are
    // compared by their predictions at the data's and at held-out poses (the held tool.rz
    // leaves theta6 and the tool axes free to trade a rotation about z6 between them, to second
    // order of the steps: 1.6e-6 rad here, different for every path), and by
    // Rz(theta6)·R_tool, which that trade leaves alone.
    let rf = ref_fit(&RefRobot::from_robot(&nominal), &params, &data_ref);
    // The reference solver itself: noise-free data of the library's fit (a model of the
    // family the held parameters allow: the truth is not, as its alpha3/alpha4 moves make
    // the axes d3, d4 slide along not quite parallel) are fitted back from nominal. Not to
    // rounding: nalgebra's angle is acos((trace − 1)/2), and next to zero acos(1 − 1.1e-16)
    // is 1.5e-8 rad, so orientation residuals below ~1e-8 rad are lost: it stops 2e-8 mm and
    // 3e-10 rad off (with an atan2 angle instead: 6e-13 mm). With noise, angles ~1e-4 rad,
    // the same acos is good to ~1e-11 rad.
    let exact_data: Vec<RefObservation> = poses
        .iter()
        .map(|q| to_ref(&observe(&fitted, *q, 0, SIGMA, true, &[0.0; 6])))
        .collect();
    let rf0 = ref_fit(&RefRobot::from_robot(&nominal), &params, &exact_data);
    let (tp, tr) = prediction_gap(&rf0.robot, &fitted, &valid, 1);
    eprintln!(
        "reference on noise-free data: cost {:.1e}, held-out predictions off the model by \
         {tp:.1e} mm {tr:.1e} rad",
        rf0.cost
    );
    assert!(
        rf0.cost < 1e-8 && tp < 1e-6 && tr < 1e-8,
        "{} {tp} {tr}",
        rf0.cost
    );
    let lib_cost = library_cost(lm.robot(), &data);
    let sv = &rf.singular_values;
    eprintln!(
        "reference: {} steps, cost {:.9}, library {:.9}, reference's residuals at the library's \
         model {:.9}; {} singular values of the scaled Jacobian, {:.2e} .. {:.2e}",
        rf.iterations,
        rf.cost,
        lib_cost,
        fitted.cost(&data_ref),
        sv.len(),
        sv[sv.len() - 1],
        sv[0],
    );
    // The reference's residuals take the orientation error's angle from acos of the trace,
    // ~1e-11 rad off at these angles (5e-8 of σ_rot per row): its cost is good to ~1e-7.
    assert!((lib_cost - fitted.cost(&data_ref)).abs() < 2e-7 * lib_cost);
    assert!((lib_cost - rf.cost).abs() < 2e-7 * lib_cost);
    // Default settings (a 1e-9 ridge; they stop once a step promises less than 1e-10 of the
    // cost): the whitened residuals may still be up to √(1e-10·cost) from the minimum's:
    // times σ, 3e-6 mm and 1.4e-8 rad here (measured: 3e-8 mm, 3e-10 rad). Run to the exact
    // minimum (see
    // `exact`): 1e-7 mm and 1e-11 rad (measured 2e-10 mm, 1.4e-12 rad: the reference's acos
    // angle, ~1e-11 rad per residual, is what is left; with an atan2 angle 4e-12 mm, 9e-15 rad).
    let bound = (LmConfig::<f64>::default().cost_tolerance * lib_cost).sqrt();
    let exact_fit = fit_with(&nominal, &set, &data, exact(), &[Param::ToolRz]);
    assert_eq!(active(&exact_fit), params);
    for (what, lib, tol_p, tol_r) in [
        (
            "default",
            fitted.clone(),
            bound * SIGMA,
            bound * sigma_rot(),
        ),
        (
            "exact",
            RefRobot::from_robot(exact_fit.robot()),
            1e-7,
            1e-11,
        ),
    ] {
        let (dp, dr) = prediction_gap(&lib, &rf.robot, &poses, 1);
        let (vp, vr) = prediction_gap(&lib, &rf.robot, &valid, 1);
        let dl = angle_between(&last_link_rotation(&lib), &last_link_rotation(&rf.robot));
        eprintln!(
            "  library ({what}) vs reference: predictions {dp:.1e} mm {dr:.1e} rad (held-out \
             {vp:.1e} mm {vr:.1e} rad), Rz(theta6)·R_tool {dl:.1e} rad, theta6 {:.1e} rad",
            (rf.robot.joints[5].theta - lib.joints[5].theta).abs()
        );
        assert!(dp.max(vp) < tol_p, "{what}: {dp} {vp} mm");
        assert!(dr.max(vr).max(dl) < tol_r, "{what}: {dr} {vr} {dl} rad");
    }

    // χ²: with the true σ, cost / (rows − parameters) is χ² over its degrees of freedom,
    // mean 1, standard deviation √(2/ν) (0.09 for ν = 300 − 30); 4 of them either way.
    let nu = (rows(&data) - params.len()) as f64;
    let chi = lib_cost / nu;
    eprintln!("χ²/ν = {chi:.3} (ν = {nu})");
    assert!((chi - 1.0).abs() < 4.0 * (2.0 / nu).sqrt(), "{chi}");
}

// ---------------------------------------------------------------------------------------------
// Several reflectors.

/// Three reflectors on the tool, each missing in about a fifth of the poses (every pose sees at
/// least one), unweighted: the fit finds all three and the geometry, and agrees with the
/// reference solver.
#[test]
fn three_reflectors_with_gaps_are_all_recovered() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let tools = [
        Vector3::new(0.0, 0.0, 109.0),
        Vector3::new(70.0, 0.0, 100.0),
        Vector3::new(-30.0, 55.0, 95.0),
    ];
    let mut nominal = ur10(tools[0]);
    nominal.set_tool_point(1, tools[1]).unwrap();
    nominal.set_tool_point(2, tools[2]).unwrap();
    let mut set = ParamSet::<P>::full(6, true).unwrap();
    for k in 1..3u8 {
        for a in 0..3u8 {
            set.push(Param::ToolPoint(k, a)).unwrap();
        }
    }
    let truth = truth_of(&nominal, &set, &[], &mut rng);
    let reference_truth = RefRobot::from_robot(&truth);
    let poses: Vec<[f64; 6]> = (0..60).map(|_| random_q(&mut rng)).collect();
    let mut data = Vec::new();
    let mut missing = [0usize; 3];
    for q in &poses {
        let mut seen: Vec<usize> = (0..3).filter(|_| rng.random_bool(0.8)).collect();
        if seen.is_empty() {
            seen.push(rng.random_range(0..3));
        }
        for (k, m) in missing.iter_mut().enumerate() {
            if !seen.contains(&k) {
                *m += 1;
            }
        }
        for k in seen {
            let mut m = observe(&reference_truth, *q, k, SIGMA, false, &normals(&mut rng));
            m.weight = Vector3::repeat(1.0);
            data.push(m);
        }
    }
    let valid: Vec<[f64; 6]> = (0..50).map(|_| random_q(&mut rng)).collect();

    let mut lm = Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
    lm.run(&data).unwrap();
    let held: Vec<Param> = lm.unidentifiable().collect();
    let fitted = RefRobot::from_robot(lm.robot());
    let per_point: Vec<f64> = (0..3)
        .map(|k| {
            let s: f64 = valid
                .iter()
                .map(|q| (fitted.point_at(q, k) - reference_truth.point_at(q, k)).norm_squared())
                .sum();
            (s / valid.len() as f64).sqrt()
        })
        .collect();
    let nominal_ref = RefRobot::from_robot(&nominal);
    let before: f64 = valid
        .iter()
        .map(|q| (nominal_ref.point_at(q, 1) - reference_truth.point_at(q, 1)).norm())
        .fold(0.0, f64::max);
    let dist = |r: &RefRobot, i: usize, j: usize| (r.tool_point(i) - r.tool_point(j)).norm();
    let dist_err = [(0, 1), (0, 2), (1, 2)]
        .iter()
        .map(|(i, j)| (dist(&fitted, *i, *j) - dist(&reference_truth, *i, *j)).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "3 points: {} observations, missing {missing:?} of {} poses; held {held:?}; held-out RMS \
         per point {per_point:.4?} mm (nominal's worst {before:.2} mm); inter-point distances \
         off by {dist_err:.1e} mm; fit RMS {:.4} mm",
        data.len(),
        poses.len(),
        rms_error(lm.robot(), &data)
    );
    for m in missing {
        assert!((6..=20).contains(&m), "{missing:?}");
    }
    assert!(before > 1.0);
    for e in &per_point {
        assert!(*e < SIGMA, "{per_point:?}");
    }
    assert!(dist_err < 0.01);
    // Nothing of the points themselves is held (theta6 or a point coordinate may be: turning
    // all three about joint 6's axis is the same as turning joint 6's zero).
    let point_coords_held = held.iter().filter(|p| p.is_tool()).count();
    assert!(point_coords_held <= 2, "{held:?}");

    // The reference solver, same data and parameters, same start.
    let params = active(&lm);
    let data_ref: Vec<RefObservation> = data.iter().map(to_ref).collect();
    let rf = ref_fit(&nominal_ref, &params, &data_ref);
    let lib_cost = library_cost(lm.robot(), &data);
    eprintln!(
        "reference: {} steps, cost {:.12}, library {:.12}",
        rf.iterations, rf.cost, lib_cost
    );
    assert!((lib_cost - rf.cost).abs() < 1e-9 * lib_cost);
    let exact_fit = Levenberg::fixed(nominal.clone(), set.clone(), exact())
        .and_then(|mut l| l.run(&data).map(|_| l))
        .unwrap();
    assert_eq!(active(&exact_fit), params);
    // Default settings: up to √(1e-10·cost) = 4e-6 mm from the minimum's residuals (see the
    // 6-D test; measured 5e-7 mm); run to the exact minimum, 1e-7 mm (measured 1e-8 mm).
    let bound = (LmConfig::<f64>::default().cost_tolerance * lib_cost).sqrt();
    for (what, lib, tol) in [
        ("default", fitted.clone(), bound),
        ("exact", RefRobot::from_robot(exact_fit.robot()), 1e-7),
    ] {
        let (dp, _) = prediction_gap(&lib, &rf.robot, &poses, 3);
        let (vp, _) = prediction_gap(&lib, &rf.robot, &valid, 3);
        eprintln!("  library ({what}) vs reference: {dp:.1e} mm (held-out {vp:.1e} mm)");
        assert!(dp.max(vp) < tol, "{what}: {dp} {vp}");
    }
    // Unweighted: cost / σ² over the degrees of freedom is χ²/ν.
    let nu = (rows(&data) - params.len()) as f64;
    let chi = lib_cost / (SIGMA * SIGMA) / nu;
    eprintln!("χ²/ν = {chi:.3} (ν = {nu})");
    assert!((chi - 1.0).abs() < 4.0 * (2.0 / nu).sqrt(), "{chi}");
}

// ---------------------------------------------------------------------------------------------
// Weights.

/// Held-out RMS (mm, noise-free poses) of the fit of `data` over the full set, base unknown.
fn held_out(
    nominal: &Robot<f64, 6, V>,
    data: &[Measurement<f64, 6>],
    valid: &[Measurement<f64, 6>],
) -> (f64, f64, usize) {
    let set = ParamSet::<P>::full(6, true).unwrap();
    let mut lm = Levenberg::fixed(nominal.clone(), set, LmConfig::default()).unwrap();
    lm.run(data).unwrap();
    let p = (0..lm.params().len()).filter(|k| lm.is_active(*k)).count();
    (
        rms_error(lm.robot(), valid),
        library_cost(lm.robot(), data),
        p,
    )
}

/// 5 % of the readings with 10× the noise, weighted by 1/σ (σ as the tracker reports it),
/// identify as well as data without them; unweighted, clearly worse.
#[test]
fn weights_discount_noisy_readings() {
    let nominal = ur10(Vector3::new(0.0, 0.0, 109.0));
    let set = ParamSet::<P>::full(6, true).unwrap();
    let (mut sc, mut sw, mut su) = (0.0, 0.0, 0.0);
    for seed in 0..8u64 {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(100 + seed);
        let truth = RefRobot::from_robot(&truth_of(&nominal, &set, &[], &mut rng));
        let n = 100;
        let poses: Vec<[f64; 6]> = (0..n).map(|_| random_q(&mut rng)).collect();
        let mut bad = vec![false; n];
        let mut count = 0;
        while count < n / 20 {
            let i = rng.random_range(0..n);
            if !bad[i] {
                bad[i] = true;
                count += 1;
            }
        }
        let noise: Vec<[f64; 6]> = (0..n).map(|_| normals(&mut rng)).collect();
        // The same draws: the clean set's reading i is σ·e_i, a noisy one 10σ·e_i.
        let clean: Vec<Measurement<f64, 6>> = (0..n)
            .map(|i| observe(&truth, poses[i], 0, SIGMA, false, &noise[i]))
            .collect();
        let weighted: Vec<Measurement<f64, 6>> = (0..n)
            .map(|i| {
                let s = if bad[i] { 10.0 * SIGMA } else { SIGMA };
                observe(&truth, poses[i], 0, s, false, &noise[i])
            })
            .collect();
        let unweighted: Vec<Measurement<f64, 6>> = weighted
            .iter()
            .map(|m| Measurement {
                weight: Vector3::repeat(1.0 / SIGMA),
                ..*m
            })
            .collect();
        let valid: Vec<Measurement<f64, 6>> = (0..200)
            .map(|_| observe(&truth, random_q(&mut rng), 0, SIGMA, false, &[0.0; 6]))
            .collect();
        let (c, _, _) = held_out(&nominal, &clean, &valid);
        let (w, w_cost, p) = held_out(&nominal, &weighted, &valid);
        let (u, _, _) = held_out(&nominal, &unweighted, &valid);
        let nu = (3 * n - p) as f64;
        eprintln!(
            "seed {seed}: held-out RMS clean {c:.4} mm, weighted {w:.4} ({:.2}×), unweighted {u:.4} \
             ({:.2}×); weighted χ²/ν {:.3}",
            w / c,
            u / c,
            w_cost / nu
        );
        // One fit's held-out RMS is itself a noisy number (seed 3: 1.17× the clean fit's).
        assert!(w < 1.3 * c && u > w, "seed {seed}");
        // With the true σ the weighted cost is χ² with ν degrees of freedom: within 4√(2/ν).
        assert!(
            (w_cost / nu - 1.0).abs() < 4.0 * (2.0 / nu).sqrt(),
            "seed {seed}"
        );
        sc += c * c;
        sw += w * w;
        su += u * u;
    }
    // Over the eight seeds: the noisy readings weighted by 1/σ cost what their lost information
    // predicts (95 % of the readings: √(1/0.95) = 1.03× the clean RMS); unweighted, their
    // variance is spread over all (0.95 + 0.05·100 = 5.95 times: ~2.4×).
    let (w, u) = ((sw / sc).sqrt(), (su / sc).sqrt());
    eprintln!("over all seeds: weighted {w:.3}× the clean held-out RMS, unweighted {u:.3}×");
    assert!(w < 1.2, "{w}");
    assert!(u > 1.5 * w, "{u} vs {w}");
}

/// A run over 6-D observations of one point and position observations of two more, saved and
/// restored into a fresh solver after every call, ends bit-identical to the uninterrupted run
/// (the snapshot carries the further tool points and the tool axes).
#[test]
fn snapshots_keep_tool_points_and_axes() {
    use kinecal::io::snapshot::Snapshot;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
    let mut nominal = ur10(Vector3::new(0.0, 0.0, 109.0));
    nominal
        .set_tool_point(1, Vector3::new(70.0, 0.0, 100.0))
        .unwrap();
    nominal
        .set_tool_point(2, Vector3::new(-30.0, 55.0, 95.0))
        .unwrap();
    nominal
        .set_tool_axes(Frame::from_xyz_rpy(
            [0.0; 3],
            [deg(5.0), deg(-10.0), deg(30.0)],
        ))
        .unwrap();
    let mut set = six_d_set();
    for k in 1..3u8 {
        for a in 0..3u8 {
            set.push(Param::ToolPoint(k, a)).unwrap();
        }
    }
    let truth = RefRobot::from_robot(&truth_of(
        &nominal,
        &set,
        &[(Param::ToolRx, deg(0.1)), (Param::ToolRy, deg(-0.1))],
        &mut rng,
    ));
    let data: Vec<Measurement<f64, 6>> = (0..25)
        .flat_map(|_| {
            let q = random_q(&mut rng);
            let n = [normals(&mut rng), normals(&mut rng), normals(&mut rng)];
            (0..3).map(move |k| (q, k, n[k]))
        })
        .map(|(q, k, n)| observe(&truth, q, k, SIGMA, k == 0, &n))
        .collect();
    let reference = fit(&nominal, &set, &data);
    let mut lm = Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
    lm.hold(Param::ToolRz).unwrap();
    let mut restores = 0;
    while lm.step(&data, 7).unwrap().stopped.is_none() {
        let mut buf = Vec::new();
        lm.save(&mut buf).unwrap();
        let mut fresh: Lm =
            Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
        // (A snapshot restores into a solver with the same holds.)
        fresh.hold(Param::ToolRz).unwrap();
        fresh.restore(&mut buf.as_slice()).unwrap();
        lm = fresh;
        restores += 1;
    }
    assert!(restores > 10);
    assert_eq!(lm.robot(), reference.robot());
    assert_eq!(lm.progress(), reference.progress());
    assert_ne!(lm.robot().tool_axes(), nominal.tool_axes());
    assert_ne!(lm.robot().tool_point(2), nominal.tool_point(2));
}
