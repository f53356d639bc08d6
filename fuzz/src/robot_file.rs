//! The CLI's robot TOML reader (`RobotFile::parse`, `to_robot`, `to_toml`, `from_robot`).
//!
//! Invariants:
//! - `no-panic` on any text;
//! - `accepted-robot-finite`: a file that parses and builds gives a robot whose every number is
//!   finite and whose forward kinematics at zero and at the joint limits is finite;
//! - `toml-round-trip`: `parse(to_toml(file)) == file`;
//! - `robot-round-trip`: `from_robot(to_robot(file)).to_robot()` is the same robot (angles
//!   written with `deg_short` read back exactly).

use super::{invariant, robot_finite, robot_numbers, skip, vec_finite};
use kinecal::forward::point;
use kinecal_cli::formats::robot_file::RobotFile;

fn check<const N: usize>(file: &RobotFile) -> anyhow::Result<()> {
    let robot = file.to_robot::<N>()?;
    if skip("robot-huge") && super::robot_magnitude(&robot) > 1e100 {
        return Ok(());
    }
    invariant!("accepted-robot-finite", robot_finite(&robot), "{file:?}");
    let zero = [0.0; N];
    let lo: [f64; N] = std::array::from_fn(|i| robot.joints()[i].lower);
    let hi: [f64; N] = std::array::from_fn(|i| robot.joints()[i].upper);
    for q in [zero, lo, hi] {
        let p = point(&robot, &q);
        invariant!(
            "accepted-robot-finite",
            vec_finite(&p),
            "FK {p:?} at {q:?} of {file:?}"
        );
    }
    let tilt = file.tilt_joints();
    let again = RobotFile::from_robot(&file.name, &robot, file.base_known(), &tilt);
    let back = again.to_robot::<N>();
    invariant!(
        "robot-round-trip",
        back.is_ok(),
        "{again:?}: {:?}",
        back.err()
    );
    let back = back.unwrap();
    let a = robot_numbers(&robot);
    let b = robot_numbers(&back);
    // Base rotations go through roll/pitch/yaw: allow rounding there only.
    let ok = a.len() == b.len()
        && a.iter()
            .zip(&b)
            .all(|(x, y)| x.to_bits() == y.to_bits() || (x - y).abs() <= 1e-12 * (1.0 + x.abs()));
    invariant!("robot-round-trip", ok, "{a:?}\nvs\n{b:?}");
    Ok(())
}

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(file) = RobotFile::parse(text, "fuzz.toml") else {
        return;
    };
    if let Ok(t) = file.to_toml() {
        let back = RobotFile::parse(&t, "again.toml");
        invariant!(
            "toml-round-trip",
            back.as_ref().is_ok_and(|b| *b == file),
            "{file:?}\n{t}\n{:?}",
            back.as_ref().map_err(|e| e.to_string())
        );
    }
    let _ = kinecal_cli::with_joints!(file.joint_count(), N => check::<N>(&file));
}
