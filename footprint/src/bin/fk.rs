//! Footprint of forward kinematics: a 6-joint robot built from its rows, the tool point at the
//! joint readings (`Robot::new`, `ForwardKinematics::compute`; f32, no effects).

#![cfg_attr(target_os = "none", no_std, no_main)]

use kinecal::{ForwardKinematics, Frame, Joint, Robot};
use kinecal_footprint::{input, Slot};
use nalgebra::Vector3;

static FK: Slot<(Robot<f32, 6>, ForwardKinematics<f32, 6>)> = Slot::new();

/// Builds the robot once, then computes a point per call.
fn run() -> f32 {
    let rows = input([Joint::mdh(0.0f32, 0.0, 0.0, 400.0); 6]);
    let tool = input(Vector3::new(0.0f32, 0.0, 100.0));
    let Ok(robot) = Robot::new(Frame::identity(), rows, tool) else {
        return f32::NAN;
    };
    // SAFETY: the only use of the slot.
    let (robot, fk) = unsafe { FK.put((robot, ForwardKinematics::new())) };
    let mut sum = 0.0;
    for _ in 0..input(4) {
        let q = input([0.1f32; 6]);
        sum += fk.compute(robot, &q).x;
    }
    sum
}

#[cfg(target_os = "none")]
#[cortex_m_rt::entry]
fn main() -> ! {
    input(run());
    loop {
        core::hint::spin_loop();
    }
}

#[cfg(not(target_os = "none"))]
fn main() {
    println!("{}", run());
}
