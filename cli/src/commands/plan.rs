//! `kinecal plan`: measurement pose selection (optimum experimental design, Jost et al. 2017):
//! reads the robot file, the scene and `--noise-from`, plans ([`crate::plan::request`], where
//! the method is described) and writes the poses.

use super::Spinner;
use crate::formats::cell_file::SceneFile;
use crate::formats::robot_file::RobotFile;
use crate::plan::design::{limits_only_scene, poses_csv, CriterionArg};
use crate::plan::request::{self, plan_request, Request};
use crate::reports::plan::PlanReport;
use crate::with_joints;
use crate::HostRobot;
use anyhow::anyhow;
use std::path::PathBuf;

/// Arguments of `kinecal plan` (docs/formats.md for the scene file).
#[derive(clap::Args, Debug)]
pub struct Args {
    /// Robot description (TOML); its `[base]`, if any, is not used (plans are in the base frame).
    #[arg(long)]
    pub robot: PathBuf,
    /// Measurement cell (TOML, robot base frame): tracker, floor, link capsules, obstacles.
    /// Without it, every configuration within the robot's joint limits is taken as measurable
    /// (no incidence limit, nothing to collide with).
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Design for these parameters only, the others held at the robot file's values (a quick
    /// re-calibration): names as identify prints them (theta2, base.x, tool.z, …) or the
    /// groups base, tool, geometry, theta. Repeatable, or comma-separated.
    #[arg(long, value_delimiter = ',', num_args = 1..)]
    pub estimate: Vec<String>,
    /// Number of measurement poses to plan.
    #[arg(long, required_unless_present = "constraints")]
    pub poses: Option<usize>,
    /// Design criterion.
    #[arg(long, value_enum)]
    pub criterion: CriterionArg,
    /// A working configuration q1,…,qN in degrees (repeatable; negative values are fine,
    /// e.g. `--work=-20,-80,120,10,-30,45`).
    #[arg(
        long = "work",
        value_name = "Q1,…,QN",
        allow_hyphen_values = true,
        required_unless_present = "constraints"
    )]
    pub work: Vec<String>,
    /// Random seed (pool and random designs).
    #[arg(long, default_value_t = request::DEFAULT_SEED)]
    pub seed: u64,
    /// Measurement noise, standard deviation per axis (mm), for the predicted covariances.
    #[arg(long, default_value_t = request::DEFAULT_NOISE_MM)]
    pub noise_mm: f64,
    /// Take the noise from a tracker file's stated uncertainties instead: the RMS of its
    /// `sx_mm`, `sy_mm`, `sz_mm` over all rows and coordinates (docs/formats.md).
    #[arg(long, value_name = "D.csv", conflicts_with = "noise_mm")]
    pub noise_from: Option<PathBuf>,
    /// How to read the `--noise-from` file (units, another layout).
    #[command(flatten)]
    pub units: crate::formats::units::UnitArgs,
    /// Output CSV of the planned poses (q1…qN in degrees, plus incidence_deg, clearance_mm).
    #[arg(long)]
    pub out: PathBuf,
    /// Number of feasible candidate poses to select from.
    #[arg(long, default_value_t = request::DEFAULT_POOL)]
    pub pool: usize,
    /// Ignore collisions, floor and beam (joint limits and incidence only), as the paper's
    /// designs "without collision avoidance".
    #[arg(long)]
    pub no_collisions: bool,
    /// Most Fedorov exchange passes.
    #[arg(long, default_value_t = request::DEFAULT_PASSES)]
    pub passes: u32,
    /// Skip the local refinement (poses near the selected ones added to the pool, then more
    /// exchange passes).
    #[arg(long)]
    pub no_refine: bool,
    /// Plan a session without a tracker instead: socket:GROUPSxROWS, plane:GROUPSxROWS,
    /// distance:PAIRS, point:ROWS, comma-separated (as `simulate --constraints`); --out gets
    /// the constraint file to measure (lengths and tracker coordinates left empty).
    #[arg(long, value_name = "KIND:COUNT,…", conflicts_with_all = ["scene", "noise_from", "estimate"])]
    pub constraints: Option<crate::constraints::simulate::SessionPlan>,
    /// A constraint plan's candidate rows per row it needs (the pool it selects from).
    #[arg(long, default_value_t = 4, requires = "constraints")]
    pub candidates: usize,
    /// The tool-point accuracy (mm) a constraint session should reach: the report says how
    /// many times its groups that takes.
    #[arg(long, requires = "constraints")]
    pub accuracy_mm: Option<f64>,
}

impl Args {
    /// The plan these arguments ask for (but the files: robot, scene, `--noise-from`, `--out`).
    pub fn request(&self) -> Request {
        Request {
            estimate: self.estimate.clone(),
            poses: self.poses.unwrap_or(0),
            criterion: self.criterion,
            work: self.work.clone(),
            seed: self.seed,
            noise_mm: self.noise_mm,
            pool: self.pool,
            collisions: !self.no_collisions,
            passes: self.passes,
            refine: !self.no_refine,
        }
    }
}

fn plan_with_joints<const N: usize>(args: &Args, file: &RobotFile) -> anyhow::Result<PlanReport> {
    let robot = file
        .to_robot::<N>()
        .map_err(|e| anyhow!("{}: {e}", args.robot.display()))?;
    let scene = match &args.scene {
        Some(path) => SceneFile::load(path, N)?.to_scene()?,
        None => limits_only_scene()?,
    };
    let req = args.request();
    let noise = |robot: &HostRobot<N>| match &args.noise_from {
        Some(p) => {
            crate::plan::request::stated_noise_mm::<N>(p, &args.units, robot, file.base_known())
        }
        None => Ok(args.noise_mm),
    };
    // A spinner while the design runs: the work is bounded by --poses, --pool and --passes
    // (checked first), but a large design takes minutes.
    let p = plan_request(&robot, &scene, &req, noise, &mut Spinner::new("plan"))?;
    crate::output::atomic::write_atomic(&args.out, poses_csv(&p.poses).as_bytes())
        .map_err(|e| anyhow!("{}: cannot write: {e}", args.out.display()))?;
    Ok(PlanReport::of(&p, &req, &args.out.display().to_string()))
}

/// Runs the subcommand: writes the planned poses and returns their predicted accuracy (a
/// constraint session's plan is `super::constraint_plan`'s).
pub fn run(args: &Args) -> anyhow::Result<PlanReport> {
    crate::output::atomic::refuse_overwriting_inputs(
        "--out",
        &args.out,
        &[
            Some(("robot", args.robot.as_path())),
            args.scene.as_deref().map(|s| ("scene", s)),
        ]
        .into_iter()
        .flatten()
        .collect::<Vec<_>>(),
    )?;
    args.request().check()?;
    let file = RobotFile::load(&args.robot)?;
    with_joints!(file.joint_count(), N => plan_with_joints::<N>(args, &file))
}
