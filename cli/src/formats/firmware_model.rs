//! The binary model (`.kcm`) of a robot file, written by the library's encoder
//! (docs/formats.md, "Binary model (.kcm)").

use crate::formats::robot_file::RobotFile;
use crate::with_joints;
use anyhow::anyhow;
use kinecal::io::model_blob::{self, MAX_JOINTS};

/// The bytes of the binary model of `file` (refused, exit 2, beyond
/// [`model_blob::MAX_JOINTS`] joints or when the library refuses the model).
pub fn encode(file: &RobotFile) -> anyhow::Result<Vec<u8>> {
    let n = file.joint_count();
    if n > MAX_JOINTS {
        crate::refuse!("the model has {n} joints: the firmware format holds at most {MAX_JOINTS}");
    }
    with_joints!(n, N => encode_with_joints::<N>(file))
}

fn encode_with_joints<const N: usize>(file: &RobotFile) -> anyhow::Result<Vec<u8>> {
    let robot = file
        .to_robot::<N>()
        .map_err(|e| crate::refused(e.to_string()))?;
    let mut out = vec![0u8; model_blob::encoded_len(&robot)];
    let n = model_blob::encode(&robot, &mut out)
        .map_err(|e| anyhow!("cannot encode the model: {e:?}"))?;
    out.truncate(n);
    Ok(out)
}
