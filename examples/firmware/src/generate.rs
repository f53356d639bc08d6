//! Host side of the firmware example: makes the measurement file the firmware streams in and
//! computes, in `f64`, every value the firmware checks itself against.
//!
//! ```text
//! cargo run -p kinecal-firmware            # rewrite data/measurements.csv, src/reference.rs
//!                                          # and ../firmware-c/reference.h
//! cargo run -p kinecal-firmware -- --check # exit 1 if any of them is out of date
//! ```
//!
//! Rerun it whenever the library's algorithms or the scenario change; the firmware then checks
//! its `f32` results against the new values on the next `cargo run --target thumbv7em-…`.

use crate::scenario::{self, ID_POSES, N, P, SWARM, TICKS, VAL_POSES};
use kinecal::compensate::{Target, Tracker};
use kinecal::identify::fitness::PositionFitness;
use kinecal::identify::lm::{constraint_scratch_len, rms_error, FixedLm, Levenberg, LmConfig};
use kinecal::identify::pso::Pso;
use kinecal::io::constraint::ConstraintRow;
use kinecal::io::csv::CsvReader;
use kinecal::model::param::{apply_delta, value};
use kinecal::{ForwardKinematics, Measurement, Robot};
use nalgebra::Vector3;
use rand::{RngExt, SeedableRng};
use rand_distr::{Distribution, Normal};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

const SEED: u64 = 20_261_122;
/// Tracker noise per axis, mm.
const SIGMA_MM: f64 = 0.01;

pub fn main() -> ExitCode {
    let check = std::env::args().any(|a| a == "--check");
    let dir = PathBuf::from(env!("CARGO_MANIFEST_DIR"));
    let (csv, truth) = measurements();
    let (reference, reference_h) = reference(csv.as_bytes(), &truth);
    let files: [(PathBuf, &str); 3] = [
        (dir.join("data/measurements.csv"), &csv),
        (dir.join("src/reference.rs"), &reference),
        // The C firmware's copy of the same values (examples/firmware-c).
        (dir.join("../firmware-c/reference.h"), &reference_h),
    ];
    let mut stale = false;
    for (path, text) in files.iter() {
        let old = std::fs::read_to_string(path).unwrap_or_default();
        if old == *text {
            println!("up to date: {}", path.display());
        } else if check {
            println!(
                "out of date: {} (regenerate with `cargo run -p kinecal-firmware`)",
                path.display()
            );
            stale = true;
        } else {
            write(path, text);
            println!("wrote {}", path.display());
        }
    }
    if stale {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}

fn write(path: &Path, text: &str) {
    if let Some(d) = path.parent() {
        if let Err(e) = std::fs::create_dir_all(d) {
            panic!("cannot create {}: {e}", d.display());
        }
    }
    if let Err(e) = std::fs::write(path, text) {
        panic!("cannot write {}: {e}", path.display());
    }
}

/// The "true" robot: the nominal one with small errors in all 24 parameters.
fn truth(rng: &mut Xoshiro256PlusPlus) -> Robot<f64, N> {
    let mut t = scenario::nominal::<f64>();
    let set = scenario::params();
    let delta: Vec<f64> = set
        .as_slice()
        .iter()
        .map(|p| {
            if p.is_length() {
                rng.random_range(-0.8..0.8)
            } else {
                rng.random_range(-0.1f64..0.1).to_radians()
            }
        })
        .collect();
    apply_delta(&mut t, &set, &delta).expect("24 finite deltas");
    t
}

/// CSV (docs/formats.md) of the true robot seen by a tracker with noise: 50 identification
/// poses (`set` 0) then 20 held-out ones (`set` 1), with a carried-along `temp_c` column.
fn measurements() -> (String, Robot<f64, N>) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(SEED);
    let truth = truth(&mut rng);
    let noise = Normal::new(0.0, SIGMA_MM).expect("finite sigma");
    let mut fk = ForwardKinematics::new();
    let mut s = String::new();
    s.push_str("# kinecal firmware example: ER20-C10-like arm, 10 um tracker noise (generated, see src/generate.rs)\n");
    s.push_str("q1,q2,q3,q4,q5,q6,x,y,z,set,temp_c\n");
    for i in 0..ID_POSES + VAL_POSES {
        let q_deg: [f64; N] = std::array::from_fn(|_| rng.random_range(-150.0f64..150.0));
        let q_deg = q_deg.map(|v| (v * 1e4).round() / 1e4);
        let p = fk.compute(&truth, &q_deg.map(f64::to_radians));
        let m = p + Vector3::new(
            noise.sample(&mut rng),
            noise.sample(&mut rng),
            noise.sample(&mut rng),
        );
        for q in q_deg {
            let _ = write!(s, "{q:.4},");
        }
        let set = usize::from(i >= ID_POSES);
        let temp = 21.0 + 0.05 * i as f64;
        let _ = writeln!(s, "{:.4},{:.4},{:.4},{set},{temp:.2}", m.x, m.y, m.z);
    }
    (s, truth)
}

