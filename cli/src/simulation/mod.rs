//! Simulated measurements: random configurations, a "true" robot made from a nominal one by
//! geometric errors and joint corrections, and tracker readings with Gaussian noise.
//!
//! Used by `kinecal simulate` and by every command or test that needs data with a known truth
//! (identify, diagnose, compensate, plan's Monte Carlo). Deterministic for a seed: the seed
//! gives three independent Xoshiro streams (configurations, errors, noise), so switching
//! `--geom-errors` or the noise level does not change the poses.

pub mod reflectors;
pub mod request;
pub mod sweeps;

use crate::formats::measurements::{quantize_deg, Dataset, Record};
use crate::HostRobot;
use anyhow::{anyhow, bail};
use kinecal::forward::ForwardKinematics;
use kinecal::model::effects::EffectKind;
use kinecal::{Joint, Measurement, Robot};
use nalgebra::Vector3;
use rand::{Rng, RngExt, SeedableRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::str::FromStr;

/// The three random streams of a seed.
#[derive(Clone, Debug)]
pub struct Streams {
    /// Joint configurations.
    pub configs: Xoshiro256PlusPlus,
    /// Geometric errors of the true robot.
    pub errors: Xoshiro256PlusPlus,
    /// Measurement noise.
    pub noise: Xoshiro256PlusPlus,
}

impl Streams {
    /// Non-overlapping streams of one seed (Xoshiro jumps of 2^128 draws).
    pub fn new(seed: u64) -> Self {
        let configs = Xoshiro256PlusPlus::seed_from_u64(seed);
        let mut errors = configs.clone();
        errors.jump();
        let mut noise = errors.clone();
        noise.jump();
        Self {
            configs,
            errors,
            noise,
        }
    }
}

/// Size of the uniform geometric errors of `--geom-errors` (the values by default).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeomErrors {
    /// alpha and theta: ±this many degrees.
    pub angle_deg: f64,
    /// a and d: ±this many millimetres.
    pub length_mm: f64,
    /// Each tool coordinate: ±this many millimetres.
    pub tool_mm: f64,
}

impl Default for GeomErrors {
    fn default() -> Self {
        Self {
            angle_deg: 0.1,
            length_mm: 0.8,
            tool_mm: 0.5,
        }
    }
}

/// Random configurations (rad), uniform within each joint's limits. Each reading is a whole
/// number of 1e-6° (what the CSV writer keeps), so data written and read back reproduce the
/// model exactly.
pub fn random_configurations<const N: usize, V: kinecal::ValueStorage, R: Rng>(
    robot: &Robot<f64, N, V>,
    n: usize,
    rng: &mut R,
) -> Vec<[f64; N]> {
    let q = 10f64.powi(crate::formats::measurements::Q_DECIMALS as i32);
    (0..n)
        .map(|_| {
            std::array::from_fn(|i| {
                let j = &robot.joints()[i];
                let (lo, hi) = (j.lower.to_degrees(), j.upper.to_degrees());
                let (qlo, qhi) = ((lo * q).ceil() / q, (hi * q).floor() / q);
                let v: f64 = rng.random_range(lo..=hi);
                quantize_deg(v)
                    .clamp(qlo.min(qhi), qhi.max(qlo))
                    .to_radians()
            })
        })
        .collect()
}

/// A copy of `robot` with uniform errors on alpha, theta (±angle), a, d (±length) of every
/// joint and on the tool point (±tool). Base, tilt and effects are kept.
pub fn perturb_geometry<const N: usize, V: kinecal::ValueStorage, R: Rng>(
    robot: &Robot<f64, N, V>,
    e: &GeomErrors,
    rng: &mut R,
) -> Robot<f64, N, V> {
    let mut out = robot.clone();
    let mut u = |w: f64| {
        if w > 0.0 {
            rng.random_range(-w..=w)
        } else {
            0.0
        }
    };
    let ang = e.angle_deg.to_radians();
    for i in 0..N {
        let j = robot.joints()[i];
        let nj = Joint {
            alpha: j.alpha + u(ang),
            a: j.a + u(e.length_mm),
            theta: j.theta + u(ang),
            d: j.d + u(e.length_mm),
            ..j
        };
        // Finite inputs plus bounded errors stay finite.
        let _ = out.set_joint(i, nj);
    }
    let t = robot.tool();
    let _ = out.set_tool(Vector3::new(
        t.x + u(e.tool_mm),
        t.y + u(e.tool_mm),
        t.z + u(e.tool_mm),
    ));
    // Further reflectors (`[[tools]]`) alike, drawn after the first: a robot with one tool
    // point gets the errors it always got.
    for k in 1..robot.tool_point_count() {
        if let Some(t) = robot.tool_point(k) {
            let p = Vector3::new(t.x + u(e.tool_mm), t.y + u(e.tool_mm), t.z + u(e.tool_mm));
            let _ = out.set_tool_point(k, p);
        }
    }
    out
}

