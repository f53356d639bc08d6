//! Joint tables whose knots the data choose: the catalogue offers fixed pitches with
//! knots on multiples of the pitch besides the fractions of the joint's limits, the best grids
//! get their phase chosen, and a table made on such a grid is found on it, to the noise floor,
//! and written back exactly.

use kinecal_cli::HostRobot;

use kinecal::model::effects::EffectKind;
use kinecal::{Joint, Measurement};
use kinecal_cli::diagnose::candidates::{
    catalogue, coverage, shifted, Candidate, CandidateKind, CatalogueConfig,
};
use kinecal_cli::diagnose::{diagnose, Config};
use kinecal_cli::formats::robot_file::RobotFile;
use kinecal_cli::simulation::{simulate, GeomErrors, Simulation};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::path::PathBuf;

fn er20() -> HostRobot<6> {
    let path = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/er20.toml");
    RobotFile::load(&path).unwrap().to_robot::<6>().unwrap()
}

/// The ER20 with joint `j` (0-based) limited to `lower..upper` degrees.
fn with_limits(j: usize, lower: f64, upper: f64) -> HostRobot<6> {
    let mut r = er20();
    let row = r.joints()[j];
    r.set_joint(
        j,
        Joint {
            lower: lower.to_radians(),
            upper: upper.to_radians(),
            ..row
        },
    )
    .unwrap();
    r
}

/// `x` (degrees) is a multiple of `p` (degrees) up to rounding.
fn on_multiple(x: f64, p: f64) -> bool {
    let k = (x / p).round();
    (x - k * p).abs() < 1e-9
}

/// Data from `nominal` with geometric errors, a table on joint `j` with knots at
/// `phase + k·pitch` degrees over the joint's limits (values N(0, σ_v) rad) and noise.
#[allow(clippy::too_many_arguments)]
fn table_data(
    nominal: &HostRobot<6>,
    j: usize,
    pitch_deg: f64,
    phase_deg: f64,
    sigma_v: f64,
    noise_mm: f64,
    poses: usize,
    seed: u64,
) -> Vec<Measurement<f64, 6>> {
    let row = nominal.joints()[j];
    let k0 = ((row.lower.to_degrees() - phase_deg) / pitch_deg).floor();
    let k1 = ((row.upper.to_degrees() - phase_deg) / pitch_deg).ceil();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let g = Normal::new(0.0, sigma_v).unwrap();
    let values: Vec<f64> = (0..=(k1 - k0) as usize)
        .map(|_| g.sample(&mut rng))
        .collect();
    let mut truth = nominal.clone();
    truth
        .effects_mut()
        .push(
            EffectKind::Table,
            j,
            6,
            1,
            (phase_deg + k0 * pitch_deg).to_radians(),
            pitch_deg.to_radians(),
            &values,
        )
        .unwrap();
    let s = Simulation {
        poses,
        noise_mm,
        seed,
        geom_errors: Some(GeomErrors::default()),
        effects: Vec::new(),
    };
    simulate(&truth, &s).unwrap().1.measurements()
}

fn table_of(c: &Candidate) -> (f64, f64, usize) {
    match c.kind {
        CandidateKind::Table { start, step, knots } => {
            (start.to_degrees(), step.to_degrees(), knots)
        }
        _ => panic!("{} is not a table", c.label()),
    }
}

/// On a ±185° joint (a KUKA axis 1) the fractions of the limits never give 10° knots on
/// multiples of 10°; the pitch ladder does, trimmed to the range the data cover.
#[test]
fn pitch_grids_sit_on_multiples_of_the_pitch() {
    let robot = with_limits(0, -185.0, 185.0);
    let data = table_data(&robot, 0, 10.0, 0.0, 0.0, 0.0, 400, 3);
    let (lo, hi) = coverage(&data);
    let cfg = CatalogueConfig::default();
    let tables: Vec<(f64, f64, usize)> = catalogue(&robot, true, &data, &cfg)
        .iter()
        .filter(|c| c.joint == 0 && matches!(c.kind, CandidateKind::Table { .. }))
        .map(table_of)
        .collect();
    for p in [5.0, 10.0, 15.0, 20.0, 30.0] {
        let (start, _, knots) = *tables
            .iter()
            .find(|t| (t.1 - p).abs() < 1e-9 && on_multiple(t.0, p))
            .unwrap_or_else(|| panic!("no {p}° grid on multiples of {p}°: {tables:?}"));
        // The grid covers the data and starts at most one pitch below them.
        let end = start + (knots - 1) as f64 * p;
        assert!(start <= lo[0].to_degrees() + 1e-9 && start > lo[0].to_degrees() - p);
        assert!(end >= hi[0].to_degrees() - 1e-9 && end < hi[0].to_degrees() + p);
    }
    // The range fractions stay: 36 intervals of the 370° are 10.28° from −185°.
    assert!(tables
        .iter()
        .any(|t| (t.1 - 370.0 / 36.0).abs() < 1e-9 && on_multiple(t.0 + 185.0, 370.0 / 36.0)));
    // Fewer than 4 poses per interval: no 1° grid over 370° from 400 poses.
    assert!(!tables.iter().any(|t| (t.1 - 1.0).abs() < 1e-9));
}