/// The socket session's joint readings (stage 3d, `scenario::SOCKETS`): socket `k` is the true
/// tool point at identification pose `k`; each of its rows starts from that pose with the
/// wrist turned (joints 4 to 6 by up to ±40°, joints 2 and 3 by up to ±8°) and takes
/// minimum-norm Newton steps of all joints until the true tool point is at the socket again,
/// give or take the contact's noise (`scenario::SOCKET_SIGMA_MM` per axis).
fn socket_readings(truth: &Robot<f64, N>, id: &[Measurement<f64, N>]) -> Vec<[f64; N]> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(SEED + 3);
    let mut fk = ForwardKinematics::<f64, N>::new();
    let mut out = Vec::new();
    for m in &id[..scenario::SOCKETS] {
        let centre = fk.compute(truth, &m.q);
        let noise = Normal::new(0.0, scenario::SOCKET_SIGMA_MM).expect("finite sigma");
        for r in 0..scenario::SOCKET_ROWS {
            let contact = centre
                + Vector3::new(
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                    noise.sample(&mut rng),
                );
            let mut q = m.q;
            if r > 0 {
                for (j, v) in q.iter_mut().enumerate() {
                    let deg: f64 = match j {
                        1 | 2 => 8.0,
                        3..=5 => 40.0,
                        _ => 0.0,
                    };
                    *v += rng.random_range(-deg..=deg).to_radians();
                }
            }
            let mut converged = false;
            for _ in 0..50 {
                let e = contact - fk.compute(truth, &q);
                if e.norm() < 1e-10 {
                    converged = true;
                    break;
                }
                let cols: [Vector3<f64>; N] = std::array::from_fn(|j| fk.reading_column(truth, j));
                let jac = nalgebra::SMatrix::<f64, 3, N>::from_columns(&cols);
                let jjt = jac * jac.transpose();
                let step = jac.transpose() * jjt.try_inverse().expect("a reachable socket") * e;
                for (v, d) in q.iter_mut().zip(step.iter()) {
                    *v += d;
                }
            }
            assert!(converged, "socket rows: Newton steps reach the socket");
            out.push(q);
        }
    }
    out
}

/// The f64 constraint run of stage 3d from the nominal robot: its end, values of
/// `scenario::params()` and which of them it held.
fn socket_fit(
    readings: &[[f64; N]],
) -> (kinecal::identify::lm::LmProgress<f64>, Vec<f64>, Vec<bool>) {
    let rows: Vec<ConstraintRow<f64, N>> = readings
        .iter()
        .map(|q| ConstraintRow::new(*q, scenario::SOCKET_SIGMA_MM))
        .collect();
    let set = scenario::params();
    let mut lm = Levenberg::<f64, N, kinecal::Inline<0>, _>::new(
        scenario::nominal(),
        FixedLm::<f64, P>::new(set.clone()),
        LmConfig::for_constraints(),
    )
    .expect("solver");
    let mut scratch = vec![0.0; constraint_scratch_len(P)];
    let progress = lm
        .run_constraints(&rows, &scenario::socket_groups(), &mut scratch)
        .expect("socket run");
    let values = set
        .iter()
        .map(|p| value(lm.robot(), *p).expect("a value"))
        .collect();
    let held = (0..P).map(|k| !lm.is_active(k)).collect();
    (progress, values, held)
}

