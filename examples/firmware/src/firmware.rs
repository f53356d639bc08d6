//! The firmware: a robot controller's calibration coprocessor, simulated on QEMU's MPS2-AN386.
//!
//! The controller's time base is a 1 kHz servo period of [`PERIOD_INSNS`] instructions (a
//! ~100 MHz M4F at about one instruction per cycle). Every period starts with the servo tick;
//! the idle loop gets the rest of the period for background work in bounded slices. The model
//! the servo tick compensates with lives in the static [`MODEL`].
//!
//! Stages, each checked against values the host computed in `f64` ([`crate::reference`]):
//! 1. **Stream**: measurement records arrive as CSV bytes through `embedded_io::Read` (a UART
//!    FIFO that hands over at most 16 bytes per read) into [`kinecal::io::csv::CsvReader`].
//! 2. **Kinematics**: `f32` forward kinematics and the identification Jacobian.
//! 3. **Identify**: the LM stepper in idle slices while the servo holds position; halfway its
//!    state is saved as a snapshot (as to flash), the run continues, and a fresh solver restored
//!    from the snapshot must finish bit-identical. The result replaces [`MODEL`].
//!    A re-mastering follows: theta2 and theta3 alone, re-identified the same way from 10 poses;
//!    then a calibration without a tracker, from 4 sockets touched 8 times each.
//! 4. **Search**: a small PSO the same way; the BPNN of BPNN-PSO predicts particle positions.
//! 5. **Servo**: a 50 ms trajectory of 6-D targets compensated tick by tick with [`MODEL`];
//!    the simulated true robot must reach every target.
//! 6. **Measure**: `BENCH <name> <instructions>` lines and the stack high-water mark.

/// A fresh static slot for a big value, so it does not live on the stack (defined before the
/// stage modules, which use it too).
macro_rules! slot {
    ($ty:ty) => {
        cortex_m::singleton!(: MaybeUninit<$ty> = MaybeUninit::uninit()).unwrap_or_else(|| fail("slot taken twice"))
    };
}

mod benches;
mod checks;
mod identify;
mod kernels;
mod kinematics;
mod probe;
mod remaster;
mod scheduler;
mod search;
mod sockets;
mod stream;
mod tables;
mod trajectory;

use crate::bench::{self, Counter};
use crate::scenario::{self, ID_POSES, N, P, SWARM, VAL_POSES};
use benches::benches;
use checks::Checks;
use core::cell::RefCell;
use core::mem::MaybeUninit;
use cortex_m::interrupt::{self as irq, Mutex};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hio, hprintln};
use heapless::Vec;
use identify::identify;
use kinecal::identify::lm::{FixedLm, Levenberg, LmError};
use kinecal::{Measurement, Robot};
use kinematics::kinematics;
use probe::probe;
use remaster::remaster;
use scheduler::Servo;
use search::{predict, search};
use sockets::sockets;
use stream::stream;
use trajectory::trajectory;

/// Instructions per 1 kHz servo period (a ~100 MHz M4F at ~1 instruction per cycle).
const PERIOD_INSNS: u32 = 100_000;
/// Longest the idle loop may stay away from its other duties (e.g. the host link): 2 periods.
const SLICE_LIMIT_INSNS: u32 = 2 * PERIOD_INSNS;
/// Poses per LM slice.
const LM_SLICE: usize = 5;
/// Particles per PSO slice (one particle is one model evaluation over all 50 poses).
const PSO_SLICE: usize = 2;
/// Room for one stepper snapshot (the "flash page").
const SNAPSHOT_BYTES: usize = 8192;

/// The solver with its normal equations in fixed arrays sized for this robot's 24 parameters.
type Lm = Levenberg<f32, N, kinecal::Inline<0>, FixedLm<f32, P>>;
type Swarm = kinecal::identify::pso::Pso<f32, SWARM, P, { scenario::PSO_HISTORY }>;

/// The model the servo tick compensates with: read every tick, replaced by the idle loop when
/// an identification finishes (shared with interrupt context on a real controller, hence the
/// critical-section mutex).
static MODEL: Mutex<RefCell<Option<Robot<f32, N>>>> = Mutex::new(RefCell::new(None));

/// Static slots the stages use in turn: the snapshot's "flash page", and one LM solver (8.6 KB)
/// for every run (the first identification, its resumed twin, the probe's).
struct Shared {
    flash: &'static mut [u8; SNAPSHOT_BYTES],
    lm: &'static mut MaybeUninit<Result<Lm, LmError>>,
}

/// Costs measured inside the stages, where the steppers run (see [`Counter::per_call_once`]).
struct Stateful {
    lm_pose: f32,
    lm_pose6d: f32,
    lm_point_multi: f32,
    lm_remaster: f32,
    lm_socket: f32,
    pso_particle: f32,
}

