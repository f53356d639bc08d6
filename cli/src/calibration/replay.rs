//! What `identify` did for a model it wrote, rebuilt from the robot file and the model: the
//! parameters it estimated, the start it fitted from and its prior. `kinecal report` draws its
//! 1-σ and tables from these; [`same_robot`] first refuses a model of another robot.

use crate::calibration::selection::{self, Selection};
use crate::formats::robot_file::RobotFile;
use crate::HostRobot;
use kinecal::model::param::ParamSet;
use kinecal::Param;
use std::path::Path;

/// The joint count of the robot file `robot`; refuses (exit 2) a model file `model` of a robot
/// with another count.
pub fn joint_count(robot: &Path, model: &Path) -> anyhow::Result<usize> {
    let n = RobotFile::load(robot)?.joint_count();
    let m = RobotFile::load(model)?.joint_count();
    if m != n {
        crate::refuse!(
            "{}: a model of a {m}-joint robot, but {} has {n} joints: give the model that \
             `kinecal identify --robot {} --out M.toml` wrote",
            model.display(),
            robot.display(),
            robot.display()
        );
    }
    Ok(n)
}

/// Refuses (exit 2) a model whose geometry is far from the robot file's: not an identified
/// model of this robot (other tool points, or a joint's parameter beyond
/// [`crate::calibration::arm_size::moved`]'s limits, which `identify` and `diagnose` do not
/// report as a calibration either).
pub fn same_robot<const N: usize>(
    robot: &HostRobot<N>,
    model: &HostRobot<N>,
    paths: (&Path, &Path),
) -> anyhow::Result<()> {
    let refuse = |what: String| -> anyhow::Result<()> {
        crate::refuse!(
            "{}: not an identified model of {} ({what}): give the model that `kinecal identify \
             --robot {} --out M.toml` wrote",
            paths.1.display(),
            paths.0.display(),
            paths.0.display()
        )
    };
    if robot.tool_point_count() != model.tool_point_count() {
        return refuse(format!(
            "{} tool points against {}",
            model.tool_point_count(),
            robot.tool_point_count()
        ));
    }
    if let Some(what) = crate::calibration::arm_size::moved(robot, model) {
        return refuse(what);
    }
    Ok(())
}

/// The note for a model equal to the robot file in every value (`None` otherwise): `validate`
/// then compares the robot file with itself, and only the recalibration verdict (the session
/// calibrated again, fold by fold) judges it; a calibrated model is what `--model` is for.
pub fn itself<const N: usize>(
    robot: &HostRobot<N>,
    model: &HostRobot<N>,
    paths: (&Path, &Path),
) -> Option<String> {
    (robot == model).then(|| {
        format!(
            "note: {} is {} itself (every value equal): the model and nominal figures are the \
             same, and only the recalibration verdict judges it; to judge a calibration, give \
             the model that `kinecal identify --robot {} --out M.toml` wrote",
            paths.1.display(),
            paths.0.display(),
            paths.0.display()
        )
    })
}

/// The parameters identify estimated for `model` (file `model_file`) from the robot file
/// `file`: its default set, the axis tilts (the file's and the model's), the model's effects,
/// the tool orientation from 6-D data (`six_d`), the further tool points, narrowed by the
/// selection given to identify; the first row held when it estimated the base
/// (`base_unknown`). Returns the tilted joints and the parameters.
pub fn estimated<const N: usize>(
    file: &RobotFile,
    (model_file, model): (&RobotFile, &HostRobot<N>),
    (six_d, base_unknown): (bool, bool),
    selected: &Selection<'_>,
) -> anyhow::Result<(Vec<usize>, Vec<Param>)> {
    let mut tilts = file.tilt_joints();
    tilts.extend(model_file.tilt_joints());
    tilts.extend((0..N).filter(|&j| model.joints()[j].beta != 0.0));
    tilts.sort_unstable();
    tilts.dedup();
    let mut estimated: Vec<Param> = ParamSet::<64>::full(N, base_unknown)
        .map_err(|e| anyhow::anyhow!("{e:?}"))?
        .as_slice()
        .to_vec();
    estimated.extend(tilts.iter().map(|&j| Param::Beta(j as u8)));
    estimated.extend((0..model.effects().values().len()).map(|k| Param::Effect(k as u16)));
    if six_d {
        estimated.extend([Param::ToolRx, Param::ToolRy, Param::ToolRz]);
    }
    for k in 1..model.tool_point_count() {
        estimated.extend((0..3).map(|a| Param::ToolPoint(k as u8, a)));
    }
    if base_unknown {
        selection::hold_first_row(&mut estimated);
    }
    selection::apply(&mut estimated, model, selected)?;
    Ok((tilts, estimated))
}

/// Identify's start for `model` (named `model_origin`): `nominal` placed as identify placed it,
/// with the effects identify added at zero; and the prior 1-σ of each of the `estimated`
/// parameters as identify set it (the file's `[prior]` and `prior`, none on a base placed by
/// registration, a tool orientation started from the data, effects added at zero).
pub fn start_and_prior<const N: usize>(
    (file, nominal): (&RobotFile, &HostRobot<N>),
    (model, model_origin): (&HostRobot<N>, &str),
    (six_d, base_unknown): (bool, bool),
    estimated: &[Param],
    prior: &[String],
) -> anyhow::Result<(HostRobot<N>, Vec<Option<f64>>)> {
    let mut start = nominal.clone();
    for e in model.effects().iter().skip(nominal.effects().len()) {
        start
            .effects_mut()
            .push(
                e.kind,
                e.joint as usize,
                N,
                e.order,
                e.start,
                e.step,
                &vec![0.0; e.len as usize],
            )
            .map_err(|err| anyhow::anyhow!("{model_origin}: effect: {err:?}"))?;
    }
    let spec = file.prior.unwrap_or_default().with_overrides(prior)?;
    let tool_axes_unknown = six_d && file.tool.rpy_deg.is_none();
    let file_effects = nominal.effects().values().len();
    let prior = crate::calibration::prior::sigmas(&spec, estimated, |p| {
        (p.is_base() && base_unknown)
            || (p.is_tool_rotation() && tool_axes_unknown)
            || (matches!(p, Param::ToolX | Param::ToolY | Param::ToolZ) && file.tool_unknown())
            || matches!(p, Param::Effect(k) if usize::from(k) >= file_effects)
    });
    Ok((start, prior))
}
