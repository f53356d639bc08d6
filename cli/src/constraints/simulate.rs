//! Constraint sessions from a robot with known errors (`simulate --constraints
//! socket:4x10,plane:3x15,distance:30[,point:20]`): the joints that bring the true robot's
//! tool point to a socket or onto a plane come from the library's `compensate` (the damped
//! Newton iteration that brings an identified robot to target points), started from random
//! poses so that each socket is touched in different orientations.

use crate::formats::measurements::quantize_deg;
use crate::simulation::{random_configurations, Streams};
use crate::HostRobot;
use kinecal::compensate::{compensate, Config, Target};
use kinecal::ForwardKinematics;
use nalgebra::Vector3;
use rand::{Rng, RngExt};
use rand_distr::StandardNormal;
use std::fmt::Write as _;

/// What to simulate: socket and plane groups × rows each, distance pairs, tracker points.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct SessionPlan {
    pub sockets: (usize, usize),
    pub planes: (usize, usize),
    pub distances: usize,
    pub points: usize,
}

impl std::str::FromStr for SessionPlan {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = |p: &str| {
            format!(
                "--constraints `{p}`: expected socket:GROUPSxROWS, plane:GROUPSxROWS, \
                 distance:PAIRS or point:ROWS, separated by commas"
            )
        };
        let mut plan = SessionPlan::default();
        for part in s.split(',').map(str::trim).filter(|p| !p.is_empty()) {
            let (kind, n) = part.split_once(':').ok_or_else(|| bad(part))?;
            let count = |t: &str| t.trim().parse::<usize>().ok().filter(|&n| n <= 100_000);
            let pair = || -> Option<(usize, usize)> {
                let (g, r) = n.split_once('x')?;
                Some((count(g)?, count(r)?))
            };
            match kind.trim() {
                "socket" => plan.sockets = pair().ok_or_else(|| bad(part))?,
                "plane" => plan.planes = pair().ok_or_else(|| bad(part))?,
                "distance" => plan.distances = count(n).ok_or_else(|| bad(part))?,
                "point" => plan.points = count(n).ok_or_else(|| bad(part))?,
                _ => return Err(bad(part)),
            }
        }
        for (what, (g, r)) in [("socket", plan.sockets), ("plane", plan.planes)] {
            if g > 0 && r < 4 {
                return Err(format!(
                    "--constraints {what}:{g}x{r}: a group needs at least 4 rows"
                ));
            }
        }
        if plan.rows() == 0 {
            return Err(format!("--constraints `{s}`: nothing to simulate"));
        }
        Ok(plan)
    }
}

impl SessionPlan {
    /// The session with `m` times its groups (rows per group unchanged).
    pub fn times(self, m: usize) -> Self {
        Self {
            sockets: (self.sockets.0 * m, self.sockets.1),
            planes: (self.planes.0 * m, self.planes.1),
            distances: self.distances * m,
            points: self.points * m,
        }
    }

    /// Rows of the session.
    pub fn rows(&self) -> usize {
        self.sockets.0 * self.sockets.1
            + self.planes.0 * self.planes.1
            + 2 * self.distances
            + self.points
    }

    /// Equations of the session left once each socket's centre and each plane have taken
    /// their 3 (as [`super::fit::spare_equations`] counts a session read from a file): 3 per
    /// socket row and per point, 1 per plane row and per distance.
    pub fn free_equations(&self) -> usize {
        let ((sg, sr), (pg, pr)) = (self.sockets, self.planes);
        sg * (3 * sr).saturating_sub(3)
            + pg * pr.saturating_sub(3)
            + self.distances
            + 3 * self.points
    }
}

/// Tries per row (seeds) and per group (locations, planes) before giving up.
const TRIES: usize = 30;