/// One `--effect KIND:JOINT:V1[,V2…][:ORDER]` (joint 1-based on the command line, 0-based here).
#[derive(Clone, Debug, PartialEq)]
pub struct EffectArg {
    /// An effect id of docs/formats.md "Effects", `axis-tilt` included.
    pub kind: String,
    pub joint: usize,
    pub values: Vec<f64>,
    /// Harmonic order for `joint-cyclic` (1 if not given).
    pub order: u16,
    /// `joint-table` only: the knot grid `(start, step)` in rad, knot k at `start + k · step`
    /// (e.g. a gear table every 10° aligned to 0°). `None`: the knots spread evenly over the
    /// joint's limits, lowest limit first (what `--effect` gives).
    pub grid: Option<(f64, f64)>,
}

impl FromStr for EffectArg {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let parts: Vec<&str> = s.split(':').collect();
        if parts.len() < 3 || parts.len() > 4 {
            return Err(format!(
                "`--effect {s}`: expected KIND:JOINT:V1[,V2…][:ORDER]"
            ));
        }
        let kind = parts[0].trim();
        if EffectKind::from_id(kind).is_none() && kind != crate::formats::robot_file::AXIS_TILT {
            return Err(format!(
                "`--effect {s}`: unknown kind `{kind}` (joint-scale, joint-cyclic, joint-compliance, joint-table, axis-tilt, thermal-expansion, base-drift)"
            ));
        }
        let joint: usize = parts[1]
            .trim()
            .parse()
            .map_err(|_| format!("`--effect {s}`: joint `{}` is not a number", parts[1]))?;
        let thermal = kind == crate::formats::robot_file::THERMAL;
        if thermal && (joint != 0 || parts.len() != 3) {
            return Err(format!(
                "`--effect {s}`: thermal-expansion acts on no joint: thermal-expansion:0:C (C per kelvin)"
            ));
        }
        let drift = kind == EffectKind::Drift.id();
        if drift && (joint != 0 || parts.len() != 3) {
            return Err(format!(
                "`--effect {s}`: base-drift acts on no joint: base-drift:0:VX,VY,VZ (mm per second, with --session-s)"
            ));
        }
        let thermal = thermal || drift;
        if joint == 0 && !thermal {
            return Err(format!("`--effect {s}`: joints are numbered from 1"));
        }
        let values = parts[2]
            .split(',')
            .map(|v| v.trim().parse::<f64>().ok().filter(|x| x.is_finite()))
            .collect::<Option<Vec<f64>>>()
            .ok_or_else(|| {
                format!(
                    "`--effect {s}`: values `{}` must be finite numbers separated by commas",
                    parts[2]
                )
            })?;
        let order = match parts.get(3) {
            Some(o) => {
                if kind != "joint-cyclic" {
                    return Err(format!(
                        "`--effect {s}`: an order applies to joint-cyclic only"
                    ));
                }
                o.trim()
                    .parse::<u16>()
                    .ok()
                    .filter(|n| *n >= 1)
                    .ok_or_else(|| format!("`--effect {s}`: order `{o}` must be an integer ≥ 1"))?
            }
            None => 1,
        };
        if let Some(v) = values.iter().find(|v| v.abs() > crate::MAX_EFFECT_VALUE) {
            return Err(format!(
                "`--effect {s}`: value {v} is implausible (effect values are at most {} in magnitude: a scale, radians, or radians per metre)",
                crate::MAX_EFFECT_VALUE
            ));
        }
        if values.len() > crate::MAX_TABLE_KNOTS {
            return Err(format!(
                "`--effect {s}`: at most {} knot values",
                crate::MAX_TABLE_KNOTS
            ));
        }
        if order > crate::MAX_CYCLIC_ORDER {
            return Err(format!(
                "`--effect {s}`: the order must be at most {}",
                crate::MAX_CYCLIC_ORDER
            ));
        }
        let want = match kind {
            "joint-scale" | "joint-compliance" | "axis-tilt" | "thermal-expansion" => {
                values.len() == 1
            }
            "joint-cyclic" => values.len() == 2,
            "base-drift" => values.len() == 3,
            _ => values.len() >= 2,
        };
        if !want {
            return Err(format!(
                "`--effect {s}`: wrong number of values (scale, compliance, axis-tilt: 1; cyclic: a,b; base-drift: vx,vy,vz; table: ≥ 2 knots)"
            ));
        }
        Ok(EffectArg {
            kind: kind.to_string(),
            joint: joint.saturating_sub(1),
            values,
            order,
            grid: None,
        })
    }
}