/// Parses the CSV exactly as the firmware does (same reader, `f64`).
fn parse(bytes: &[u8]) -> (Vec<Measurement<f64, N>>, Vec<Measurement<f64, N>>, [f64; 2]) {
    let mut reader = CsvReader::<&[u8], N, 128, 4>::new(bytes).expect("header");
    let set_col = reader.extra_index("set").expect("set column");
    let temp_col = reader.extra_index("temp_c").expect("temp_c column");
    let (mut id, mut val) = (Vec::new(), Vec::new());
    let mut sums = [0.0; 2];
    while let Some(r) = reader.next_record() {
        let r = r.expect("record");
        sums[0] += r.q_deg.iter().sum::<f64>() + r.xyz_mm.iter().sum::<f64>();
        sums[1] += r.extra[temp_col];
        if r.extra[set_col] == 0.0 {
            id.push(r.measurement())
        } else {
            val.push(r.measurement())
        }
    }
    (id, val, sums)
}

/// `src/reference.rs` for the Rust firmware and `../firmware-c/reference.h` for the C one, from
/// the same values.
fn reference(csv: &[u8], truth: &Robot<f64, N>) -> (String, String) {
    let (id, val, sums) = parse(csv);
    assert_eq!((id.len(), val.len()), (ID_POSES, VAL_POSES));
    let nominal = scenario::nominal::<f64>();
    let mut fk = ForwardKinematics::<f64, N>::new();

    let nominal_fk: Vec<[f64; 3]> = id
        .iter()
        .take(4)
        .map(|m| fk.compute(&nominal, &m.q).into())
        .collect();
    let coupled = scenario::coupled::<f64>();
    let coupled_fk: Vec<[f64; 3]> = id
        .iter()
        .take(4)
        .map(|m| fk.compute(&coupled, &m.q).into())
        .collect();
    fk.compute(&nominal, &id[0].q);
    let set = scenario::params();
    let mut cols = [Vector3::zeros(); P];
    fk.identification_jacobian(&nominal, set.as_slice(), &mut cols)
        .expect("24 columns");
    let jac: Vec<[f64; 3]> = cols.iter().map(|c| (*c).into()).collect();

    let mut lm = Levenberg::<f64, N, kinecal::Inline<0>, _>::new(
        nominal.clone(),
        FixedLm::<f64, P>::new(set),
        scenario::lm_config(),
    )
    .expect("solver");
    let progress = lm.run(&id).expect("LM runs");
    let model = lm.robot().clone();
    let predicted: Vec<[f64; 3]> = val
        .iter()
        .map(|m| fk.compute(&model, &m.q).into())
        .collect();

    // The small swarm, same seed and schedule as the firmware's (f32 runs diverge from f64
    // after a few iterations, so its result is reported beside the firmware's, not compared).
    let mut swarm = Pso::<f64, SWARM, P, { scenario::PSO_HISTORY }>::new(
        scenario::pso_config(),
        scenario::PSO_SEED,
    )
    .expect("swarm");
    let params = scenario::params();
    let mut fitness = PositionFitness::new(&nominal, &params, &id).expect("fitness");
    swarm.run(&mut fitness).expect("PSO runs");
    let nominal_cost = fitness.of_robot(&nominal);

    let net = scenario::net::<f64>();
    let net_out = net.forward(&scenario::net_input());

    // The servo loop's trajectory compensated with the f64 identified model.
    let mut tracker = Tracker::new(scenario::compensation());
    let mut commands = Vec::new();
    for k in 0..TICKS {
        let qn = scenario::nominal_joints::<f64>(k);
        fk.compute(&nominal, &qn);
        let target = Target::Pose(fk.flange_pose());
        let s = tracker
            .next(&model, &target, &qn)
            .expect("trajectory point compensates");
        commands.push(s.q);
    }
    // The probe's 6-D and multi-reflector run from the nominal probe, on
    // observations of its truth at the first identification poses.
    let truth6 = scenario::probe_truth::<f64>();
    let mut obs = Vec::new();
    scenario::pose6d_observations(&truth6, |i| id[i].q, |m| obs.push(m));
    assert_eq!(
        obs.len(),
        VAL_POSES,
        "the 6-D run fills the held-out poses' storage"
    );
    let set6 = scenario::pose6d_params();
    let mut lm6 = Levenberg::<f64, N, kinecal::Inline<0>, _>::new(
        scenario::nominal_probe(),
        FixedLm::<f64, P>::new(set6.clone()),
        scenario::lm_config(),
    )
    .expect("solver");
    let progress6 = lm6.run(&obs).expect("6-D LM runs");
    let values6: Vec<f64> = set6
        .iter()
        .map(|p| value(lm6.robot(), *p).expect("a value"))
        .collect();
    for (p, v) in set6.iter().zip(&values6) {
        let want = value(&truth6, *p).expect("a value");
        assert!(
            (v - want).abs() < 1e-6,
            "6-D run: {p:?} = {v}, truth {want}"
        );
    }

    // The re-mastering (the firmware's stage 3c): theta2 and theta3 from the true rows less
    // REMASTER_DEG, on the first REMASTER_POSES identification poses. What the f64 solve is left
    // from the truth is the tracker noise's share, which the firmware's tolerance must exceed.
    let remastered = scenario::remaster_params();
    let mut before = truth.clone();
    apply_delta(
        &mut before,
        &remastered,
        &[-scenario::REMASTER_DEG.to_radians(); 2],
    )
    .expect("two finite deltas");
    let mut lm_r = Levenberg::<f64, N, kinecal::Inline<0>, _>::new(
        before,
        FixedLm::<f64, P>::new(remastered.clone()),
        scenario::lm_config(),
    )
    .expect("solver");
    lm_r.run(&id[..scenario::REMASTER_POSES])
        .expect("re-mastering LM runs");
    let remaster_noise_floor = remastered
        .iter()
        .map(|p| {
            (value(lm_r.robot(), *p).expect("a value") - value(truth, *p).expect("a value")).abs()
        })
        .fold(0.0, f64::max);
    assert!(
        remaster_noise_floor <= 0.5 * scenario::REMASTER_TOLERANCE_RAD,
        "re-mastering: the f64 solve is {remaster_noise_floor} rad from the truth, more than half \
         the firmware's tolerance"
    );

    // The socket session (stage 3d): readings at the true robot's sockets, and the f64 run.
    let sockets = socket_readings(truth, &id);
    let (socket_progress, socket_values, socket_held) = socket_fit(&sockets);
    assert!(
        socket_progress.stopped.is_some() && socket_held.iter().filter(|h| **h).count() >= 5,
        "socket run: {socket_progress:?}, held {socket_held:?}"
    );

    let rows: Vec<[f64; 4]> = truth
        .joints()
        .iter()
        .map(|j| [j.alpha, j.a, j.theta, j.d])
        .collect();

    let mut o = String::new();
    o.push_str("//! Values the firmware checks itself against, computed on the host in f64.\n");
    o.push_str(
        "//! Generated by `cargo run -p kinecal-firmware` (src/generate.rs): do not edit.\n\n",
    );
    let _ = writeln!(
        o,
        "/// Sum of all joint readings (deg) and coordinates (mm) in the file; sum of `temp_c`."
    );
    let _ = writeln!(o, "pub const CSV_SUMS: [f64; 2] = {:?};", sums);
    let _ = writeln!(
        o,
        "/// Nominal forward kinematics at the first identification poses, mm."
    );
    let _ = writeln!(
        o,
        "pub const NOMINAL_FK: [[f64; 3]; 4] = {};",
        arr3(&nominal_fk)
    );
    let _ = writeln!(
        o,
        "/// The same poses' readings on the coupled arm (q3 = J3 + J2), mm."
    );
    let _ = writeln!(
        o,
        "pub const COUPLED_FK: [[f64; 3]; 4] = {};",
        arr3(&coupled_fk)
    );
    let _ = writeln!(
        o,
        "/// RMS error of the nominal model on the identification poses, mm."
    );
    let _ = writeln!(
        o,
        "pub const NOMINAL_RMS_MM: f64 = {:?};",
        rms_error(&nominal, &id)
    );
    let _ = writeln!(
        o,
        "/// Identification Jacobian of the 24 parameters, nominal model, first pose."
    );
    let _ = writeln!(o, "pub const JACOBIAN: [[f64; 3]; {P}] = {};", arr3(&jac));
    let _ = writeln!(o, "/// LM from the nominal model: iterations, RMS on the identification and held-out poses (mm).");
    let _ = writeln!(o, "pub const LM_ITERATIONS: u32 = {};", progress.iteration);
    let _ = writeln!(
        o,
        "pub const LM_ID_RMS_MM: f64 = {:?};",
        rms_error(&model, &id)
    );
    let _ = writeln!(
        o,
        "pub const LM_VAL_RMS_MM: f64 = {:?};",
        rms_error(&model, &val)
    );
    let _ = writeln!(
        o,
        "/// The identified model's prediction at the held-out poses, mm."
    );
    let _ = writeln!(
        o,
        "pub const LM_VAL_PREDICTED: [[f64; 3]; {VAL_POSES}] = {};",
        arr3(&predicted)
    );
    let _ = writeln!(
        o,
        "/// PSO cost (sum of squared errors, mm²) of the nominal model and the swarm's best."
    );
    let _ = writeln!(o, "pub const NOMINAL_COST_MM2: f64 = {:?};", nominal_cost);
    let _ = writeln!(
        o,
        "pub const PSO_BEST_MM2: f64 = {:?};",
        swarm.best_fitness()
    );
    let _ = writeln!(
        o,
        "/// Output of the seeded, untrained BPNN at `scenario::net_input()`."
    );
    let _ = writeln!(o, "pub const NET_OUTPUT: [f64; {P}] = {:?};", net_out);
    let _ = writeln!(o, "/// The simulated robot's true rows (alpha rad, a mm, theta rad, d mm); tool and base nominal.");
    let _ = writeln!(o, "pub const TRUE_ROWS: [[f64; 4]; {N}] = {};", arrn(&rows));
    let _ = writeln!(
        o,
        "/// Joint commands (rad) of the compensated trajectory, f64 identified model."
    );
    let _ = writeln!(
        o,
        "pub const COMMANDS: [[f64; {N}]; {TICKS}] = {};",
        arrn(&commands)
    );

    let _ = writeln!(
        o,
        "/// The probe's 6-D run: iterations, identified values of `scenario::pose6d_params()` (rad, mm)."
    );
    let _ = writeln!(
        o,
        "pub const POSE6D_ITERATIONS: u32 = {};",
        progress6.iteration
    );
    let _ = writeln!(o, "pub const POSE6D_VALUES: [f64; {P}] = {:?};", values6);
    let a = lm6.robot().tool_axes();
    let _ = writeln!(
        o,
        "/// The identified probe frame's axes (x, y, z) in the flange frame."
    );
    let _ = writeln!(
        o,
        "pub const POSE6D_AXES: [[f64; 3]; 3] = {};",
        arr3(&[a.x.into(), a.y.into(), a.z.into()])
    );

    let _ = writeln!(
        o,
        "/// Stage 3d: the socket session's joint readings (rad), the f64 run's iterations, its \
         values of `scenario::params()` (rad, mm) and which of them it held."
    );
    let _ = writeln!(
        o,
        "pub const SOCKET_Q: [[f64; {N}]; {}] = {};",
        sockets.len(),
        arrn(&sockets)
    );
    let _ = writeln!(
        o,
        "pub const SOCKET_ITERATIONS: u32 = {};",
        socket_progress.iteration
    );
    let _ = writeln!(
        o,
        "pub const SOCKET_VALUES: [f64; {P}] = {:?};",
        socket_values
    );
    let _ = writeln!(o, "pub const SOCKET_HELD: [bool; {P}] = {:?};", socket_held);

    let rms = [
        rms_error(&nominal, &id),
        rms_error(&model, &id),
        rms_error(&model, &val),
    ];
    let h = reference_h(&C {
        sums,
        nominal_fk: &nominal_fk,
        coupled_fk: &coupled_fk,
        jac: &jac,
        iterations: progress.iteration,
        rms,
        predicted: &predicted,
        rows: &rows,
        commands: &commands,
    });
    (o, h)
}