/// The CSV of a constraint session of `truth` (noise `noise_mm` per contact, length or tracker
/// axis; `seed` as `simulate`'s). Joint readings are rounded as the file keeps them. With
/// `temperature` `(A, B)` the arm warms (or cools) linearly from A to B °C over the rows in
/// their order: each row is taken at its temperature (a socket reached, a point measured by
/// the true robot at it) and written with it (`temp_c`, to 0.01 °C as a sensor reports it).
pub fn session<const N: usize>(
    truth: &HostRobot<N>,
    plan: &SessionPlan,
    noise_mm: f64,
    seed: u64,
    temperature: Option<(f64, f64)>,
) -> anyhow::Result<String> {
    let temps = match temperature {
        Some(t) => crate::simulation::warm_up(t, plan.rows())?,
        None => Vec::new(),
    };
    // Row `i`'s temperature (°C), `None` without `--temperature`.
    let temp_of = |i: usize| temps.get(i).copied();
    let mut s = Streams::new(seed);
    let mut out = String::from("kind,group");
    for j in 1..=N {
        let _ = write!(out, ",q{j}");
    }
    out.push_str(",length_mm,sigma_mm,x,y,z");
    out.push_str(if temperature.is_some() {
        ",temp_c\n"
    } else {
        "\n"
    });
    let sigma = if noise_mm > 0.0 {
        format!("{noise_mm}")
    } else {
        String::new()
    };
    // Rows written so far: the next row's index in the warm-up.
    let mut written = 0;
    let mut row = |out: &mut String, kind: &str, group: &str, q: &[f64; N], tail: &str| {
        let _ = write!(out, "{kind},{group}");
        for v in q {
            let _ = write!(out, ",{}", quantize_deg(v.to_degrees()));
        }
        match temp_of(written) {
            Some(t) => {
                let _ = writeln!(out, "{tail},{t}");
            }
            None => {
                let _ = writeln!(out, "{tail}");
            }
        }
        written += 1;
    };
    let noise3 = |rng: &mut rand_xoshiro::Xoshiro256PlusPlus| {
        Vector3::from_fn(|_, _| noise_mm * rng.sample::<f64, _>(StandardNormal))
    };
    let mut first = 0;
    for g in 0..plan.sockets.0 {
        let rows = group_rows(plan.sockets.1, &mut s, |s| {
            let q0 = random_configurations(truth, 1, &mut s.configs)[0];
            let centre = fk(truth, &q0, temp_of(first));
            (0..plan.sockets.1)
                .map(|k| {
                    let target = centre + noise3(&mut s.noise);
                    reach(
                        truth,
                        &target,
                        &q0,
                        45.0,
                        temp_of(first + k),
                        &mut s.configs,
                    )
                })
                .collect()
        })?;
        first += plan.sockets.1;
        for q in &rows {
            row(
                &mut out,
                "socket",
                &format!("s{}", g + 1),
                q,
                &format!(",,{sigma},,,"),
            );
        }
    }
    for g in 0..plan.planes.0 {
        let rows = group_rows(plan.planes.1, &mut s, |s| {
            let q0 = random_configurations(truth, 1, &mut s.configs)[0];
            let p0 = fk(truth, &q0, temp_of(first));
            let normal =
                Vector3::from_fn(|_, _| s.errors.sample::<f64, _>(StandardNormal)).normalize();
            let (t1, t2) = super::shapes::tangents(&normal);
            (0..plan.planes.1)
                .map(|k| {
                    let u: f64 = s.configs.random_range(-150.0..150.0);
                    let v: f64 = s.configs.random_range(-150.0..150.0);
                    let target = p0 + t1 * u + t2 * v + normal * noise3(&mut s.noise).x;
                    reach(
                        truth,
                        &target,
                        &q0,
                        30.0,
                        temp_of(first + k),
                        &mut s.configs,
                    )
                })
                .collect()
        })?;
        first += plan.planes.1;
        for q in &rows {
            row(
                &mut out,
                "plane",
                &format!("p{}", g + 1),
                q,
                &format!(",,{sigma},,,"),
            );
        }
    }
    for g in 0..plan.distances {
        let q = random_configurations(truth, 2, &mut s.configs);
        let (pa, pb) = (
            fk(truth, &q[0], temp_of(first)),
            fk(truth, &q[1], temp_of(first + 1)),
        );
        let length = (pa - pb).norm() + noise3(&mut s.noise).x;
        first += 2;
        let tail = format!(",{length:.6},{sigma},,,");
        for qa in &q {
            row(&mut out, "distance", &format!("d{}", g + 1), qa, &tail);
        }
    }
    for k in 0..plan.points {
        let q = random_configurations(truth, 1, &mut s.configs)[0];
        let p = fk(truth, &q, temp_of(first)) + noise3(&mut s.noise);
        first += 1;
        let tail = format!(",,{sigma},{:.8},{:.8},{:.8}", p.x, p.y, p.z);
        row(&mut out, "point", &format!("x{}", k + 1), &q, &tail);
    }
    Ok(out)
}