/// Builds a stepper straight into a static slot: its constructor's `Result` is written there
/// and borrowed, so the multi-kilobyte state is not moved through the stack on the way. A slot
/// may be built into again once the previous stepper's borrow has ended.
#[inline(never)]
fn place<T, E>(
    slot: &mut MaybeUninit<Result<T, E>>,
    make: impl FnOnce() -> Result<T, E>,
) -> &mut T {
    match slot.write(make()) {
        Ok(v) => v,
        Err(_) => fail("stepper setup refused its settings"),
    }
}

#[entry]
fn main() -> ! {
    let cp = cortex_m::Peripherals::take().unwrap_or_else(|| fail("peripherals taken twice"));
    let mut counter = match Counter::new(cp.SYST) {
        Ok(c) => c,
        Err(e) => fail_fmt(format_args!(
            "SysTick does not count instructions ({} ticks for 400,000 instructions, expected {}): \
             run QEMU with -icount shift=0 (see .cargo/config.toml)",
            e.ticks, e.expected
        )),
    };
    hprintln!(
        "kinecal firmware: Cortex-M4F (QEMU mps2-an386), f32, {} joints, {} parameters",
        N,
        P
    );
    let mut checks = Checks {
        failed: 0,
        passed: 0,
    };
    // At boot the controller runs on the nominal model.
    irq::free(|cs| *MODEL.borrow(cs).borrow_mut() = Some(scenario::nominal()));
    let mut servo = Servo::new();

    let id = slot!(Vec<Measurement<f32, N>, ID_POSES>).write(Vec::new());
    let val = slot!(Vec<Measurement<f32, N>, VAL_POSES>).write(Vec::new());
    let mut shared = Shared {
        flash: slot!([u8; SNAPSHOT_BYTES]).write([0; SNAPSHOT_BYTES]),
        lm: slot!(Result<Lm, LmError>),
    };
    stream(&mut counter, &mut checks, id, val);
    kinematics(&mut checks, id);
    let mut stateful = Stateful {
        lm_pose: f32::NAN,
        lm_pose6d: f32::NAN,
        lm_point_multi: f32::NAN,
        lm_remaster: f32::NAN,
        lm_socket: f32::NAN,
        pso_particle: f32::NAN,
    };
    identify(
        &mut counter,
        &mut checks,
        &mut stateful,
        &mut servo,
        &mut shared,
        id,
        val,
    );
    // The held-out poses are done with: their storage takes the probe's observations.
    probe(
        &mut counter,
        &mut checks,
        &mut stateful,
        &mut servo,
        shared.lm,
        id,
        val,
    );
    remaster(
        &mut counter,
        &mut checks,
        &mut stateful,
        &mut servo,
        shared.lm,
        id,
    );
    sockets(
        &mut counter,
        &mut checks,
        &mut stateful,
        &mut servo,
        shared.lm,
    );
    search(
        &mut counter,
        &mut checks,
        &mut stateful,
        &mut servo,
        id,
        shared.flash,
    );
    let net = predict(&mut checks);
    trajectory(&mut counter, &mut checks);
    benches(&mut counter, id, &stateful, net);

    hprintln!("STACK {}", bench::stack_high_water());
    hprintln!("{} passed, {} failed", checks.passed, checks.failed);
    debug::exit(if checks.failed == 0 {
        debug::EXIT_SUCCESS
    } else {
        debug::EXIT_FAILURE
    });
    loop {
        cortex_m::asm::nop();
    }
}

fn fail(msg: &str) -> ! {
    fail_fmt(format_args!("{}", msg))
}

/// Prints `FATAL …` and ends the QEMU run with a non-zero exit code.
fn fail_fmt(args: core::fmt::Arguments) -> ! {
    if let Ok(mut out) = hio::hstdout() {
        let _ =
            core::fmt::Write::write_fmt(&mut HostOut(&mut out), format_args!("FATAL {}\n", args));
    }
    debug::exit(debug::EXIT_FAILURE);
    loop {
        cortex_m::asm::nop();
    }
}

/// Semihosting stdout as a `fmt::Write` that never panics (usable from the panic handler).
struct HostOut<'a>(&'a mut hio::HostStream);

impl core::fmt::Write for HostOut<'_> {
    fn write_str(&mut self, s: &str) -> core::fmt::Result {
        self.0.write_all(s.as_bytes()).map_err(|_| core::fmt::Error)
    }
}

#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    fail_fmt(format_args!("panic: {}", info))
}

#[exception]
unsafe fn HardFault(ef: &ExceptionFrame) -> ! {
    fail_fmt(format_args!("HardFault at pc {:#010x}", ef.pc()))
}
