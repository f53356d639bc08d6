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

mod columns;
mod reflectors;
mod six_d;
mod snapshots;
mod weights;

type V = kinecal::Inline<64>;
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
