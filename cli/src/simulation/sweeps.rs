//! Simulated single-joint sweeps for the circle-point method (`kinecal simulate --sweeps`,
//! `kinecal frames`): one joint turns through a span around a rest configuration while the
//! others stay at rest, the tracker reads the point with Gaussian noise, and each row carries
//! the swept joint's number in the extra column [`SWEEP_COLUMN`].
//!
//! With joint couplings a sweep turns one *model* angle: sweeping the reading of a joint that
//! others are coupled from (FANUC J2, with J3 read from the horizontal) moves each coupled
//! joint's reading by `−ratio ×` the swept reading's change, so their model angles stay put and
//! the point moves on a circle about the swept axis (what `kinecal frames` needs).

use crate::formats::measurements::{quantize_deg, Dataset, Record};
use crate::simulation::{measure, Streams};
use anyhow::{bail, Result};
use kinecal::frames::circle_point::Sweep;
use kinecal::{ForwardKinematics, Robot};
use nalgebra::Vector3;

/// Name of the extra CSV column holding the swept joint (1-based).
pub const SWEEP_COLUMN: &str = "sweep";

/// Readings (degrees) of one sweep of `joint` (0-based): `points` values over `span_deg`
/// centred on the rest reading, shifted (and if need be shortened) to stay inside the joint's
/// limits (and, with couplings, inside the range where the coupled joints' compensating
/// readings stay within theirs, see [`coupled_readings`]). A span of 360° or more gives
/// `points` evenly spaced readings round the full turn (no repeated end point). Every reading
/// is quantized to what the CSV writer keeps.
pub fn sweep_readings<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    rest_deg: &[f64; N],
    joint: usize,
    points: usize,
    span_deg: f64,
) -> Result<Vec<f64>> {
    let Some(j) = robot.joint(joint) else {
        bail!("joint {} is beyond the robot's {N} joints", joint + 1)
    };
    if points < 4 {
        bail!("a sweep needs at least 4 points, got {points}");
    }
    if !(span_deg.is_finite() && span_deg > 0.0) {
        bail!("the sweep span must be a positive number of degrees, got {span_deg}");
    }
    let (mut lower, mut upper) = (j.lower.to_degrees(), j.upper.to_degrees());
    let rest = rest_deg[joint];
    // Coupled joints follow with −ratio × the change: keep their readings within limits.
    for (k, ratio) in robot.couplings().dependents(joint) {
        if ratio == 0.0 {
            continue;
        }
        let lk = &robot.joints()[k];
        let (lo_k, hi_k) = (lk.lower.to_degrees(), lk.upper.to_degrees());
        let a = rest + (rest_deg[k] - hi_k) / ratio;
        let b = rest + (rest_deg[k] - lo_k) / ratio;
        lower = lower.max(a.min(b));
        upper = upper.min(a.max(b));
    }
    if !(rest >= lower && rest <= upper) {
        bail!(
            "rest reading {rest}° of joint {} is outside its limits [{lower}°, {upper}°]",
            joint + 1
        );
    }
    let full = span_deg >= 360.0 && upper - lower >= 360.0;
    let (span, steps) = if full {
        (360.0, points as f64)
    } else {
        (span_deg.min(upper - lower), (points - 1) as f64)
    };
    let mut lo = rest - span / 2.0;
    if !full {
        lo = lo.max(lower).min(upper - span);
    } else {
        lo = lo.max(lower).min(upper - span + span / steps);
    }
    Ok((0..points)
        .map(|k| quantize_deg(lo + span * k as f64 / steps).clamp(lower, upper))
        .collect())
}

/// The readings (degrees) of a sweep row: `rest_deg` with `joint` (0-based) at `reading`, and
/// every joint coupled from `joint` moved by `−ratio × (reading − rest)` so that its model
/// angle stays at rest (quantized like every reading the CSV writer keeps).
pub fn coupled_readings<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    rest_deg: &[f64; N],
    joint: usize,
    reading: f64,
) -> [f64; N] {
    let mut c = *rest_deg;
    if joint >= N {
        return c;
    }
    c[joint] = reading;
    for (k, ratio) in robot.couplings().dependents(joint) {
        let lk = &robot.joints()[k];
        c[k] = quantize_deg(rest_deg[k] - ratio * (reading - rest_deg[joint]))
            .clamp(lk.lower.to_degrees(), lk.upper.to_degrees());
    }
    c
}

/// Distance (mm) of the measured point from joint `j`'s axis at readings `q` (rad).
pub fn radius_about<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    q: &[f64; N],
    j: usize,
) -> f64 {
    let mut fk = ForwardKinematics::<f64, N>::new();
    let p = fk.compute(robot, q);
    let Some(f) = fk.frames.get(j) else {
        return 0.0;
    };
    let d = p - f.o;
    (d - f.z * d.dot(&f.z)).norm()
}