/// The tool point of `robot` at `q` and the temperature `temp_c` (°C; `None`: the reference).
fn fk<const N: usize>(robot: &HostRobot<N>, q: &[f64; N], temp_c: Option<f64>) -> Vector3<f64> {
    let mut fk = ForwardKinematics::<f64, N>::new();
    fk.compute_at(robot, q, 0, temp_c)
        .unwrap_or(Vector3::repeat(f64::NAN))
}

/// Joint readings (rounded as written) that bring `robot`'s tool point to `target` at the
/// temperature `temp_c`, started from `around` moved by up to ±`spread_deg` per joint at random.
pub(crate) fn reach<const N: usize, R: Rng>(
    robot: &HostRobot<N>,
    target: &Vector3<f64>,
    around: &[f64; N],
    spread_deg: f64,
    temp_c: Option<f64>,
    rng: &mut R,
) -> Option<[f64; N]> {
    let config = Config {
        iterations: 60,
        max_step: 120f64.to_radians(),
        accept: 1e-4,
        tolerance: 1e-8,
        temperature_c: temp_c,
        ..Config::default()
    };
    let spread = spread_deg.to_radians();
    for _ in 0..TRIES {
        let seed: [f64; N] = std::array::from_fn(|j| {
            let jt = &robot.joints()[j];
            (around[j] + rng.random_range(-spread..spread)).clamp(jt.lower, jt.upper)
        });
        let Ok(sol) = compensate(robot, &Target::Point(*target), &seed, &config) else {
            continue;
        };
        let q = sol.q.map(|v| quantize_deg(v.to_degrees()).to_radians());
        let inside = (0..N).all(|j| {
            let jt = &robot.joints()[j];
            q[j] >= jt.lower && q[j] <= jt.upper
        });
        if inside && (fk(robot, &q, temp_c) - target).norm() < 1e-3 {
            return Some(q);
        }
    }
    None
}

/// Draws a group (a socket's location or a plane, then its rows) until every row is reachable.
fn group_rows<const N: usize>(
    rows: usize,
    s: &mut Streams,
    mut draw: impl FnMut(&mut Streams) -> Option<Vec<[f64; N]>>,
) -> anyhow::Result<Vec<[f64; N]>> {
    for _ in 0..TRIES {
        if let Some(q) = draw(s) {
            debug_assert_eq!(q.len(), rows);
            return Ok(q);
        }
    }
    anyhow::bail!(
        "simulate --constraints: no socket or plane of {rows} reachable rows found in {TRIES} \
         draws: try another --seed or fewer rows"
    )
}

/// One row of a planned session (`plan --constraints` writes them): kind, group, joint
/// readings (rad).
pub type PlannedRow<const N: usize> = (String, String, [f64; N]);

/// Reads a planned session: `kind,group,q1..qN,…` with the readings in degrees (lengths and
/// tracker coordinates, still unmeasured, are not read).
pub fn read_plan<const N: usize>(text: &str, origin: &str) -> anyhow::Result<Vec<PlannedRow<N>>> {
    let mut lines = text
        .lines()
        .enumerate()
        .filter(|(_, l)| !l.trim().is_empty());
    let Some((_, header)) = lines.next() else {
        crate::refuse!("{origin}: empty plan");
    };
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    let readings = cols
        .iter()
        .skip(2)
        .take_while(|c| {
            c.strip_prefix('q')
                .is_some_and(|d| d.parse::<usize>().is_ok())
        })
        .count();
    if cols.len() < 2 + N || cols[0] != "kind" || cols[1] != "group" || readings != N {
        crate::refuse!(
            "{origin}: not a plan of `plan --constraints` for {N} joints (header kind,group,q1,…)"
        );
    }
    let mut out = Vec::new();
    for (i, line) in lines {
        let c: Vec<&str> = line.split(',').map(str::trim).collect();
        let q: Option<Vec<f64>> = c
            .get(2..2 + N)
            .map(|v| v.iter().filter_map(|x| x.parse::<f64>().ok()).collect());
        match q {
            Some(q) if q.len() == N && q.iter().all(|v| v.is_finite()) => {
                let q: [f64; N] = std::array::from_fn(|j| q[j].to_radians());
                out.push((c[0].to_string(), c[1].to_string(), q));
            }
            _ => crate::refuse!("{origin}: line {}: expected {N} joint readings", i + 1),
        }
    }
    Ok(out)
}

