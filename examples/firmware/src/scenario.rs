//! The calibration scenario both builds share: the host generator (f64) and the firmware (f32)
//! must agree on the robot, the parameter set and the solver settings, or the firmware's
//! comparisons against host-computed values would compare different problems.

use kinecal::identify::bpnn::{Bpnn, BpnnConfig};
use kinecal::identify::lm::LmConfig;
use kinecal::identify::pso::PsoConfig;
use kinecal::model::param::{Param, ParamSet};
use kinecal::{Frame, Joint, Measurement, Real, Robot};
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
/// `q3 = J3 + J2` (a `[[couplings]]` table, docs/formats.md).
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

/// A re-mastering (a motor swap moves the zero of joints 2 and 3): the firmware re-identifies
/// only [`remaster_params`] from the first [`REMASTER_POSES`] identification poses, starting
/// from the true rows with theta2 and theta3 off by [`REMASTER_DEG`] each (the controller's
/// model from before the re-mastering), and must find the true rows again.
pub const REMASTER_POSES: usize = 10;
pub const REMASTER_DEG: f64 = 0.2;
/// Largest error (rad) the firmware accepts in the re-identified theta2 and theta3 (the
/// re-mastering moved them 3,491 µrad): 10 poses of 10 µm tracker noise leave about 2 µrad,
/// which the host generator (src/generate.rs) asserts, in `f64`, is at most half of this.
pub const REMASTER_TOLERANCE_RAD: f64 = 1e-5;

