//! `kinecal simulate`: measurement data from a robot with known errors (docs/formats.md): the
//! flags become a [`Request`] and a [`Session`], [`crate::application::simulate`] does the work,
//! this module writes the files.

use crate::application::simulate::{simulate, Session};
use crate::formats::measurements;
use crate::formats::robot_file::RobotFile;
use crate::reports::path_text;
use crate::reports::simulate::SimulateReport;
use crate::simulation::request::Request;
use crate::with_joints;
use anyhow::anyhow;
use std::path::PathBuf;

/// Arguments of `kinecal simulate` (docs/formats.md).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Nominal robot (TOML); without `[base]` the base is the measurement frame (identity).
    #[arg(long)]
    pub robot: PathBuf,
    /// Number of poses.
    #[arg(long, default_value_t = Request::default().poses)]
    pub poses: usize,
    /// Measurement noise, standard deviation per axis (mm).
    #[arg(long, default_value_t = Request::default().noise_mm)]
    pub noise_mm: f64,
    /// Random seed: same seed, same files.
    #[arg(long, default_value_t = Request::default().seed)]
    pub seed: u64,
    /// Give the true robot uniform geometric errors (alpha/theta ±0.1°, a/d ±0.8 mm, tool ±0.5 mm).
    #[arg(long)]
    pub geom_errors: bool,
    /// Joint correction of the true robot, KIND:JOINT:V1[,V2…][:ORDER] (repeatable); units:
    /// scale 1, cyclic rad, compliance rad/m, axis-tilt rad, table knot values rad over the joint range.
    #[arg(
        long = "effect",
        value_name = "KIND:JOINT:VALUES[:ORDER]",
        allow_hyphen_values = true
    )]
    pub effects: Vec<String>,
    /// The arm warms (or cools) linearly from A to B °C over the poses, in their order: each
    /// row gets a `temp_c` column, and a `--effect thermal-expansion:0:C` (C per kelvin) is
    /// referred to the mean temperature.
    #[arg(long, value_name = "A:B", value_parser = crate::simulation::request::parse_temperature, allow_hyphen_values = true)]
    pub temperature: Option<(f64, f64)>,
    /// The poses are taken evenly over this many seconds, in their order: each row gets a
    /// `t_s` column (from 0), and a `--effect base-drift:0:VX,VY,VZ` (the tracker drifting, mm
    /// per second) is referred to the mean time.
    #[arg(long, value_name = "SECONDS")]
    pub session_s: Option<f64>,
    /// Output measurement CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write the true model (robot TOML).
    #[arg(long)]
    pub truth: Option<PathBuf>,
    /// Instead of random poses, single-joint sweeps of these joints (1-based, e.g. 1,2,5,6) for
    /// `kinecal frames`; the CSV gets a `sweep` column.
    #[arg(long, value_delimiter = ',')]
    pub sweeps: Vec<usize>,
    /// Points per sweep.
    #[arg(long, default_value_t = Request::default().sweep_points)]
    pub sweep_points: usize,
    /// Angular span of each sweep (degrees), shortened to the joint's limits. Short arcs fix
    /// the circle's centre poorly: 360° for joints 1 and 2 gives the base within ~0.03 mm.
    #[arg(long, default_value_t = Request::default().sweep_span_deg)]
    pub sweep_span_deg: f64,
    /// Joint readings (degrees) the sweeps start from, q1,…,qN (default: a bent pose).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub rest: Vec<f64>,
    /// Instead of tracker points, a constraint session (no tracker): socket:GROUPSxROWS,
    /// plane:GROUPSxROWS, distance:PAIRS, point:ROWS, comma-separated (e.g.
    /// socket:4x10,plane:3x15,distance:30); --noise-mm is each contact's or length's σ.
    #[arg(long, value_name = "KIND:COUNT,…")]
    pub constraints: Option<crate::constraints::simulate::SessionPlan>,
    /// Instead of tracker points, the session `plan --constraints` planned, measured on the
    /// true robot: each row reached from its planned readings (a socket where the nominal
    /// robot puts its group, a plane through its points), lengths and tracker points the
    /// truth's; --noise-mm is each contact's or length's σ.
    #[arg(long, value_name = "PLAN.csv", conflicts_with = "constraints")]
    pub plan: Option<PathBuf>,
}

impl Args {
    /// The simulation these arguments ask for.
    pub fn request(&self) -> Request {
        Request {
            poses: self.poses,
            noise_mm: self.noise_mm,
            seed: self.seed,
            geom_errors: self.geom_errors,
            effects: self.effects.clone(),
            temperature: self.temperature,
            session_s: self.session_s,
            sweeps: self.sweeps.clone(),
            sweep_points: self.sweep_points,
            sweep_span_deg: self.sweep_span_deg,
            rest: self.rest.clone(),
        }
    }
}

fn simulate_with_joints<const N: usize>(
    args: &Args,
    file: &RobotFile,
) -> anyhow::Result<SimulateReport> {
    let nominal = file
        .to_robot::<N>()
        .map_err(|e| anyhow!("{}: {e}", args.robot.display()))?;
    let session = match (&args.plan, &args.constraints) {
        (Some(path), _) => {
            let origin = path.display().to_string();
            let text = std::fs::read_to_string(path)
                .map_err(|e| crate::refused(crate::formats::cannot_read(&origin, &e)))?;
            Session::Planned { text, origin }
        }
        (None, Some(plan)) => Session::Constraints(*plan),
        (None, None) => Session::Tracker,
    };
    let req = args.request();
    let robot = args.robot.display().to_string();
    let done = simulate((file, &nominal, &robot), &req, &session, &mut crate::Stderr)?;
    match &done.session_csv {
        Some(csv) => crate::output::atomic::write_atomic(&args.out, csv.as_bytes())
            .map_err(|e| anyhow!("{}: cannot write: {e}", args.out.display()))?,
        None => measurements::write(&args.out, &done.sim.data)?,
    }
    if let Some(t) = &args.truth {
        done.sim.truth_file.save(t)?;
    }
    let (out, truth) = (path_text(&args.out), args.truth.as_deref().map(path_text));
    let (sim, base, rows) = (&done.sim, file.base_known(), done.rows);
    let written = (out.as_str(), truth.as_deref());
    Ok(SimulateReport::of(sim, &req, base, rows, written))
}

/// Runs the subcommand: writes the files and returns what was written.
pub fn run(args: &Args) -> anyhow::Result<SimulateReport> {
    use crate::output::atomic::refuse_overwriting_inputs as refuse_over;
    refuse_over("--out", &args.out, &[("robot", &args.robot)])?;
    let (robot, out) = (args.robot.as_path(), args.out.as_path());
    if let Some(t) = &args.truth {
        refuse_over("--truth", t, &[("robot", robot), ("--out", out)])?;
    }
    let file = RobotFile::load(&args.robot)?;
    args.request().checked(file.joint_count())?;
    with_joints!(file.joint_count(), N => simulate_with_joints::<N>(args, &file))
}
