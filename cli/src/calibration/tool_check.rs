//! The tool points a robot file states, checked against where a fit put them: reflectors whose
//! labels are exchanged ([`super::reflector_labels`]), then a point written in metres or with a
//! sign flipped ([`super::arm_size::tool_slip`]).

use kinecal::Robot;

/// [`super::reflector_labels::mixed_up`] and [`super::arm_size::tool_slip`] for the tool points
/// the robot file `file` states (none when its tool is
/// unknown: started from the data), named as the file names them.
pub fn stated_tool_slip<const N: usize, V: kinecal::ValueStorage, W: kinecal::ValueStorage>(
    file: &crate::formats::robot_file::RobotFile,
    nominal: &Robot<f64, N, V>,
    fitted: &Robot<f64, N, W>,
) -> Option<String> {
    // A reversed flange axis puts an unknown tool behind the wrist as well (a stated one is
    // checked for it in `tool_slip`, after a flipped sign).
    if file.tool_unknown() {
        return super::arm_size::axis_reversed(nominal, fitted, false);
    }
    let names = file.tool_names();
    // Labels first: an exchanged pair mirrored in one axis (B at y = 52, C at −52) also reads
    // as a flipped sign.
    super::reflector_labels::mixed_up(nominal, fitted, &names)
        .or_else(|| super::arm_size::tool_slip(nominal, fitted, &names))
}