/// The re-mastering's parameters: theta2 and theta3, in a set of the solver's capacity.
pub fn remaster_params() -> ParamSet<P> {
    let mut s = ParamSet::new();
    if s.push(Param::Theta(1)).is_err() || s.push(Param::Theta(2)).is_err() {
        unreachable!("2 parameters fit a set of 24");
    }
    s
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

/// the tool as a 6-DoF probe with two further reflectors. Reflectors 2 and 3 in the
/// flange frame, mm (reflector 1 is [`TOOL_MM`]).
pub const TOOL_POINTS_MM: [[f64; 3]; 2] = [[-60.0, 30.0, 110.0], [10.0, -70.0, 100.0]];
/// Orientation of the probe's frame in the flange frame (roll, pitch, yaw), deg.
pub const TOOL_AXES_RPY_DEG: [f64; 3] = [0.0, 0.0, 30.0];
/// Poses of the 6-D run: the first identification poses' joint readings.
pub const POSE6D_POSES: usize = 8;
/// Reflector observations (reflectors 2 and 3, alternately) at the first poses: a reflector is
/// not seen in every pose. The 6-D run's observations fill the held-out poses' storage.
pub const POINT_OBS: usize = 12;
/// Weights of the tracker's coordinates (1/σ relative to x, y: z is twice as uncertain) and of
/// the orientation residual (mm per rad: 1 mrad weighs as 0.5 mm).
pub const WEIGHT: [f64; 3] = [1.0, 1.0, 0.5];
pub const ORIENTATION_WEIGHT: f64 = 500.0;

/// The nominal arm with the probe: three reflectors and the probe frame's axes.
#[inline(never)]
pub fn nominal_probe<T: Real>() -> Robot<T, N> {
    let mut r = nominal::<T>();
    let v = |p: [f64; 3]| Vector3::new(T::of(p[0]), T::of(p[1]), T::of(p[2]));
    let rpy = TOOL_AXES_RPY_DEG.map(|d| T::of(d.to_radians()));
    let ok = r.set_tool_point(1, v(TOOL_POINTS_MM[0])).is_ok()
        && r.set_tool_point(2, v(TOOL_POINTS_MM[1])).is_ok()
        && r.set_tool_axes(Frame::from_xyz_rpy([T::zero(); 3], rpy))
            .is_ok();
    if !ok {
        unreachable!("finite points within bounds, a rotation");
    }
    r
}

/// The 6-D run's 24 parameters: the probe (orientation, the three reflectors) and the wrist's
/// rows (joints 3, 4, 5; joint 6's theta and d would repeat the probe's pose).
pub fn pose6d_params() -> ParamSet<P> {
    let mut s = ParamSet::new();
    let tool = [
        Param::ToolRx,
        Param::ToolRy,
        Param::ToolRz,
        Param::ToolX,
        Param::ToolY,
        Param::ToolZ,
    ];
    let points = (1..3u8).flat_map(|k| (0..3u8).map(move |a| Param::ToolPoint(k, a)));
    let rows = (2..5u8).flat_map(|i| [Param::Alpha(i), Param::A(i), Param::Theta(i), Param::D(i)]);
    for p in tool.into_iter().chain(points).chain(rows) {
        if s.push(p).is_err() {
            unreachable!("24 parameters fit a set of 24");
        }
    }
    s
}

/// The known error the 6-D run must find, in the order of [`pose6d_params`] (rad, mm): the
/// probe's frame off by tenths of a degree, its reflectors by up to 1.2 mm, the wrist rows by
/// 0.05° and 0.3 mm.
#[rustfmt::skip]
pub const POSE6D_DELTA: [f64; P] = {
    const D: f64 = core::f64::consts::PI / 180.0;
    [
        0.3 * D, -0.2 * D, 0.5 * D,           // probe axes (tool.rx/ry/rz)
        0.8, -0.5, 1.2,                       // reflector 1 (tool.x/y/z)
        -0.6, 0.4, 0.9,                       // reflector 2 (tool2.*)
        0.7, 0.3, -0.8,                       // reflector 3 (tool3.*)
        0.05 * D, 0.3, -0.05 * D, 0.2,        // joint 3: alpha, a, theta, d
        -0.04 * D, -0.25, 0.06 * D, -0.3,     // joint 4
        0.05 * D, 0.2, -0.03 * D, 0.25,       // joint 5
    ]
};

/// The probe robot with [`POSE6D_DELTA`] applied: the truth the 6-D observations come from.
pub fn probe_truth<T: Real>() -> Robot<T, N> {
    let mut r = nominal_probe::<T>();
    let d = POSE6D_DELTA.map(T::of);
    match kinecal::model::param::apply_delta(&mut r, &pose6d_params(), &d) {
        Ok(()) => r,
        Err(_) => unreachable!("small finite deltas"),
    }
}

/// The 6-D run's observations of `truth` at the joint readings `q` (noise-free, weighted):
/// first a 6-D observation of reflector 1 with the probe's orientation at each of
/// [`POSE6D_POSES`] poses, then [`POINT_OBS`] position observations of reflectors 2 and 3.
pub fn pose6d_observations<T: Real>(
    truth: &Robot<T, N>,
    q: impl Fn(usize) -> [T; N],
    mut push: impl FnMut(Measurement<T, N>),
) {
    let mut fk = kinecal::ForwardKinematics::<T, N>::new();
    let weight = Vector3::new(T::of(WEIGHT[0]), T::of(WEIGHT[1]), T::of(WEIGHT[2]));
    for i in 0..POSE6D_POSES {
        let qi = q(i);
        let p = fk.compute(truth, &qi);
        let mut m = Measurement::new(qi, p);
        m.weight = weight;
        m.orientation = Some(fk.tool_pose(truth));
        m.orientation_weight = T::of(ORIENTATION_WEIGHT);
        push(m);
    }
    for i in 0..POINT_OBS {
        let (qi, k) = (q(i / 2), 1 + i % 2);
        let Some(p) = fk.compute_point(truth, &qi, k) else {
            unreachable!("the truth has three reflectors");
        };
        let mut m = Measurement::new(qi, p);
        m.tool = k as u8;
        m.weight = weight;
        push(m);
    }
}

/// Stage 3d, calibration without a tracker: the arm touches [`SOCKETS`] fixed sockets (unknown
/// points) [`SOCKET_ROWS`] times each, from as many wrist orientations. The joint readings are
/// the host's (src/generate.rs: the true robot's tool point at the socket, found by Newton
/// steps from the first identification poses with the wrist turned, each contact off the
/// socket by noise of [`SOCKET_SIGMA_MM`]); the
/// firmware calibrates [`params`] from the nominal model in idle slices and must reach the
/// host's `f64` values, holding what sockets cannot see (the base's share of the first row,
/// and one length: the scale).
pub const SOCKETS: usize = 4;
pub const SOCKET_ROWS: usize = 8;
/// The contact's uncertainty, mm (every row alike).
pub const SOCKET_SIGMA_MM: f64 = 0.01;

/// The socket session's groups: socket `k` is rows `k·SOCKET_ROWS..(k+1)·SOCKET_ROWS`.
pub fn socket_groups<T: Real>() -> [kinecal::io::constraint::ConstraintGroup<T>; SOCKETS] {
    core::array::from_fn(|k| kinecal::io::constraint::ConstraintGroup {
        kind: kinecal::io::constraint::ConstraintKind::Socket,
        first: (k * SOCKET_ROWS) as u32,
        len: SOCKET_ROWS as u32,
    })
}
