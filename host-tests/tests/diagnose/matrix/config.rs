//! The matrix files (TOML): robots, noise levels, amplitudes and hidden effects; the robots loaded.

use super::*;
use kinecal_cli::HostRobot;

#[derive(Deserialize, Debug)]
pub struct Matrix {
    pub poses: usize,
    pub noise_mm: Vec<f64>,
    pub amplitudes: Vec<f64>,
    pub nothing_seeds: u64,
    /// First case seed (cases are numbered from here).
    #[serde(default = "default_seed_base")]
    pub seed_base: u64,
    pub robots: Vec<RobotCase>,
    /// Cases with effect values as given (`kinecal simulate --effect` syntax).
    #[serde(default)]
    pub raw: Vec<RawCase>,
}

fn default_seed_base() -> u64 {
    1000
}

#[derive(Deserialize, Debug)]
pub struct RawCase {
    pub robot: String,
    pub noise_mm: f64,
    /// KIND:JOINT:V1[,V2…][:ORDER]
    pub effects: Vec<String>,
    /// How many seeds of this case.
    #[serde(default = "one")]
    pub seeds: u64,
}

fn one() -> u64 {
    1
}

#[derive(Deserialize, Debug)]
pub struct RobotCase {
    pub name: String,
    pub file: String,
    /// Poses per case for this robot (default: the matrix's `poses`). Fine table pitches need
    /// more: the search offers a table only with ≥ 4 poses per knot interval.
    #[serde(default)]
    pub poses: Option<usize>,
    pub base_known: bool,
    pub base_xyz_mm: Option<[f64; 3]>,
    pub base_rpy_deg: Option<[f64; 3]>,
    /// Replaces the file's tool point (e.g. off the last axis, so that joint 6 is visible).
    pub tool_xyz_mm: Option<[f64; 3]>,
    pub effects: Vec<String>,
    pub pairs: Vec<Vec<String>>,
}

/// A hidden effect: kind, 1-based joint, cyclic order or table knot count.
#[derive(Clone, Debug, PartialEq)]
pub struct Hidden {
    pub kind: String,
    pub joint: usize,
    pub arg: usize,
    /// A `joint-table` on a fixed angle grid: `(pitch, phase)` in degrees, knots at
    /// `phase + k · pitch` (`joint-grid:JOINT:PITCH[:PHASE]`; `arg` is then unused). For a
    /// table the search found: its knot spacing and its knots' phase (`arg`: its knot count).
    pub grid: Option<(f64, f64)>,
}

impl Hidden {
    /// `KIND:JOINT`, `joint-cyclic:JOINT:ORDER`, `joint-table:JOINT:KNOTS` (knots spread evenly
    /// over the joint's limits) or `joint-grid:JOINT:PITCH_DEG[:PHASE_DEG]` (a `joint-table`
    /// with knots at PHASE + k·PITCH covering the joint's limits; phase 0 if not given).
    pub fn parse(s: &str) -> Hidden {
        let p: Vec<&str> = s.split(':').collect();
        if p[0] == "joint-grid" {
            assert!(
                p.len() == 3 || p.len() == 4,
                "`{s}`: joint-grid:JOINT:PITCH[:PHASE]"
            );
            let pitch: f64 = p[2].parse().unwrap();
            let phase: f64 = p.get(3).map(|x| x.parse().unwrap()).unwrap_or(0.0);
            assert!(
                pitch > 0.0 && phase.is_finite(),
                "`{s}`: bad pitch or phase"
            );
            return Hidden {
                kind: "joint-table".into(),
                joint: p[1].parse().unwrap(),
                arg: 0,
                grid: Some((pitch, phase)),
            };
        }
        let arg = p.get(2).map(|a| a.parse().unwrap()).unwrap_or(match p[0] {
            "joint-cyclic" => 1,
            "joint-table" => 9,
            _ => 0,
        });
        Hidden {
            kind: p[0].to_string(),
            joint: p[1].parse().unwrap(),
            arg,
            grid: None,
        }
    }
    pub fn label(&self) -> String {
        match (self.kind.as_str(), self.grid) {
            (_, Some((pitch, phase))) => {
                let short = |x: f64| {
                    let t = format!("{x:.3}");
                    t.trim_end_matches('0').trim_end_matches('.').to_string()
                };
                format!(
                    "{}:{}:every{}°@{}°",
                    self.kind,
                    self.joint,
                    short(pitch),
                    short(phase)
                )
            }
            ("joint-cyclic", _) => format!("{}:{}:order{}", self.kind, self.joint, self.arg),
            ("joint-table", _) => format!("{}:{}:{}knots", self.kind, self.joint, self.arg),
            _ => format!("{}:{}", self.kind, self.joint),
        }
    }
    /// The knot grid of a fixed-pitch table on a joint with limits `lower..upper` (rad):
    /// `(start, step, knots)` in rad, the first knot at or below the lower limit and the last
    /// at or above the upper one.
    pub fn knot_grid(&self, lower: f64, upper: f64) -> Option<(f64, f64, usize)> {
        let (pitch, phase) = self.grid?;
        let (lo, hi) = (lower.to_degrees(), upper.to_degrees());
        let k0 = ((lo - phase) / pitch + 1e-9).floor();
        let k1 = ((hi - phase) / pitch - 1e-9).ceil();
        let start = phase + k0 * pitch;
        Some((
            start.to_radians(),
            pitch.to_radians(),
            (k1 - k0) as usize + 1,
        ))
    }
    /// Values of a unit-sized effect (random phase / shape from `rng`) on a joint with limits
    /// `lower..upper` (rad).
    pub fn unit(&self, rng: &mut Xoshiro256PlusPlus, lower: f64, upper: f64) -> EffectArg {
        let g = |rng: &mut Xoshiro256PlusPlus| -> f64 { rng.sample(StandardNormal) };
        let grid = self.knot_grid(lower, upper);
        let values = match (self.kind.as_str(), grid) {
            ("joint-table", Some((_, _, knots))) => (0..knots).map(|_| 1e-4 * g(rng)).collect(),
            ("joint-cyclic", _) => {
                let ph: f64 = rng.random_range(0.0..std::f64::consts::TAU);
                vec![1e-4 * ph.cos(), 1e-4 * ph.sin()]
            }
            ("joint-table", _) => (0..self.arg).map(|_| 1e-4 * g(rng)).collect(),
            ("joint-scale", _) => vec![1e-5],
            _ => vec![1e-4],
        };
        EffectArg {
            kind: self.kind.clone(),
            joint: self.joint - 1,
            values,
            order: if self.kind == "joint-cyclic" {
                self.arg as u16
            } else {
                1
            },
            grid: grid.map(|(start, step, _)| (start, step)),
        }
    }
}

