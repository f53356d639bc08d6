//! The discrepancy-search test matrices (configurations in tests/data/).
//!
//! Fast subset (runs with `cargo test`): a few cases of every kind, asserted one by one.
//! Full matrices (print the naming rate, the false-alarm rate and the gap to the noise floor):
//!
//!     cargo test -p kinecal-host --test diagnose matrix:: -- --ignored --nocapture
//!
//! `full_matrix` runs diagnose_matrix.toml (the matrix the search was developed on);
//! `unseen_matrix` runs diagnose_matrix_unseen.toml (robots, joints, amplitudes, noise levels
//! and seeds the search was never tuned on, a 7-joint arm, and cases with raw effect values as
//! `kinecal simulate --effect` takes them); `grid_matrix` runs diagnose_matrix_grid.toml (joint
//! tables with knots on a fixed angle pitch aligned to multiples of the pitch or at a phase, as
//! gear and encoder tables are, on joints whose limits are not multiples of the pitch):
//!
//!     KINECAL_MATRIX_THREADS=2 cargo test -p kinecal-host --test diagnose matrix::grid_matrix -- --ignored --nocapture
//!
//! (The test profile is optimised: no `--release` needed. `KINECAL_MATRIX_FILE=other.toml` makes
//! `full_matrix` run another configuration, relative to tests/data or absolute;
//! `KINECAL_MATRIX_THREADS=2` runs two cases at a time; `KINECAL_MATRIX_ONLY=SEED,…` only the
//! cases with these seeds; `KINECAL_MATRIX_VERBOSE=1` prints every case's JSON report.)

use crate::common::main_sized_stack;

use kinecal::{Frame, Measurement, Robot};
use kinecal_cli::diagnose::{diagnose, fit_geometry, Config, Diagnosis};
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::simulation::{simulate, EffectArg, GeomErrors, Simulation};
use kinecal_cli::VCAP;
use rand::{RngExt, SeedableRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;
use serde::Deserialize;
use std::path::PathBuf;
use std::time::Instant;

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
    pub nominal: Robot<f64, N, VCAP>,
    /// The same with the simulated base, for making data.
    pub sim_nominal: Robot<f64, N, VCAP>,
    pub base_known: bool,
}

/// A robot of the matrix, 6 or 7 joints.
pub enum Arm {
    Six(Loaded<6>),
    Seven(Loaded<7>),
}

