//! The calibration scenario both builds share: the host generator (f64) and the firmware (f32)
//! must agree on the robot, the parameter set and the solver settings, or the firmware's
//! comparisons against host-computed values would compare different problems.

use kinecal::identify::bpnn::{Bpnn, BpnnConfig};
use kinecal::identify::lm::LmConfig;
use kinecal::identify::pso::PsoConfig;
use kinecal::model::param::ParamSet;
use kinecal::{Frame, Joint, Real, Robot};
use nalgebra::Vector3;

/// Joints of the arm.
pub const N: usize = 6;
/// Identified parameters: alpha, a, theta, d of every joint (the BPNN-PSO paper's 24).
pub const P: usize = 24;
/// Poses measured for identification and held out for validation.
pub const ID_POSES: usize = 50;
pub const VAL_POSES: usize = 20;

/// Nominal MDH rows of an ER20-C10-like 6R arm: (alpha°, a mm, theta°, d mm).
pub const ROWS: [(f64, f64, f64, f64); N] = [
    (0.0, 0.0, 0.0, 504.0),
    (-90.0, 170.0, -90.0, 0.0),
    (0.0, 780.0, 0.0, 0.0),
    (-90.0, 140.0, 0.0, 760.0),
    (90.0, 0.0, 0.0, 0.0),
    (-90.0, 0.0, 0.0, 125.0),
];
/// Tool point in the flange frame, mm: off the flange axis so that theta6 is observable.
pub const TOOL_MM: [f64; 3] = [40.0, 30.0, 120.0];

/// The nominal model (data are in the robot base frame, so the base is the identity). Out of
/// line: the firmware builds it in several stages, one copy of the code serves them all.
#[inline(never)]
pub fn nominal<T: Real>() -> Robot<T, N> {
    let joints = ROWS.map(|(al, a, th, d)| Joint::mdh_deg(al, a, th, d));
    let tool = Vector3::new(T::of(TOOL_MM[0]), T::of(TOOL_MM[1]), T::of(TOOL_MM[2]));
    match Robot::new(Frame::identity(), joints, tool) {
        Ok(r) => r,
        // Finite constants: cannot fail.
        Err(_) => unreachable!("nominal rows are finite"),
    }
}

/// The same arm read the FANUC way: J3 measured from the horizontal, so the model angle is
/// `q3 = J3 + J2` (a `[[couplings]]` table, interfaces.md §3).
pub fn coupled<T: Real>() -> Robot<T, N> {
    let mut r = nominal::<T>();
    match r.set_coupling(2, 1, T::one()) {
        Ok(()) => r,
        Err(_) => unreachable!("J3 from J2 is a valid coupling"),
    }
}

/// The 24 parameters of the paper's model.
pub fn params() -> ParamSet<P> {
    match ParamSet::mdh(N) {
        Ok(s) => s,
        Err(_) => unreachable!("24 parameters fit a set of 24"),
    }
}

/// Solver settings shared by the host reference and the firmware (library defaults, which are
/// scaled to the scalar's precision).
pub fn lm_config<T: Real>() -> LmConfig<T> {
    LmConfig::default()
}

/// Particles of the firmware's small swarm and its iterations (the paper uses 200 × 404).
pub const SWARM: usize = 16;
pub const PSO_ITERATIONS: u32 = 8;
pub const PSO_SEED: u64 = 7;
/// Fitness history kept by the swarm (one entry per iteration).
pub const PSO_HISTORY: usize = 16;

/// The paper's coefficients over the calibration box (±0.5°, ±2 mm), a fixed number of
/// iterations and no early stop, so host and firmware run the same schedule.
pub fn pso_config<T: Real>() -> PsoConfig<T, P> {
    match PsoConfig::calibration(params().as_slice()) {
        Ok(mut c) => {
            c.max_iterations = PSO_ITERATIONS;
            c.stagnation_window = 0;
            c
        }
        Err(_) => unreachable!("24 parameters, finite box"),
    }
}

/// Hidden neurons of the BPNN (the paper's rule: round(√48) + 5).
pub const HIDDEN: usize =
    kinecal::identify::bpnn::hidden_size(P, P, kinecal::identify::bpnn::DEFAULT_A);
pub const BPNN_SEED: u64 = 11;
pub type Net<T> = Bpnn<T, P, HIDDEN, P>;

/// A fresh net whose input and output ranges are the PSO box (particle positions in, best
/// position out), as BPNN-PSO uses it.
pub fn net<T: Real>() -> Net<T> {
    let c = pso_config::<T>();
    match Bpnn::new(BpnnConfig::default(), BPNN_SEED) {
        Ok(mut n) => match n.set_ranges(&c.lower, &c.upper, &c.lower, &c.upper) {
            Ok(()) => n,
            Err(_) => unreachable!("finite ranges"),
        },
        Err(_) => unreachable!("valid default config"),
    }
}

/// The input of the BPNN forward check: a fixed point inside the box.
pub fn net_input<T: Real>() -> [T; P] {
    let set = params();
    core::array::from_fn(|k| {
        // The PSO box in f64, as `PsoConfig::calibration` draws it (±0.5° for angles, ±2 mm
        // for lengths), without an f64 `PsoConfig` in the firmware (1 KB of soft-float code).
        let b = if set.as_slice()[k].is_length() {
            2.0
        } else {
            0.5f64.to_radians()
        };
        let (lower, upper) = (-b, b);
        T::of(lower + (upper - lower) * ((k * 7 % 24) as f64 + 0.5) / 24.0)
    })
}

/// Servo ticks of the compensated trajectory (1 kHz: 50 ms).
pub const TICKS: usize = 50;
/// Centre of the trajectory, deg (away from the wrist singularity at q5 = 0).
pub const Q_MID_DEG: [f64; N] = [20.0, -70.0, 20.0, 30.0, 45.0, -30.0];

/// The controller's nominal inverse-kinematics solution at servo tick `k` (rad): a small
/// joint-space sweep, ±1.5° on every joint with its own phase.
pub fn nominal_joints<T: Real>(k: usize) -> [T; N] {
    let t = k as f64 / TICKS as f64;
    core::array::from_fn(|j| {
        let phase = j as f64 * 0.7;
        let deg = Q_MID_DEG[j]
            + 1.5 * kinecal::num::trig::sincos_f64(core::f64::consts::TAU * t + phase).0;
        T::of(deg.to_radians())
    })
}

/// Compensation settings of the servo loop: library defaults.
pub fn compensation<T: Real>() -> kinecal::compensate::Config<T> {
    kinecal::compensate::Config::default()
}