/// Adds a correction to `robot`. Units: joint-scale dimensionless; joint-cyclic a, b in rad;
/// joint-compliance rad per metre of lever arm; axis-tilt sets the joint's beta (rad);
/// joint-table values are knot corrections (rad), lowest knot first, on `e.grid` when given and
/// otherwise spread evenly over the joint's range from the lowest limit.
pub fn add_effect<const N: usize, V: kinecal::ValueStorage>(
    robot: &mut Robot<f64, N, V>,
    e: &EffectArg,
) -> anyhow::Result<()> {
    let Some(j) = robot.joint(e.joint).copied() else {
        crate::refuse!(
            "effect {} on joint {}: the robot has {N} joints",
            e.kind,
            e.joint + 1
        );
    };
    if e.grid.is_some() && e.kind != "joint-table" {
        bail!(
            "effect {} on joint {}: a knot grid applies to joint-table only",
            e.kind,
            e.joint + 1
        );
    }
    if e.kind == crate::formats::robot_file::AXIS_TILT {
        let beta = e.values.first().copied().unwrap_or(0.0);
        return robot
            .set_joint(e.joint, Joint { beta, ..j })
            .map_err(|err| anyhow!("axis-tilt on joint {}: {err:?}", e.joint + 1));
    }
    let kind =
        EffectKind::from_id(&e.kind).ok_or_else(|| anyhow!("unknown effect kind `{}`", e.kind))?;
    let (start, step) = match (kind, e.grid) {
        (EffectKind::Table, Some((start, step))) => {
            if !(start.is_finite() && step.is_finite() && step > 0.0) {
                bail!(
                    "joint-table on joint {}: the knot grid needs a finite start and a step > 0, got start {start} rad, step {step} rad",
                    e.joint + 1
                );
            }
            (start, step)
        }
        (EffectKind::Table, None) => (
            j.lower,
            (j.upper - j.lower) / (e.values.len().max(2) - 1) as f64,
        ),
        _ => (0.0, 0.0),
    };
    robot
        .effects_mut()
        .push(kind, e.joint, N, e.order, start, step, &e.values)
        .map(|_| ())
        .map_err(|err| anyhow!("effect {} on joint {}: {err:?}", e.kind, e.joint + 1))
}

/// Measured points of `robot` at `configs` (rad) with Gaussian noise of `sigma_mm` per axis.
pub fn measure<const N: usize, V: kinecal::ValueStorage, R: Rng>(
    robot: &Robot<f64, N, V>,
    configs: &[[f64; N]],
    sigma_mm: f64,
    rng: &mut R,
) -> Vec<Vector3<f64>> {
    measure_at(robot, configs, &[], sigma_mm, rng)
}

/// [`measure`] with the arm at temperature `temps[i]` (°C) for pose `i` (none beyond the
/// slice): what a model's thermal-expansion term is evaluated at.
pub fn measure_at<const N: usize, V: kinecal::ValueStorage, R: Rng>(
    robot: &Robot<f64, N, V>,
    configs: &[[f64; N]],
    temps: &[f64],
    sigma_mm: f64,
    rng: &mut R,
) -> Vec<Vector3<f64>> {
    measure_when(robot, configs, (temps, &[]), sigma_mm, rng)
}