impl Arm {
    pub fn run(&self, poses: usize, c: &Case) -> Outcome {
        match self {
            Arm::Six(l) => run_case(l, poses, c),
            Arm::Seven(l) => run_case(l, poses, c),
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

pub fn sim<const N: usize>(
    l: &Loaded<N>,
    poses: usize,
    noise: f64,
    seed: u64,
    effects: Vec<EffectArg>,
) -> Vec<Measurement<f64, N>> {
    let s = Simulation {
        poses,
        noise_mm: noise,
        seed,
        geom_errors: Some(GeomErrors::default()),
        effects,
    };
    simulate(&l.sim_nominal, &s).unwrap().1.measurements()
}

/// RMS (mm) a geometric refit leaves of noiseless data with `effects`.
pub fn unexplained<const N: usize>(
    l: &Loaded<N>,
    poses: usize,
    seed: u64,
    effects: Vec<EffectArg>,
) -> f64 {
    let data = sim(l, poses, 0.0, seed, effects);
    let (fitted, _) = fit_geometry(&l.nominal, l.base_known, &[], &data).unwrap();
    kinecal::identify::lm::rms_error(&fitted, &data)
}

/// The data of a case: each hidden effect scaled so that what the geometry cannot absorb has an
/// RMS of `amplitude` noise floors.
pub fn make_data<const N: usize>(
    l: &Loaded<N>,
    poses: usize,
    c: &Case,
) -> Vec<Measurement<f64, N>> {
    if let Some(raw) = &c.raw {
        return sim(l, poses, c.noise_mm, c.seed, raw.clone());
    }
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(c.seed ^ 0xeff);
    let floor = 3f64.sqrt() * c.noise_mm;
    let mut effects = Vec::new();
    for h in &c.hidden {
        let j = l.nominal.joints()[h.joint - 1];
        let mut e = h.unit(&mut rng, j.lower, j.upper);
        let u = unexplained(l, poses, c.seed, vec![e.clone()]);
        let k = c.amplitude * floor / u.max(1e-9);
        e.values.iter_mut().for_each(|v| *v *= k);
        effects.push(e);
    }
    sim(l, poses, c.noise_mm, c.seed, effects)
}

pub struct Outcome {
    pub named: Vec<String>,
    pub exact: bool,
    pub final_rms: f64,
    pub baseline_rms: f64,
    pub floor_est: f64,
    pub floor_true: f64,
    pub seconds: f64,
}

pub fn named<const N: usize>(d: &Diagnosis<N>) -> Vec<Hidden> {
    d.found
        .iter()
        .map(|f| {
            use kinecal_cli::diagnose::candidates::CandidateKind;
            let (arg, grid) = match f.candidate.kind {
                CandidateKind::Cyclic(n) => (n as usize, None),
                CandidateKind::Table { start, step, knots } => {
                    let (start, step) = (start.to_degrees(), step.to_degrees());
                    let phase = start.rem_euclid(step);
                    let phase = if step - phase < 1e-6 { 0.0 } else { phase };
                    (knots, Some((step, phase)))
                }
                _ => (0, None),
            };
            Hidden {
                kind: f.candidate.id().to_string(),
                joint: f.candidate.joint + 1,
                arg,
                grid,
            }
        })
        .collect()
}

/// Named exactly: the same kinds on the same joints (cyclic: the same order), nothing else.
/// A table on a fixed grid is a `joint-table` like any other (its grid is not compared).
pub fn exact(hidden: &[Hidden], found: &[Hidden]) -> bool {
    let key = |h: &Hidden| {
        (
            h.kind.clone(),
            h.joint,
            if h.kind == "joint-cyclic" { h.arg } else { 0 },
        )
    };
    let mut a: Vec<_> = hidden.iter().map(key).collect();
    let mut b: Vec<_> = found.iter().map(key).collect();
    a.sort();
    b.sort();
    a == b
}

pub fn run_case<const N: usize>(l: &Loaded<N>, poses: usize, c: &Case) -> Outcome {
    let data = make_data(l, poses, c);
    let t = Instant::now();
    let d = diagnose(&l.nominal, l.base_known, &[], &data, &Config::default()).unwrap();
    let seconds = t.elapsed().as_secs_f64();
    if std::env::var("KINECAL_MATRIX_VERBOSE").is_ok() {
        let r = kinecal_cli::reports::diagnose::DiagnoseReport::of(&d).to_value();
        eprintln!("{}", serde_json::to_string_pretty(&r).unwrap());
    }
    let found = named(&d);
    Outcome {
        named: found.iter().map(|h| h.label()).collect(),
        exact: exact(&c.hidden, &found),
        final_rms: d.final_validation_rms_mm,
        baseline_rms: d.baseline_validation_rms_mm,
        floor_est: d.noise_floor_mm,
        floor_true: 3f64.sqrt() * c.noise_mm,
        seconds,
    }
}

pub fn all_cases(m: &Matrix) -> Vec<Case> {
    let mut cases = Vec::new();
    let mut seed = m.seed_base;
    for (ri, rc) in m.robots.iter().enumerate() {
        let mut sets: Vec<Vec<Hidden>> =
            rc.effects.iter().map(|e| vec![Hidden::parse(e)]).collect();
        sets.extend(
            rc.pairs
                .iter()
                .map(|p| p.iter().map(|e| Hidden::parse(e)).collect()),
        );
        for hidden in sets {
            for &noise in &m.noise_mm {
                for &amp in &m.amplitudes {
                    seed += 1;
                    cases.push(Case {
                        robot: ri,
                        hidden: hidden.clone(),
                        noise_mm: noise,
                        amplitude: amp,
                        seed,
                        raw: None,
                    });
                }
            }
        }
        for &noise in &m.noise_mm {
            for _ in 0..m.nothing_seeds {
                seed += 1;
                cases.push(Case {
                    robot: ri,
                    hidden: Vec::new(),
                    noise_mm: noise,
                    amplitude: 0.0,
                    seed,
                    raw: None,
                });
            }
        }
    }
    for rc in &m.raw {
        let ri = m
            .robots
            .iter()
            .position(|r| r.name == rc.robot)
            .unwrap_or_else(|| panic!("raw case: no robot {}", rc.robot));
        let effects: Vec<EffectArg> = rc.effects.iter().map(|e| e.parse().unwrap()).collect();
        let hidden = effects
            .iter()
            .map(|e| Hidden {
                kind: e.kind.clone(),
                joint: e.joint + 1,
                arg: if e.kind == "joint-cyclic" {
                    e.order as usize
                } else {
                    e.values.len()
                },
                grid: None,
            })
            .collect::<Vec<_>>();
        for _ in 0..rc.seeds {
            seed += 1;
            cases.push(Case {
                robot: ri,
                hidden: hidden.clone(),
                noise_mm: rc.noise_mm,
                amplitude: f64::NAN,
                seed,
                raw: Some(effects.clone()),
            });
        }
    }
    cases
}

pub fn describe(m: &Matrix, c: &Case) -> String {
    let h: Vec<String> = match &c.raw {
        Some(raw) => raw
            .iter()
            .map(|e| format!("{}:{}:{:?}", e.kind, e.joint + 1, e.values))
            .collect(),
        None => c.hidden.iter().map(|h| h.label()).collect(),
    };
    format!(
        "{:6} seed {:5} noise {:.3} amp {:>4}  hidden [{}]",
        m.robots[c.robot].name,
        c.seed,
        c.noise_mm,
        if c.amplitude.is_nan() {
            "raw".to_string()
        } else {
            format!("{:.0}", c.amplitude)
        },
        if h.is_empty() {
            "nothing".into()
        } else {
            h.join(" + ")
        }
    )
}

/// `joint-grid` cases: knots at phase + k·pitch from at or below the lower limit to at or
/// above the upper one, a `joint-table` for "named exactly", the grid given to the simulation.
#[test]
fn grid_cases_cover_the_limits_on_the_pitch() {
    let deg = f64::to_radians;
    let grid = |s: &str, lo: f64, hi: f64| {
        let (start, step, knots) = Hidden::parse(s).knot_grid(deg(lo), deg(hi)).unwrap();
        (start.to_degrees(), step.to_degrees(), knots)
    };
    let close = |a: (f64, f64, usize), b: (f64, f64, usize)| {
        assert!(
            (a.0 - b.0).abs() < 1e-9 && (a.1 - b.1).abs() < 1e-9 && a.2 == b.2,
            "{a:?} vs {b:?}"
        )
    };
    close(grid("joint-grid:1:10", -185.0, 185.0), (-190.0, 10.0, 39));
    close(
        grid("joint-grid:1:10:2.5", -185.0, 185.0),
        (-187.5, 10.0, 39),
    );
    close(grid("joint-grid:2:3.6", -155.0, 35.0), (-158.4, 3.6, 55));
    // A limit on the grid is a knot.
    close(grid("joint-grid:2:15:0", -120.0, 120.0), (-120.0, 15.0, 17));
    close(grid("joint-grid:2:15:5", -120.0, 120.0), (-130.0, 15.0, 18));
    close(
        grid("joint-grid:3:20:-12", -130.0, 154.0),
        (-132.0, 20.0, 16),
    );
    let h = Hidden::parse("joint-grid:4:20:8");
    assert_eq!(h.label(), "joint-table:4:every20°@8°");
    let table = Hidden::parse("joint-table:4:9");
    assert!(exact(std::slice::from_ref(&h), &[table]));
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(3);
    let e = h.unit(&mut rng, deg(-350.0), deg(350.0));
    let (start, step) = e.grid.unwrap();
    assert!((start.to_degrees() + 352.0).abs() < 1e-9 && (step.to_degrees() - 20.0).abs() < 1e-9);
    assert_eq!(e.values.len(), 37);
    assert_eq!((e.kind.as_str(), e.joint), ("joint-table", 3));
}

/// A few cases of each kind, asserted: the hidden effects named exactly and the held-out RMS
/// within 1.25× the noise floor; nothing named where nothing is hidden.
#[test]
fn fast_subset_names_hidden_effects_exactly() {
    main_sized_stack(|| {
        let pick = vec![
            (0, vec!["joint-compliance:2"], 0.02, 4.0),
            (0, vec!["joint-cyclic:4:2"], 0.02, 4.0),
            (0, vec!["joint-scale:3"], 0.02, 4.0),
            (0, vec!["axis-tilt:3"], 0.02, 4.0),
            (0, vec!["joint-table:2:9"], 0.02, 4.0),
            (1, vec!["joint-compliance:4"], 0.02, 4.0),
            (1, vec!["joint-cyclic:1:1"], 0.02, 4.0),
            (1, vec!["joint-compliance:2", "joint-cyclic:5:1"], 0.02, 5.0),
            (0, vec![], 0.02, 0.0),
            (1, vec![], 0.02, 0.0),
        ];
        assert_picks(&load_matrix(), &pick, 77);
    });
}

/// Joint tables whose knots lie on a fixed angle pitch (robots of diagnose_matrix_grid.toml,
/// with its poses): a 10° table aligned to 0° on the KR 16's joint 1 (limits ±185°), a 15°
/// table at a phase of 5° on the 7-joint arm's joint 2 (limits ±120°) and a 10° table at 2.5°
/// on its joint 1 (±170°), and nothing hidden on the KR 16. Asserted like
/// `fast_subset_names_hidden_effects_exactly`.
#[test]
fn fast_grid_tables_named_exactly_at_the_floor() {
    main_sized_stack(|| {
        let m = load_matrix_file("diagnose_matrix_grid.toml");
        let kr16 = robot_index(&m, "kr16");
        let arm7 = robot_index(&m, "arm7");
        let pick = vec![
            (kr16, vec!["joint-grid:1:10"], 0.02, 4.0),
            (arm7, vec!["joint-grid:2:15:5"], 0.02, 6.0),
            (arm7, vec!["joint-grid:1:10:2.5"], 0.02, 4.0),
            (kr16, vec![], 0.02, 0.0),
        ];
        assert_picks(&m, &pick, 161);
    });
}

/// The index of the robot called `name` in `m`.
pub fn robot_index(m: &Matrix, name: &str) -> usize {
    m.robots
        .iter()
        .position(|r| r.name == name)
        .unwrap_or_else(|| panic!("no robot {name}"))
}

/// Runs `(robot, hidden, noise mm, amplitude)` cases with seeds from `seed0` and asserts each:
/// hidden effects named exactly (nothing named when nothing is hidden), final held-out RMS
/// ≤ 1.25× the estimated and the true noise floor.
pub fn assert_picks(m: &Matrix, pick: &[(usize, Vec<&str>, f64, f64)], seed0: u64) {
    let robots: Vec<Arm> = m.robots.iter().map(load_arm).collect();
    let mut failures = Vec::new();
    for (i, (r, h, noise, amp)) in pick.iter().enumerate() {
        let c = Case {
            robot: *r,
            hidden: h.iter().map(|s| Hidden::parse(s)).collect(),
            noise_mm: *noise,
            amplitude: *amp,
            seed: seed0 + i as u64,
            raw: None,
        };
        let o = robots[*r].run(poses_of(m, &c), &c);
        let line = format!(
            "{}: named {:?}; held-out {:.4} → {:.4} mm, floor {:.4} (true {:.4}), {:.2} s",
            describe(m, &c),
            o.named,
            o.baseline_rms,
            o.final_rms,
            o.floor_est,
            o.floor_true,
            o.seconds
        );
        eprintln!("{line}");
        if !o.exact || o.final_rms > 1.25 * o.floor_est || o.final_rms > 1.25 * o.floor_true {
            failures.push(line);
        }
    }
    assert!(
        failures.is_empty(),
        "failed cases:\n{}",
        failures.join("\n")
    );
}

/// The matrix the search was developed on: naming rate, false-alarm rate, gap to the floor.
#[test]
#[ignore = "the full matrix takes minutes: cargo test -p kinecal-host --test diagnose matrix:: -- --ignored --nocapture"]
fn full_matrix() {
    main_sized_stack(|| {
        let file =
            std::env::var("KINECAL_MATRIX_FILE").unwrap_or_else(|_| "diagnose_matrix.toml".into());
        run_matrix(&file)
    });
}

/// Cases the search was never tuned on.
#[test]
#[ignore = "the full matrix takes minutes: cargo test -p kinecal-host --test diagnose matrix:: -- --ignored --nocapture"]
fn unseen_matrix() {
    main_sized_stack(|| run_matrix("diagnose_matrix_unseen.toml"));
}

/// Joint tables on fixed angle pitches and phases, with null cases.
#[test]
#[ignore = "the grid matrix takes a minute or more: KINECAL_MATRIX_THREADS=2 cargo test -p kinecal-host --test diagnose matrix::grid_matrix -- --ignored --nocapture"]
fn grid_matrix() {
    main_sized_stack(|| run_matrix("diagnose_matrix_grid.toml"));
}

/// Runs every case of a matrix file and prints the rates.
pub fn run_matrix(file: &str) {
    let m = load_matrix_file(file);
    let robots: Vec<Arm> = m.robots.iter().map(load_arm).collect();
    let mut cases = all_cases(&m);
    // KINECAL_MATRIX_ONLY=1040,1041 runs only the cases with these seeds.
    if let Ok(only) = std::env::var("KINECAL_MATRIX_ONLY") {
        let seeds: Vec<u64> = only
            .split(',')
            .filter_map(|s| s.trim().parse().ok())
            .collect();
        cases.retain(|c| seeds.contains(&c.seed));
    }
    let threads: usize = std::env::var("KINECAL_MATRIX_THREADS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1)
        .max(1);
    let next = std::sync::atomic::AtomicUsize::new(0);
    let results: std::sync::Mutex<Vec<(usize, Outcome)>> = std::sync::Mutex::new(Vec::new());
    std::thread::scope(|s| {
        for _ in 0..threads {
            // Each worker needs a big stack too.
            let work = || loop {
                let i = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                let Some(c) = cases.get(i) else { break };
                let o = robots[c.robot].run(poses_of(&m, c), c);
                eprintln!(
                    "{}{}{}: named {:?}; held-out {:.4} → {:.4} mm = {:.2}× floor (est {:.4}, true {:.4}: {:.2}×), {:.2} s",
                    if (c.hidden.is_empty() && !o.named.is_empty()) || (!c.hidden.is_empty() && !o.exact) { "MISS " } else { "" },
                    if o.final_rms > 1.25 * o.floor_true { "FAR " } else { "" },
                    describe(&m, c),
                    o.named,
                    o.baseline_rms,
                    o.final_rms,
                    o.final_rms / o.floor_est,
                    o.floor_est,
                    o.floor_true,
                    o.final_rms / o.floor_true,
                    o.seconds
                );
                results.lock().unwrap().push((i, o));
            };
            std::thread::Builder::new()
                .stack_size(8 << 20)
                .spawn_scoped(s, work)
                .unwrap();
        }
    });
    let results = results.into_inner().unwrap();
    let mut hidden_n = 0;
    let mut hidden_exact = 0;
    let mut nothing_n = 0;
    let mut false_alarms = 0;
    let mut gaps_est = Vec::new();
    let mut gaps_true = Vec::new();
    let mut gaps_hidden = Vec::new();
    let mut secs = Vec::new();
    // Per kind: cases, named exactly, final held-out / true floor of each.
    let mut by_kind: std::collections::BTreeMap<String, (usize, usize, Vec<f64>)> =
        Default::default();
    for (i, o) in &results {
        let c = &cases[*i];
        secs.push(o.seconds);
        if c.hidden.is_empty() {
            nothing_n += 1;
            false_alarms += usize::from(!o.named.is_empty());
        } else {
            hidden_n += 1;
            hidden_exact += usize::from(o.exact);
            let key = if c.hidden.len() > 1 {
                "two effects".to_string()
            } else {
                match c.hidden[0].grid {
                    Some((pitch, _)) => format!("joint-table every {pitch}° (grid)"),
                    None => c.hidden[0].kind.clone(),
                }
            };
            let key = if c.raw.is_some() {
                format!("{key} (raw values)")
            } else {
                key
            };
            let e = by_kind.entry(key).or_default();
            e.0 += 1;
            e.1 += usize::from(o.exact);
            e.2.push(o.final_rms / o.floor_true);
            gaps_hidden.push(o.final_rms / o.floor_true);
        }
        gaps_est.push(o.final_rms / o.floor_est);
        gaps_true.push(o.final_rms / o.floor_true);
    }
    let stats = |v: &mut Vec<f64>| {
        v.sort_by(f64::total_cmp);
        let mean = v.iter().sum::<f64>() / v.len() as f64;
        let within = v.iter().filter(|g| **g <= 1.25).count() as f64 / v.len() as f64;
        (mean, v[v.len() / 2], v[v.len() - 1], within)
    };
    let (ge_mean, ge_med, ge_max, ge_in) = stats(&mut gaps_est);
    let (gt_mean, gt_med, gt_max, gt_in) = stats(&mut gaps_true);
    let hidden_stats = (!gaps_hidden.is_empty()).then(|| stats(&mut gaps_hidden));
    secs.sort_by(f64::total_cmp);
    let per_robot: Vec<String> = m
        .robots
        .iter()
        .filter_map(|r| r.poses.map(|p| format!("{} {p}", r.name)))
        .collect();
    println!(
        "\n=== {file}: {} cases, {} poses each{} ===",
        results.len(),
        m.poses,
        if per_robot.is_empty() {
            String::new()
        } else {
            format!(" (but {})", per_robot.join(", "))
        }
    );
    println!(
        "naming rate (hidden effects named exactly, nothing else): {hidden_exact}/{hidden_n} = {:.1} %",
        100.0 * hidden_exact as f64 / hidden_n.max(1) as f64
    );
    for (k, (n, ok, gaps)) in &by_kind {
        let mean = gaps.iter().sum::<f64>() / gaps.len() as f64;
        let max = gaps.iter().copied().fold(0.0, f64::max);
        let within = gaps.iter().filter(|g| **g <= 1.25).count();
        println!(
            "  {k:30} {ok}/{n}   final/true floor mean {mean:.3}, max {max:.3}, ≤ 1.25 in {within}/{n}"
        );
    }
    println!(
        "false-alarm rate (something named, nothing hidden): {false_alarms}/{nothing_n} = {:.1} %",
        100.0 * false_alarms as f64 / nothing_n.max(1) as f64
    );
    println!("final held-out RMS / estimated noise floor: mean {ge_mean:.3}, median {ge_med:.3}, max {ge_max:.3}; ≤ 1.25 in {:.1} % of cases", 100.0 * ge_in);
    println!("final held-out RMS / true noise floor √3σ:  mean {gt_mean:.3}, median {gt_med:.3}, max {gt_max:.3}; ≤ 1.25 in {:.1} % of cases", 100.0 * gt_in);
    if let Some((mean, med, max, within)) = hidden_stats {
        println!("  … of the cases with something hidden:    mean {mean:.3}, median {med:.3}, max {max:.3}; ≤ 1.25 in {:.1} % of cases", 100.0 * within);
    }
    println!(
        "seconds per case (diagnose only): median {:.2}, max {:.2}",
        secs[secs.len() / 2],
        secs[secs.len() - 1]
    );
}
