//! Footprint of compensation with effects: a whole model (rows, base, tool, effects of every
//! kind, couplings) decoded from a binary model in flash (`io::model_blob::decode`), then the
//! joint command for a target (`compensate::compensate`; f32, 256 effect values).

#![cfg_attr(target_os = "none", no_std, no_main)]

use kinecal::compensate::{compensate, Config, Target};
use kinecal::io::model_blob;
use kinecal::{Frame, Joint, Robot};
use kinecal_footprint::{input, Slot};
use nalgebra::Vector3;

/// Room for the binary model (`kinecal export --format firmware`), as a firmware keeps it in
/// flash; its bytes are the firmware's to provide.
static BLOB: [u8; 2048] = [0; 2048];

static MODEL: Slot<Robot<f32, 6, kinecal::Inline<256>>> = Slot::new();

fn run() -> f32 {
    let zero = Joint::mdh(0.0f32, 0.0, 0.0, 0.0);
    let Ok(empty) = Robot::new(Frame::identity(), [zero; 6], Vector3::zeros()) else {
        return f32::NAN;
    };
    // SAFETY: the only use of the slot.
    let robot = unsafe { MODEL.put(empty) };
    let len = input(BLOB.len());
    let Some(blob) = input(&BLOB[..]).get(..len) else {
        return f32::NAN;
    };
    if model_blob::decode(blob, robot).is_err() {
        return f32::NAN;
    }
    let target = Target::Point(input(Vector3::new(800.0f32, 100.0, 600.0)));
    let seed = input([0.1f32; 6]);
    match compensate(robot, &target, &seed, &Config::default()) {
        Ok(s) => s.q[0],
        Err(e) => e.best().map_or(f32::NAN, |s| s.q[1]),
    }
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