/// Every pitch is offered at phases 0 and ½; `shifted` moves a grid's knots by a fraction of
/// its pitch and still covers the data.
#[test]
fn pitches_come_at_two_phases_and_shift_by_fractions_of_the_pitch() {
    let robot = with_limits(0, -185.0, 185.0);
    let data = table_data(&robot, 0, 10.0, 0.0, 0.0, 0.0, 400, 4);
    let (lo, hi) = coverage(&data);
    let cfg = CatalogueConfig::default();
    let mut phases: Vec<f64> = catalogue(&robot, true, &data, &cfg)
        .iter()
        .filter(|c| c.joint == 0 && matches!(c.kind, CandidateKind::Table { step, .. } if (step.to_degrees() - 20.0).abs() < 1e-9))
        .map(|c| table_of(c).0.rem_euclid(20.0))
        .collect();
    phases.sort_by(f64::total_cmp);
    assert_eq!(phases.len(), 2, "{phases:?}");
    for (k, p) in phases.iter().enumerate() {
        assert!((p - 10.0 * k as f64).abs() < 1e-9, "{phases:?}");
    }
    let c = Candidate {
        kind: CandidateKind::Table {
            start: (-180f64).to_radians(),
            step: 10f64.to_radians(),
            knots: 37,
        },
        joint: 0,
    };
    for f in [-0.5, -0.125, 1.0 / 64.0, 0.375] {
        let v = shifted(&c, f, lo[0], hi[0], data.len(), &cfg).unwrap();
        let (start, step, knots) = table_of(&v);
        assert!((step - 10.0).abs() < 1e-12);
        // Knots at 10·f + k·10 degrees, written round (1e-9).
        let phase = start.rem_euclid(10.0);
        assert!(
            (phase - (10.0 * f).rem_euclid(10.0)).abs() < 1e-9,
            "{f}: {start}"
        );
        assert_eq!(start, (start * 1e9).round() / 1e9);
        assert!(start <= lo[0].to_degrees() + 1e-9 && start > lo[0].to_degrees() - 10.0);
        assert!(start + (knots - 1) as f64 * step >= hi[0].to_degrees() - 1e-9);
    }
    // Not a table: nothing to shift.
    let s = Candidate {
        kind: CandidateKind::Scale,
        joint: 0,
    };
    assert!(shifted(&s, 0.25, lo[0], hi[0], data.len(), &cfg).is_none());
}

/// The case: a table every 10° aligned to 0° on a ±185° joint (the limits' fractions
/// give 10.28° from −185°). It is named, found on its own grid, and the held-out RMS reaches
/// the noise floor; the written model reads back with the same knots.
#[test]
fn a_ten_degree_table_aligned_to_zero_is_found_on_its_grid() {
    let nominal = with_limits(0, -185.0, 185.0);
    let noise = 0.02;
    let data = table_data(&nominal, 0, 10.0, 0.0, 1.5e-4, noise, 600, 11);
    let d = diagnose(&nominal, true, &[], &data, &Config::default()).unwrap();
    assert_eq!(
        d.found.len(),
        1,
        "{:?}",
        d.found
            .iter()
            .map(|f| f.candidate.label())
            .collect::<Vec<_>>()
    );
    let c = d.found[0].candidate;
    assert_eq!(c.joint, 0);
    let (start, step, _) = table_of(&c);
    assert!(
        (step - 10.0).abs() < 1e-9 && on_multiple(start, 10.0),
        "{}",
        c.label()
    );
    let floor = 3f64.sqrt() * noise;
    assert!(
        d.baseline_validation_rms_mm > 3.0 * floor,
        "{}",
        d.baseline_validation_rms_mm
    );
    assert!(
        d.final_validation_rms_mm <= 1.25 * floor,
        "{} vs {floor}",
        d.final_validation_rms_mm
    );
    // The robot file keeps step_deg and the knot origin: the table reads back exactly.
    let file = RobotFile::from_robot("t", &d.model, true, &d.free_tilt);
    let text = file.to_toml().unwrap();
    let back = RobotFile::parse(&text, "written model").unwrap();
    let r = back.to_robot::<6>().unwrap();
    let (a, b) = (d.model.effects(), r.effects());
    let i = a.find(EffectKind::Table, 0, 1).unwrap();
    let k = b.find(EffectKind::Table, 0, 1).unwrap();
    assert_eq!(a.values_of(i), b.values_of(k));
    let (ea, eb) = (a.get(i).unwrap(), b.get(k).unwrap());
    assert_eq!((ea.start, ea.step), (eb.start, eb.step));
    assert!(text.contains("step_deg = 10.0"), "{text}");
}

/// A 15° table whose knots sit at 6° + k·15° on joint 3: the phase search finds a grid whose
/// knots lie within a sixteenth of the pitch (0.94°) of the truth's, and the held-out RMS
/// reaches the noise floor.
#[test]
fn a_table_at_a_phase_is_found_near_its_phase() {
    let nominal = er20();
    let noise = 0.02;
    let data = table_data(&nominal, 2, 15.0, 6.0, 2e-4, noise, 400, 12);
    let d = diagnose(&nominal, true, &[], &data, &Config::default()).unwrap();
    let labels: Vec<String> = d.found.iter().map(|f| f.candidate.label()).collect();
    assert_eq!(d.found.len(), 1, "{labels:?}");
    let c = d.found[0].candidate;
    assert_eq!(c.joint, 2, "{labels:?}");
    let (start, step, _) = table_of(&c);
    // The pitch, or half of it (which holds every knot of the truth).
    assert!(
        (step - 15.0).abs() < 1e-9 || (step - 7.5).abs() < 1e-9,
        "{labels:?}"
    );
    let off = (start - 6.0).rem_euclid(step);
    assert!(off.min(step - off) <= 15.0 / 16.0 + 1e-9, "{labels:?}");
    let floor = 3f64.sqrt() * noise;
    assert!(
        d.final_validation_rms_mm <= 1.25 * floor,
        "{} vs {floor}",
        d.final_validation_rms_mm
    );
}