/// What `reference.h` holds beyond the scenario.
struct C<'a> {
    sums: [f64; 2],
    nominal_fk: &'a [[f64; 3]],
    coupled_fk: &'a [[f64; 3]],
    jac: &'a [[f64; 3]],
    iterations: u32,
    /// Nominal on the identification poses; identified on the identification and held-out.
    rms: [f64; 3],
    predicted: &'a [[f64; 3]],
    rows: &'a [[f64; 4]],
    commands: &'a [[f64; N]],
}

/// The C firmware's reference values: the scenario as `float` (exactly the `f32` values the
/// Rust firmware builds: angles converted to radians in `f64`, then rounded), and the host's
/// `f64` results as the Rust firmware compares them (`float` tables where it stores `f32`).
/// Literals are the shortest decimals that read back exactly, so the C compiler rebuilds the
/// same bits.
fn reference_h(c: &C) -> String {
    let mut o = String::new();
    o.push_str("/* Values the C firmware checks itself against, computed on the host in f64: the same as\n");
    o.push_str("   examples/firmware/src/reference.rs, plus the scenario (examples/firmware/src/scenario.rs)\n");
    o.push_str("   as float. Generated by `cargo run -p kinecal-firmware` (examples/firmware/src/generate.rs):\n");
    o.push_str("   do not edit. */\n");
    o.push_str("#ifndef KINECAL_FIRMWARE_REFERENCE_H\n#define KINECAL_FIRMWARE_REFERENCE_H\n\n");
    let _ = writeln!(o, "#define REF_JOINTS {N}");
    let _ = writeln!(o, "#define REF_PARAMS {P}");
    let _ = writeln!(o, "#define REF_ID_POSES {ID_POSES}");
    let _ = writeln!(o, "#define REF_VAL_POSES {VAL_POSES}");
    let _ = writeln!(o, "#define REF_TICKS {TICKS}\n");
    let nominal = scenario::nominal::<f32>();
    let rows32: Vec<[f32; 4]> = nominal
        .joints()
        .iter()
        .map(|j| [j.alpha, j.a, j.theta, j.d])
        .collect();
    let limits32: Vec<[f32; 2]> = nominal
        .joints()
        .iter()
        .map(|j| [j.lower, j.upper])
        .collect();
    let t = nominal.tool();
    let joints: Vec<[f32; N]> = (0..TICKS).map(scenario::nominal_joints::<f32>).collect();
    o.push_str("/* The nominal model's rows (alpha rad, a mm, theta rad, d mm) and joint limits (rad). */\n");
    c_table(&mut o, "REF_NOMINAL_ROWS", &rows32);
    c_table(&mut o, "REF_LIMITS", &limits32);
    o.push_str("/* Tool point in the flange frame, mm. */\n");
    c_table(&mut o, "REF_TOOL_MM", &[[t.x, t.y, t.z]]);
    o.push_str("/* The controller's nominal joints (rad) at every servo tick. */\n");
    c_table(&mut o, "REF_NOMINAL_JOINTS", &joints);
    o.push_str("/* Sum of all joint readings (deg) and coordinates (mm) in the file; sum of `temp_c`. */\n");
    c_table(&mut o, "REF_CSV_SUMS", &[c.sums]);
    o.push_str("/* Nominal forward kinematics at the first identification poses, mm. */\n");
    c_table(&mut o, "REF_NOMINAL_FK", &f32s(c.nominal_fk));
    o.push_str("/* The same poses' readings on the coupled arm (q3 = J3 + J2), mm. */\n");
    c_table(&mut o, "REF_COUPLED_FK", &f32s(c.coupled_fk));
    o.push_str("/* Identification Jacobian of the 24 parameters, nominal model, first pose. */\n");
    c_table(&mut o, "REF_JACOBIAN", &f32s(c.jac));
    o.push_str("/* RMS error (mm): nominal model on the identification poses; LM's model on the\n   identification and held-out poses. LM iterations. */\n");
    let _ = writeln!(
        o,
        "static const double REF_NOMINAL_RMS_MM = {:?};",
        c.rms[0]
    );
    let _ = writeln!(o, "static const double REF_LM_ID_RMS_MM = {:?};", c.rms[1]);
    let _ = writeln!(o, "static const double REF_LM_VAL_RMS_MM = {:?};", c.rms[2]);
    let _ = writeln!(o, "#define REF_LM_ITERATIONS {}u", c.iterations);
    o.push_str("/* The identified model's prediction at the held-out poses, mm. */\n");
    c_table(&mut o, "REF_LM_VAL_PREDICTED", &f32s(c.predicted));
    o.push_str("/* The simulated robot's true rows (alpha rad, a mm, theta rad, d mm); tool and base nominal. */\n");
    c_table(&mut o, "REF_TRUE_ROWS", &f32s(c.rows));
    o.push_str("/* Joint commands (rad) of the compensated trajectory, f64 identified model. */\n");
    c_table(&mut o, "REF_COMMANDS", &f32s(c.commands));
    o.push_str("\n#endif /* KINECAL_FIRMWARE_REFERENCE_H */\n");
    o
}