/// [`measure_at`] with the time `when.1[i]` (s) of pose `i` too (none beyond the slice): what
/// a model's base-drift term is evaluated at.
pub fn measure_when<const N: usize, V: kinecal::ValueStorage, R: Rng>(
    robot: &Robot<f64, N, V>,
    configs: &[[f64; N]],
    when: (&[f64], &[f64]),
    sigma_mm: f64,
    rng: &mut R,
) -> Vec<Vector3<f64>> {
    let (temps, times) = when;
    let mut fk = ForwardKinematics::<f64, N>::new();
    configs
        .iter()
        .enumerate()
        .map(|(i, q)| {
            fk.temp_c = temps.get(i).copied();
            fk.time_s = times.get(i).copied();
            let p = fk.compute(robot, q);
            if sigma_mm > 0.0 {
                let n: [f64; 3] = std::array::from_fn(|_| rng.sample::<f64, _>(StandardNormal));
                p + Vector3::from(n) * sigma_mm
            } else {
                p
            }
        })
        .collect()
}

/// A robot with default geometric errors ([`GeomErrors::default`]) made from `nominal`, and `n`
/// measurements of it at random configurations with Gaussian noise of `sigma_mm` per axis:
/// `(truth, measurements)`.
pub fn perturbed_measurements<const N: usize, V: kinecal::ValueStorage, R: Rng>(
    nominal: &Robot<f64, N, V>,
    n: usize,
    sigma_mm: f64,
    rng: &mut R,
) -> (Robot<f64, N, V>, Vec<Measurement<f64, N>>) {
    let truth = perturb_geometry(nominal, &GeomErrors::default(), rng);
    let configs = random_configurations(nominal, n, rng);
    let points = measure(&truth, &configs, sigma_mm, rng);
    let data = configs
        .iter()
        .zip(points)
        .map(|(q, point)| Measurement::new(*q, point))
        .collect();
    (truth, data)
}

/// A dataset in file units from configurations (rad) and points (mm).
pub fn dataset<const N: usize>(configs: &[[f64; N]], points: &[Vector3<f64>]) -> Dataset<N> {
    let records = configs
        .iter()
        .zip(points)
        .map(|(q, p)| Record::new(q.map(|x| quantize_deg(x.to_degrees())), [p.x, p.y, p.z]))
        .collect();
    Dataset {
        records,
        extra_names: Vec::new(),
    }
}

/// Everything `kinecal simulate` varies.
#[derive(Clone, Debug, PartialEq)]
pub struct Simulation {
    pub poses: usize,
    pub noise_mm: f64,
    pub seed: u64,
    /// Geometric errors of the true robot (`None` = the true geometry is the nominal one).
    pub geom_errors: Option<GeomErrors>,
    /// Corrections added to the true robot after the geometric errors.
    pub effects: Vec<EffectArg>,
}

/// The true robot and its measurements. The true robot is `nominal` with the geometric
/// errors and then the effects applied; the configurations are drawn within its limits.
pub fn simulate<const N: usize>(
    nominal: &HostRobot<N>,
    sim: &Simulation,
) -> anyhow::Result<(HostRobot<N>, Dataset<N>)> {
    simulate_at(nominal, sim, None)
}

/// The temperatures (°C) of `count` rows of an arm warming (or cooling) linearly from
/// `temperature.0` to `temperature.1`, each as a sensor reports it, to 0.01 °C (the file and
/// the truth then agree exactly).
pub fn warm_up(temperature: (f64, f64), count: usize) -> anyhow::Result<Vec<f64>> {
    let (a, b) = temperature;
    if !(a.is_finite() && b.is_finite() && a.abs() <= 1e3 && b.abs() <= 1e3) {
        bail!("the temperatures must be finite numbers of °C, got {a} and {b}");
    }
    let n = count.max(2) - 1;
    Ok((0..count)
        .map(|i| ((a + (b - a) * i as f64 / n as f64) * 100.0).round() / 100.0)
        .collect())
}

/// [`simulate`] with the arm warming (or cooling) linearly from `temperature.0` to
/// `temperature.1` °C over the poses, in their order: every row gets a `temp_c`, and a
/// thermal-expansion effect of the true robot is referred to the mean temperature.
pub fn simulate_at<const N: usize>(
    nominal: &HostRobot<N>,
    sim: &Simulation,
    temperature: Option<(f64, f64)>,
) -> anyhow::Result<(HostRobot<N>, Dataset<N>)> {
    simulate_session(nominal, sim, temperature, None)
}

/// The times (s) of `count` poses taken evenly over `session_s` seconds from 0, rounded to
/// the millisecond as a tracker's clock writes them.
pub fn session_times(session_s: f64, count: usize) -> anyhow::Result<Vec<f64>> {
    if !(session_s.is_finite() && session_s > 0.0 && session_s <= 1e7) {
        crate::refuse!(
            "--session-s: the session must last a finite number of seconds above 0 and at most 1e7, got {session_s}"
        );
    }
    let n = count.max(2) - 1;
    Ok((0..count)
        .map(|i| (session_s * i as f64 / n as f64 * 1e3).round() / 1e3)
        .collect())
}

