//! `kinecal plan --constraints …`: reads the robot file and the working configurations, plans
//! the session ([`crate::constraints::plan`], where the method is described), writes the
//! constraint file to measure and returns the predicted accuracy (and, with `--accuracy-mm`,
//! how many times the groups it takes).

use super::plan::Args;
use crate::constraints::plan::{plan, Request, SessionDesign};
use crate::constraints::report::{AccuracyNeed, ConstraintPlanReport};
use crate::constraints::simulate::SessionPlan;
use crate::formats::robot_file::RobotFile;
use crate::plan::design::{parse_configuration, CriterionArg};
use crate::with_joints;

/// Most times the groups `--accuracy-mm` may ask for.
const MOST_REPEATS: usize = 50;

/// Runs `plan --constraints`.
pub fn run(args: &Args) -> anyhow::Result<ConstraintPlanReport> {
    crate::output::atomic::refuse_overwriting_inputs(
        "--out",
        &args.out,
        &[("robot", args.robot.as_path())],
    )?;
    if !(1..=50).contains(&args.candidates) {
        crate::refuse!(
            "--candidates {}: give 1 to 50 candidate rows per row",
            args.candidates
        );
    }
    crate::check_positive("--noise-mm", args.noise_mm, 1e3)?;
    if let Some(a) = args.accuracy_mm {
        crate::check_positive("--accuracy-mm", a, 1e3)?;
    }
    if args.criterion == CriterionArg::Kpi && args.work.is_empty() {
        crate::refuse!("--criterion kpi needs the working configurations: give --work q1,…,qN");
    }
    let file = RobotFile::load(&args.robot)?;
    with_joints!(file.joint_count(), N => run_with_joints::<N>(args, &file))
}

fn run_with_joints<const N: usize>(
    args: &Args,
    file: &RobotFile,
) -> anyhow::Result<ConstraintPlanReport> {
    let nominal = file
        .to_robot::<N>()
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.robot.display()))?;
    let session = args.constraints.unwrap_or_default();
    let work = args
        .work
        .iter()
        .map(|w| parse_configuration::<N>(w))
        .collect::<anyhow::Result<Vec<_>>>()?;
    for (q, text) in work.iter().zip(&args.work) {
        if let Some(w) = crate::plan::design::radians_warning(q, text) {
            eprintln!("kinecal plan: {w}");
        }
    }
    let request = |session: SessionPlan| Request {
        session,
        criterion: args.criterion,
        pool: args.candidates,
        seed: args.seed,
        sigma_mm: args.noise_mm,
        work: &work,
    };
    let design = plan(file, &nominal, &request(session))?;
    let (free, k) = (session.free_equations(), design.estimated.len());
    if !design.planned_tool_mm.is_finite() || free <= k {
        let shapes = session.sockets.0 + session.planes.0 > 0;
        crate::refuse!(
            "plan --constraints: {} rows give {free} equations{}, which cannot determine the {k} \
             parameters such a session could estimate (identify refuses it): plan more groups or \
             rows (a socket's row or a point adds 3 equations, a plane's row or a distance 1)",
            design.rows(),
            if shapes {
                " once the sockets' centres and the planes have taken theirs"
            } else {
                ""
            }
        );
    }
    if free < k + crate::constraints::fit::MIN_SPARE as usize {
        eprintln!(
            "warning: plan --constraints: {free} equations for {k} parameters leave {} to spare: \
             identify will fit such a session nearly exactly whatever the robot; plan more groups \
             or rows",
            free - k
        );
    }
    crate::output::atomic::write_atomic(&args.out, design.csv(args.noise_mm).as_bytes())
        .map_err(|e| anyhow::anyhow!("{}: cannot write: {e}", args.out.display()))?;
    let need = match args.accuracy_mm {
        Some(target) => Some(accuracy_need(
            file, &nominal, &design, session, target, &request,
        )?),
        None => None,
    };
    Ok(ConstraintPlanReport::of(
        &design,
        session,
        args.criterion.name(),
        &args.out.display().to_string(),
        need,
        |p| p.name(&nominal).to_string(),
    ))
}

/// How many times the groups of `session` a tool-point σ of `target` mm takes: the noise
/// share falls as one over the root of the repeats, so `m = ⌈(σ/target)²⌉` is tried and
/// planned, and raised until the plan predicts `target` (at most [`MOST_REPEATS`]).
fn accuracy_need<'a, const N: usize>(
    file: &RobotFile,
    nominal: &crate::HostRobot<N>,
    design: &SessionDesign<N>,
    session: SessionPlan,
    target: f64,
    request: &dyn Fn(SessionPlan) -> Request<'a, N>,
) -> anyhow::Result<AccuracyNeed> {
    let mut predicted = design.planned_tool_mm;
    let mut m = 1usize;
    let mut rows = design.rows();
    while predicted > target && m < MOST_REPEATS {
        let next = ((m as f64) * (predicted / target).powi(2)).ceil() as usize;
        m = next.clamp(m + 1, MOST_REPEATS);
        let d = plan(file, nominal, &request(session.times(m)))?;
        predicted = d.planned_tool_mm;
        rows = d.rows();
    }
    // The estimate may overshoot: one time fewer, if that reaches the target too.
    if m > 2 && predicted <= target {
        let fewer = m - 1;
        let d = plan(file, nominal, &request(session.times(fewer)))?;
        if d.planned_tool_mm <= target {
            (m, predicted, rows) = (fewer, d.planned_tool_mm, d.rows());
        }
    }
    Ok(AccuracyNeed {
        target_mm: target,
        reached: predicted <= target,
        times_the_groups: m,
        rows,
        predicted_tool_mm: predicted,
    })
}