fn f32s<const K: usize>(v: &[[f64; K]]) -> Vec<[f32; K]> {
    v.iter().map(|r| r.map(|x| x as f32)).collect()
}

/// A C number: `float` or `double`, with the shortest exact decimals.
trait CNum: Copy {
    const TYPE: &'static str;
    fn literal(self) -> String;
}

impl CNum for f32 {
    const TYPE: &'static str = "float";
    fn literal(self) -> String {
        format!("{self:?}f")
    }
}

impl CNum for f64 {
    const TYPE: &'static str = "double";
    fn literal(self) -> String {
        format!("{self:?}")
    }
}

/// `static const T NAME[rows][K]` (or `NAME[K]` for one row).
fn c_table<T: CNum, const K: usize>(o: &mut String, name: &str, v: &[[T; K]]) {
    if let [row] = v {
        let cells: Vec<String> = row.iter().map(|x| x.literal()).collect();
        let _ = writeln!(
            o,
            "static const {} {name}[{K}] = {{{}}};",
            T::TYPE,
            cells.join(", ")
        );
        return;
    }
    let _ = writeln!(o, "static const {} {name}[{}][{K}] = {{", T::TYPE, v.len());
    for r in v {
        let cells: Vec<String> = r.iter().map(|x| x.literal()).collect();
        let _ = writeln!(o, "    {{{}}},", cells.join(", "));
    }
    o.push_str("};\n");
}

fn arrn<const K: usize>(v: &[[f64; K]]) -> String {
    let mut s = String::from("[\n");
    for r in v {
        let cells: Vec<String> = r.iter().map(|x| format!("{x:?}")).collect();
        let _ = writeln!(s, "    [{}],", cells.join(", "));
    }
    s.push(']');
    s
}

fn arr3(v: &[[f64; 3]]) -> String {
    arrn(v)
}