/// [`simulate_at`] with the poses taken evenly over `session_s` seconds, in their order: every
/// row gets a `t_s` (from 0), and a base-drift effect of the true robot (the tracker drifting)
/// is referred to the mean time.
pub fn simulate_session<const N: usize>(
    nominal: &HostRobot<N>,
    sim: &Simulation,
    temperature: Option<(f64, f64)>,
    session_s: Option<f64>,
) -> anyhow::Result<(HostRobot<N>, Dataset<N>)> {
    let temps = match temperature {
        Some(t) => warm_up(t, sim.poses)?,
        None => Vec::new(),
    };
    let times = match session_s {
        Some(d) => session_times(d, sim.poses)?,
        None => Vec::new(),
    };
    if !(sim.noise_mm.is_finite() && sim.noise_mm >= 0.0) {
        bail!(
            "the noise level must be a finite number ≥ 0, got {}",
            sim.noise_mm
        );
    }
    let mut rng = Streams::new(sim.seed);
    let mut truth = match &sim.geom_errors {
        Some(e) => perturb_geometry(nominal, e, &mut rng.errors),
        None => nominal.clone(),
    };
    for e in &sim.effects {
        if e.kind == crate::formats::robot_file::THERMAL {
            let reference = if temps.is_empty() {
                crate::formats::robot_file::DEFAULT_REFERENCE_C
            } else {
                temps.iter().sum::<f64>() / temps.len() as f64
            };
            truth
                .effects_mut()
                .push(EffectKind::Thermal, 0, N, 1, reference, 0.0, &e.values)
                .map_err(|err| anyhow!("effect thermal-expansion: {err:?}"))?;
            continue;
        }
        if e.kind == EffectKind::Drift.id() {
            if times.is_empty() {
                crate::refuse!(
                    "--effect base-drift needs --session-s: the rows' times the drift grows with"
                );
            }
            let reference = times.iter().sum::<f64>() / times.len() as f64;
            truth
                .effects_mut()
                .push(EffectKind::Drift, 0, N, 1, reference, 0.0, &e.values)
                .map_err(|err| {
                    anyhow!(
                        "effect base-drift (mm per second, each below {}): {err:?}",
                        kinecal::model::effects::MAX_DRIFT_SPEED
                    )
                })?;
            continue;
        }
        add_effect(&mut truth, e)?;
    }
    let configs = random_configurations(&truth, sim.poses, &mut rng.configs);
    let points = measure_when(
        &truth,
        &configs,
        (&temps, &times),
        sim.noise_mm,
        &mut rng.noise,
    );
    let mut ds = dataset(&configs, &points);
    if !temps.is_empty() {
        ds.extra_names
            .push(crate::formats::measurements::TEMPERATURE_COLUMN.to_string());
        for (r, t) in ds.records.iter_mut().zip(&temps) {
            r.extra.push(*t);
        }
    }
    if !times.is_empty() {
        ds.extra_names
            .push(crate::formats::measurements::TIME_COLUMN.to_string());
        for (r, t) in ds.records.iter_mut().zip(&times) {
            r.extra.push(*t);
        }
    }
    Ok((truth, ds))
}

/// The ER20-C10 stand-in (rows alpha°, a mm, theta°, d mm; tool 100 mm along the flange z).
pub fn er20_c10() -> HostRobot<6> {
    let rows = [
        (0.0, 0.0, 0.0, 504.0),
        (-90.0, 170.0, -90.0, 0.0),
        (0.0, 780.0, 0.0, 0.0),
        (-90.0, 140.0, 0.0, 760.0),
        (90.0, 0.0, 0.0, 0.0),
        (-90.0, 0.0, 0.0, 125.0),
    ];
    let mut joints = rows.map(|(al, a, th, d)| kinecal::Joint::mdh_deg(al, a, th, d));
    for j in joints.iter_mut() {
        j.lower = (-170f64).to_radians();
        j.upper = 170f64.to_radians();
    }
    // Cannot fail: finite constants.
    kinecal::Robot::new(
        kinecal::Frame::identity(),
        joints,
        nalgebra::Vector3::new(0.0, 0.0, 100.0),
    )
    .expect("built-in robot")
}
