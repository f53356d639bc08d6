//! Footprint of identification: the Levenberg–Marquardt stepper over the 24 MDH parameters of a
//! 6-joint robot (`identify::lm::Levenberg` with `FixedLm<f32, 24>`), stepped over measured
//! points in slices (`Levenberg::step`), and the identified robot read back.

#![cfg_attr(target_os = "none", no_std, no_main)]

use kinecal::identify::lm::{FixedLm, Levenberg, LmConfig};
use kinecal::io::measurement::Measurement;
use kinecal::model::param::ParamSet;
use kinecal::{Frame, Joint, Robot};
use kinecal_footprint::{input, Slot};
use nalgebra::Vector3;

/// Poses of the identification (the measurements a firmware streams in).
const POSES: usize = 50;

type Solver = Levenberg<f32, 6, kinecal::Inline<0>, FixedLm<f32, 24>>;

static SOLVER: Slot<Solver> = Slot::new();
static DATA: Slot<[Measurement<f32, 6>; POSES]> = Slot::new();

fn run() -> f32 {
    let rows = input([Joint::mdh(0.0f32, 0.0, 0.0, 400.0); 6]);
    let Ok(start) = Robot::new(Frame::identity(), rows, Vector3::new(0.0f32, 0.0, 100.0)) else {
        return f32::NAN;
    };
    let Ok(set) = ParamSet::<24>::mdh(6) else {
        return f32::NAN;
    };
    let Ok(solver) = Levenberg::new(start, FixedLm::new(set), LmConfig::default()) else {
        return f32::NAN;
    };
    // SAFETY: the only use of each slot.
    let (lm, data) = unsafe {
        (
            SOLVER.put(solver),
            DATA.put(input([Measurement::new([0.0; 6], Vector3::zeros()); POSES])),
        )
    };
    loop {
        match lm.step(&data[..], input(5)) {
            Ok(p) if p.stopped.is_none() => continue,
            Ok(_) => return lm.robot().joints()[1].a,
            Err(_) => return f32::NAN,
        }
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
