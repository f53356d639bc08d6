//! Which reflector the targets are for. A model with several `[[tools]]` points (a probe with
//! reflectors A, B, C) brings one of them to each target; the library compensates the first
//! tool point, so the model is handed over with the chosen point first. Without a choice the
//! first is taken, and a warning says so: targets of reflector B compensated as A's fail or,
//! near A's point, bring the wrong point there.

use crate::formats::robot_file::RobotFile;
use kinecal::Robot;

/// `robot` (of the robot file `file`, called `what` in messages) with the point of the
/// reflector `tool` names as its first tool point, and the warning to print when the model has
/// several and none was named. Refuses (exit 2) a name the file does not give its reflectors.
pub fn of_reflector<const N: usize, V: kinecal::ValueStorage>(
    file: &RobotFile,
    robot: &Robot<f64, N, V>,
    tool: Option<&str>,
    what: &str,
) -> anyhow::Result<(Robot<f64, N, V>, Option<String>)> {
    let names = file.tool_names();
    let list = || {
        names
            .iter()
            .map(|n| format!("{n:?}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let Some(tool) = tool else {
        let warning = (names.len() > 1).then(|| {
            format!(
                "{what} has {} reflectors ({}): the targets are taken as points of the first, \
                 {:?}; --tool NAME takes them for another",
                names.len(),
                list(),
                names[0]
            )
        });
        return Ok((robot.clone(), warning));
    };
    if names.is_empty() {
        crate::refuse!(
            "--tool {tool}: {what} has one tool point ([tool]), not named reflectors: drop --tool"
        );
    }
    let Some(k) = names.iter().position(|n| n == tool) else {
        crate::refuse!(
            "--tool {tool}: {what} has no reflector of that name; its [[tools]] are {}",
            list()
        );
    };
    let mut chosen = robot.clone();
    let point = *robot.tool_point(k).ok_or_else(|| {
        crate::refused(format!(
            "--tool {tool}: {what} has {} tool points, fewer than its [[tools]] names",
            robot.tool_point_count()
        ))
    })?;
    chosen
        .set_tool_point(0, point)
        .map_err(|e| crate::refused(format!("--tool {tool}: {e:?}")))?;
    Ok((chosen, None))
}
