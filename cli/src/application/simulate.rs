//! `kinecal simulate` on a robot file already read: the true robot and the session measured
//! on it, as tracker points ([`crate::simulation::request`]), a constraint session
//! (`--constraints`) or the session `plan --constraints` planned (`--plan`). The command
//! module writes what this returns (docs/formats.md).

use crate::constraints::simulate::{read_plan, session, session_from_plan, SessionPlan};
use crate::formats::robot_file::RobotFile;
use crate::simulation::request::{simulate_request, Request, Simulated};
use crate::{HostRobot, Tell};

/// What the session's rows are.
#[derive(Clone, Debug)]
pub enum Session {
    /// Tracker points of random poses (or sweeps): [`Simulated::data`].
    Tracker,
    /// A constraint session of these kinds and counts.
    Constraints(SessionPlan),
    /// The planned constraint session in `text` (a `plan --constraints` CSV named `origin`),
    /// each row reached from its planned readings.
    Planned { text: String, origin: String },
}

/// A simulation and its session.
#[derive(Clone, Debug)]
pub struct Measured<const N: usize> {
    /// The true robot, its file and (for [`Session::Tracker`]) its tracker points.
    pub sim: Simulated<N>,
    /// The constraint session's CSV (`None`: the tracker points are the session).
    pub session_csv: Option<String>,
    /// Rows of the session.
    pub rows: usize,
}

/// Simulates `req` on the robot file `file` (model `nominal`, named `robot_origin`) and
/// measures `session` on the true robot; notes go to `tell`.
pub fn simulate<const N: usize>(
    (file, nominal, robot_origin): (&RobotFile, &HostRobot<N>, &str),
    req: &Request,
    session_kind: &Session,
    tell: &mut dyn Tell,
) -> anyhow::Result<Measured<N>> {
    let constraints = !matches!(session_kind, Session::Tracker);
    let reflectors = file.tool_names().len();
    if reflectors > 1 && constraints {
        crate::refuse!(
            "--constraints and --plan sessions touch with one point: give a robot file with one \
             [tool] (or one [[tools]] entry), not {reflectors} reflectors"
        );
    }
    if req.session_s.is_some() && constraints {
        crate::refuse!(
            "--session-s applies to tracker points: a constraint session has no tracker to drift"
        );
    }
    let sim = simulate_request(file, nominal, req, robot_origin, tell)?;
    let (session_csv, rows) = match session_kind {
        Session::Tracker => (None, sim.data.len()),
        Session::Planned { text, origin } => {
            let planned = read_plan::<N>(text, origin)?;
            let csv = session_from_plan(&sim.truth, nominal, &planned, req.noise_mm, req.seed)?;
            (Some(csv), planned.len())
        }
        Session::Constraints(plan) => {
            if !req.sweeps.is_empty() {
                crate::refuse!("--constraints does not combine with --sweeps");
            }
            let csv = session(&sim.truth, plan, req.noise_mm, req.seed, req.temperature)?;
            (Some(csv), plan.rows())
        }
    };
    Ok(Measured {
        sim,
        session_csv,
        rows,
    })
}