pub struct Case {
    pub robot: usize,
    pub hidden: Vec<Hidden>,
    pub noise_mm: f64,
    pub amplitude: f64,
    pub seed: u64,
    /// Effect values used as given (amplitude ignored).
    pub raw: Option<Vec<EffectArg>>,
}

pub struct Loaded<const N: usize> {
    /// The model given to the diagnosis (nominal; base from the file or identity).
    pub nominal: HostRobot<N>,
    /// The same with the simulated base, for making data.
    pub sim_nominal: HostRobot<N>,
    pub base_known: bool,
}

/// A robot of the matrix, 6 or 7 joints.
pub enum Arm {
    Six(Loaded<6>),
    Seven(Loaded<7>),
}

impl Arm {
    /// The case's outcome; `against_truth`: with the true effects' figures and both models
    /// on fresh poses ([`Outcome::fresh_rms`], [`Outcome::oracle`]), which the matrices print.
    pub fn run(&self, poses: usize, c: &Case, against_truth: bool) -> Outcome {
        match self {
            Arm::Six(l) => run_case(l, poses, c, against_truth),
            Arm::Seven(l) => run_case(l, poses, c, against_truth),
        }
    }
}

pub fn data_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data")
}

pub fn load_matrix() -> Matrix {
    load_matrix_file("diagnose_matrix.toml")
}

/// Poses of a case: its robot's `poses`, or the matrix's.
pub fn poses_of(m: &Matrix, c: &Case) -> usize {
    m.robots[c.robot].poses.unwrap_or(m.poses)
}

pub fn load_matrix_file(name: &str) -> Matrix {
    let text = std::fs::read_to_string(data_dir().join(name)).unwrap();
    toml::from_str(&text).unwrap()
}

pub fn load_arm(rc: &RobotCase) -> Arm {
    let file = RobotFile::load(&data_dir().join(&rc.file)).unwrap();
    match file.joint_count() {
        6 => Arm::Six(load_robot::<6>(rc)),
        7 => Arm::Seven(load_robot::<7>(rc)),
        n => panic!("{}: {n} joints", rc.name),
    }
}

pub fn load_robot<const N: usize>(rc: &RobotCase) -> Loaded<N> {
    let file = RobotFile::load(&data_dir().join(&rc.file)).unwrap();
    let mut nominal = file.to_robot::<N>().unwrap();
    if let Some(t) = rc.tool_xyz_mm {
        nominal.set_tool(nalgebra::Vector3::from(t)).unwrap();
    }
    let mut sim_nominal = nominal.clone();
    if let Some(xyz) = rc.base_xyz_mm {
        let rpy = rc.base_rpy_deg.unwrap_or([0.0; 3]).map(f64::to_radians);
        sim_nominal.set_base(Frame::from_xyz_rpy(xyz, rpy)).unwrap();
    }
    assert_eq!(
        file.base_known(),
        rc.base_known,
        "{}: base_known disagrees with the file",
        rc.name
    );
    Loaded {
        nominal,
        sim_nominal,
        base_known: rc.base_known,
    }
}
