//! What `kinecal simulate` asks for, checked against the command line's limits, and the
//! simulation it runs in memory: the true robot made from a robot file and its measurements
//! (random poses, or single-joint sweeps for `kinecal frames`). The command line writes them;
//! the Python package returns them.

use super::{EffectArg, GeomErrors, Simulation};
use crate::formats::measurements::Dataset;
use crate::formats::robot_file::{RobotFile, AXIS_TILT};
use crate::HostRobot;
use crate::Tell;

/// The options of a simulation (`kinecal simulate`'s flags).
#[derive(Clone, Debug, PartialEq)]
pub struct Request {
    /// Number of random poses.
    pub poses: usize,
    /// Measurement noise, standard deviation per axis (mm).
    pub noise_mm: f64,
    pub seed: u64,
    /// Uniform geometric errors of the true robot ([`GeomErrors::default`]).
    pub geom_errors: bool,
    /// Joint corrections of the true robot, `KIND:JOINT:V1[,V2…][:ORDER]` ([`EffectArg`]).
    pub effects: Vec<String>,
    /// The arm warms (or cools) linearly from the first to the second temperature (°C).
    pub temperature: Option<(f64, f64)>,
    /// The poses are taken evenly over this many seconds: each row gets a `t_s`.
    pub session_s: Option<f64>,
    /// Instead of random poses, single-joint sweeps of these joints (1-based).
    pub sweeps: Vec<usize>,
    pub sweep_points: usize,
    pub sweep_span_deg: f64,
    /// Joint readings (degrees) the sweeps start from (empty: a bent pose).
    pub rest: Vec<f64>,
}

impl Default for Request {
    /// The command line's defaults: 100 random poses of the nominal robot, no noise, seed 1;
    /// sweeps of 24 points over 360°.
    fn default() -> Self {
        Self {
            poses: 100,
            noise_mm: 0.0,
            seed: 1,
            geom_errors: false,
            effects: Vec::new(),
            temperature: None,
            session_s: None,
            sweeps: Vec::new(),
            sweep_points: 24,
            sweep_span_deg: 360.0,
            rest: Vec::new(),
        }
    }
}

impl Request {
    /// The effects parsed; refuses (exit 2) numbers outside the command line's limits, an
    /// effect that does not parse, and an effect on a joint a `joints`-joint robot lacks.
    pub fn checked(&self, joints: usize) -> anyhow::Result<Vec<EffectArg>> {
        crate::check_number("--noise-mm", self.noise_mm, 0.0, crate::MAX_NOISE_MM)?;
        crate::check_count("--poses", self.poses, 1, crate::MAX_SIMULATED_POSES)?;
        if !self.sweeps.is_empty() {
            crate::check_count(
                "--sweep-points",
                self.sweep_points,
                2,
                crate::MAX_SWEEP_POINTS,
            )?;
            crate::check_positive("--sweep-span-deg", self.sweep_span_deg, 3600.0)?;
            if self.sweeps.len() > 64 {
                crate::refuse!("--sweeps: at most 64 sweeps, got {}", self.sweeps.len());
            }
            for &j in &self.sweeps {
                crate::check_count("--sweep", j, 1, joints)?;
            }
            for &q in &self.rest {
                crate::check_number(
                    "--rest",
                    q,
                    -crate::MAX_JOINT_READING_DEG,
                    crate::MAX_JOINT_READING_DEG,
                )?;
            }
        }
        let effects = self
            .effects
            .iter()
            .map(|s| s.parse::<EffectArg>().map_err(crate::refused))
            .collect::<anyhow::Result<Vec<_>>>()?;
        for e in &effects {
            if e.joint >= joints {
                crate::refuse!(
                    "--effect {}:{}: the robot has {} joints",
                    e.kind,
                    e.joint + 1,
                    joints
                );
            }
        }
        Ok(effects)
    }
}

/// A simulation done: the true robot (as a model and as a robot file), its measurements and
/// the effects it was given.
#[derive(Clone, Debug)]
pub struct Simulated<const N: usize> {
    pub truth: HostRobot<N>,
    /// What `--truth` writes: the true model with the robot file's name and tool orientation,
    /// its tilts (the file's and `axis-tilt` effects') stated.
    pub truth_file: RobotFile,
    /// The measurements, in mm and degrees (what `--out` writes).
    pub data: Dataset<N>,
    pub effects: Vec<EffectArg>,
}

/// Simulates `req` for the robot file `file` (named `robot_origin` in the note that a file
/// without `[base]` is simulated at the measurement frame's origin, told to `tell`) and its
/// model `nominal`.
pub fn simulate_request<const N: usize>(
    file: &RobotFile,
    nominal: &HostRobot<N>,
    req: &Request,
    robot_origin: &str,
    tell: &mut dyn Tell,
) -> anyhow::Result<Simulated<N>> {
    let effects = req.checked(N)?;
    if !file.base_known() {
        tell.line(&format!(
            "kinecal simulate: {robot_origin} has no [base]: simulating with the robot base at the measurement frame's origin (identity)"
        ));
    }
    let sim = Simulation {
        poses: req.poses,
        noise_mm: req.noise_mm,
        seed: req.seed,
        geom_errors: req.geom_errors.then(GeomErrors::default),
        effects: effects.clone(),
    };
    let (truth, mut data) = super::simulate_session(nominal, &sim, req.temperature, req.session_s)?;
    if !req.sweeps.is_empty() {
        if req.temperature.is_some() {
            crate::refuse!("--temperature applies to random poses, not to --sweeps");
        }
        if req.session_s.is_some() {
            crate::refuse!("--session-s applies to random poses, not to --sweeps");
        }
        let rest: [f64; N] = if req.rest.is_empty() {
            super::sweeps::default_rest(&truth)
        } else {
            req.rest.as_slice().try_into().map_err(|_| {
                crate::refused(format!(
                    "--rest needs {N} joint readings, got {}",
                    req.rest.len()
                ))
            })?
        };
        data = super::sweeps::sweep_data(
            &truth,
            &rest,
            &req.sweeps,
            req.sweep_points,
            req.sweep_span_deg,
            req.noise_mm,
            req.seed,
        )?;
    }
    let mut tilt = file.tilt_joints();
    tilt.extend(
        effects
            .iter()
            .filter(|e| e.kind == AXIS_TILT)
            .map(|e| e.joint),
    );
    let names = file.tool_names();
    if names.len() > 1 {
        if !req.sweeps.is_empty() {
            crate::refuse!(
                "--sweeps follow one point: give a robot file with one [tool] (or one [[tools]] \
                 entry), not {} reflectors",
                names.len()
            );
        }
        data = super::reflectors::named_points(&truth, &data, &names, req.noise_mm, req.seed)?;
    }
    let mut truth_file =
        RobotFile::from_robot(&file.name, &truth, true, &tilt).with_tool_names(&names);
    truth_file.tool.rpy_deg = file.tool.rpy_deg;
    Ok(Simulated {
        truth,
        truth_file,
        data,
        effects,
    })
}

/// `--temperature A:B`: two temperatures in °C.
pub fn parse_temperature(s: &str) -> Result<(f64, f64), String> {
    let bad = || format!("`--temperature {s}`: expected A:B, two temperatures in °C (e.g. 15:35)");
    let (a, b) = s.split_once(':').ok_or_else(bad)?;
    let t = |x: &str| {
        x.trim()
            .parse::<f64>()
            .ok()
            .filter(|v| v.is_finite() && v.abs() <= 1e3)
    };
    Ok((t(a).ok_or_else(bad)?, t(b).ok_or_else(bad)?))
}