/// A rest configuration (degrees) for sweeps: all zeros (the paper's "zero position") when the
/// point is there at least 30 % of the robot's reach from the axes of joints 1 and 2 (so both
/// circles are large), otherwise the first of a small grid over joints 2, 3 and 5 (0, ±30°,
/// ±60°, ±90°, within the limits) that is; failing that, the grid point with the largest
/// smaller radius. An arm that stands straight up at zero (a 7-axis arm, say) gets bent.
pub fn default_rest<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
) -> [f64; N] {
    let clamp = |j: usize, deg: f64| -> Option<f64> {
        let r = robot.joints().get(j)?;
        let v = deg.to_radians();
        (v >= r.lower && v <= r.upper).then_some(deg)
    };
    let mut base = [0.0; N];
    for (j, b) in base.iter_mut().enumerate() {
        let jt = &robot.joints()[j];
        *b = if clamp(j, 0.0).is_some() {
            0.0
        } else {
            quantize_deg((jt.lower + jt.upper).to_degrees() / 2.0)
        };
    }
    if N < 3 {
        return base;
    }
    let steps = [0.0, 30.0, -30.0, 60.0, -60.0, 90.0, -90.0];
    let want = 0.3 * robot.reach();
    let mut best = (f64::NEG_INFINITY, base);
    let wrist = if N >= 5 { Some(N - 2) } else { None };
    for &a in &steps {
        for &b in &steps {
            for &c in steps
                .iter()
                .take(if wrist.is_some() { steps.len() } else { 1 })
            {
                let mut rest = base;
                let (Some(a), Some(b)) = (clamp(1, a), clamp(2, b)) else {
                    continue;
                };
                rest[1] = a;
                rest[2] = b;
                if let Some(w) = wrist {
                    let Some(c) = clamp(w, c) else { continue };
                    rest[w] = c;
                }
                let q = rest.map(f64::to_radians);
                let r = radius_about(robot, &q, 0).min(radius_about(robot, &q, 1));
                if r >= want {
                    return rest;
                }
                if r > best.0 {
                    best = (r, rest);
                }
            }
        }
    }
    best.1
}

/// Sweep data of `robot` (the true robot: its base is the pose to be found).
///
/// * `rest_deg`: the joint readings every other joint keeps (degrees);
/// * `joints`: the joints to sweep, 1-based, in the order they are written (e.g. `[1, 2, 5, 6]`:
///   base from 1 and 2, tool distances from the last two);
/// * `points` per sweep, `span_deg` of each sweep (see [`sweep_readings`]);
/// * `noise_mm`: standard deviation of the tracker noise per axis; `seed`: the random seed
///   (the noise comes from the seed's noise stream of [`Streams`]).
///
/// Rows carry the swept joint in the extra column `sweep`.
pub fn sweep_data<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    rest_deg: &[f64; N],
    joints: &[usize],
    points: usize,
    span_deg: f64,
    noise_mm: f64,
    seed: u64,
) -> Result<Dataset<N>> {
    if !(noise_mm.is_finite() && noise_mm >= 0.0) {
        bail!("the noise level must be a finite number ≥ 0, got {noise_mm}");
    }
    if joints.is_empty() {
        bail!("no joints to sweep");
    }
    let rest: [f64; N] = rest_deg.map(quantize_deg);
    let mut configs: Vec<[f64; N]> = Vec::new();
    let mut labels = Vec::new();
    for &joint in joints {
        if joint == 0 || joint > N {
            bail!("cannot sweep joint {joint}: joints are numbered 1 to {N}");
        }
        for q in sweep_readings(robot, &rest, joint - 1, points, span_deg)? {
            let c = coupled_readings(robot, &rest, joint - 1, q);
            configs.push(c.map(f64::to_radians));
            labels.push(joint as f64);
        }
    }
    let mut rng = Streams::new(seed);
    let measured = measure(robot, &configs, noise_mm, &mut rng.noise);
    let records = configs
        .iter()
        .zip(measured)
        .zip(labels)
        .map(|((q, p), s)| {
            let mut r = Record::new(q.map(|x| quantize_deg(x.to_degrees())), [p.x, p.y, p.z]);
            r.extra = vec![s];
            r
        })
        .collect();
    Ok(Dataset {
        records,
        extra_names: vec![SWEEP_COLUMN.to_string()],
    })
}

/// The rows of a sweep file grouped by swept joint, in file order, in library units.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SweepSet<const N: usize> {
    /// `points[j]`: measured points of joint `j`'s sweep (0-based).
    pub points: Vec<Vec<Vector3<f64>>>,
    /// `q[j]`: joint readings (rad) of those rows.
    pub q: Vec<Vec<[f64; N]>>,
}

/// A `sweep` cell that does not name a joint.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BadSweepCell {
    /// Line of the file (0 for records made in memory).
    pub line: u32,
    pub value: f64,
}

impl<const N: usize> SweepSet<N> {
    /// Groups `data` by its `sweep` column; `Ok(None)` when there is no such column. Rows with
    /// an empty cell or 0 are skipped (points that belong to no sweep).
    pub fn from_dataset(data: &Dataset<N>) -> std::result::Result<Option<Self>, BadSweepCell> {
        let Some(k) = data.extra_names.iter().position(|n| n == SWEEP_COLUMN) else {
            return Ok(None);
        };
        let mut s = SweepSet {
            points: vec![Vec::new(); N],
            q: vec![Vec::new(); N],
        };
        for r in &data.records {
            let v = r.extra.get(k).copied().unwrap_or(f64::NAN);
            if v.is_nan() || v == 0.0 {
                continue;
            }
            if v.fract() != 0.0 || !(1.0..=N as f64).contains(&v) {
                return Err(BadSweepCell {
                    line: r.line,
                    value: v,
                });
            }
            let j = v as usize - 1;
            let m = r.measurement::<f64>();
            s.points[j].push(m.point);
            s.q[j].push(m.q);
        }
        Ok(Some(s))
    }

    /// The sweep of joint `joint` (0-based), if the data has one.
    pub fn get(&self, joint: usize) -> Option<Sweep<'_, f64, N>> {
        let p = self.points.get(joint)?;
        let q = self.q.get(joint)?;
        (!p.is_empty()).then_some(Sweep {
            joint,
            points: p,
            q,
        })
    }
}