/// The session a planned one gives on `truth`: each socket is where the nominal robot puts
/// its group's tool points (their mean), each plane the plane through them, and every row is
/// the truth's joint readings that reach it from the planned ones (the ball seated in the
/// socket, the probe on the plane; `noise_mm` off each contact); a distance's length and a
/// tracker point are the truth's at the planned readings, with noise.
pub fn session_from_plan<const N: usize>(
    truth: &HostRobot<N>,
    nominal: &HostRobot<N>,
    plan: &[PlannedRow<N>],
    noise_mm: f64,
    seed: u64,
) -> anyhow::Result<String> {
    let mut s = Streams::new(seed);
    let mut out = String::from("kind,group");
    for j in 1..=N {
        let _ = write!(out, ",q{j}");
    }
    out.push_str(",length_mm,sigma_mm,x,y,z\n");
    let sigma = if noise_mm > 0.0 {
        format!("{noise_mm}")
    } else {
        String::new()
    };
    let mut groups: Vec<(&str, &str, Vec<[f64; N]>)> = Vec::new();
    for (kind, group, q) in plan {
        match groups.iter_mut().find(|g| g.0 == kind && g.1 == group) {
            Some(g) => g.2.push(*q),
            None => groups.push((kind, group, vec![*q])),
        }
    }
    let noise = |rng: &mut rand_xoshiro::Xoshiro256PlusPlus| {
        noise_mm * rng.sample::<f64, _>(StandardNormal)
    };
    for (kind, group, qs) in &groups {
        let nominal_points: Vec<Vector3<f64>> = qs.iter().map(|q| fk(nominal, q, None)).collect();
        let line = |out: &mut String, q: &[f64; N], tail: &str| {
            let _ = write!(out, "{kind},{group}");
            for v in q {
                let _ = write!(out, ",{}", quantize_deg(v.to_degrees()));
            }
            let _ = writeln!(out, "{tail}");
        };
        match *kind {
            "socket" | "plane" => {
                let shape = super::shapes::fit(
                    if *kind == "socket" {
                        super::read::Kind::Socket
                    } else {
                        super::read::Kind::Plane
                    },
                    &nominal_points,
                );
                for (q, p) in qs.iter().zip(&nominal_points) {
                    let e = Vector3::from_fn(|_, _| noise(&mut s.noise));
                    let target = match shape {
                        super::shapes::Shape::Centre(c) => c + e,
                        super::shapes::Shape::Plane(n, d) => p - n * (n.dot(p) - d) + n * e.x,
                        super::shapes::Shape::None => *p,
                    };
                    let Some(q) = reach(truth, &target, q, 2.0, None, &mut s.configs) else {
                        crate::refuse!(
                            "simulate --plan: the true robot cannot reach {kind} {group} near its planned readings"
                        );
                    };
                    line(&mut out, &q, &format!(",,{sigma},,,"));
                }
            }
            "distance" => {
                let [a, b] = qs.as_slice() else {
                    crate::refuse!(
                        "simulate --plan: distance {group} has {} rows, not 2",
                        qs.len()
                    );
                };
                let length = (fk(truth, a, None) - fk(truth, b, None)).norm() + noise(&mut s.noise);
                for q in [a, b] {
                    line(&mut out, q, &format!(",{length:.6},{sigma},,,"));
                }
            }
            "point" => {
                for q in qs {
                    let p = fk(truth, q, None) + Vector3::from_fn(|_, _| noise(&mut s.noise));
                    line(
                        &mut out,
                        q,
                        &format!(",,{sigma},{:.8},{:.8},{:.8}", p.x, p.y, p.z),
                    );
                }
            }
            other => crate::refuse!("simulate --plan: unknown kind `{other}` (group {group})"),
        }
    }
    Ok(out)
}
