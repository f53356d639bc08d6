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
//!    A re-mastering follows: theta2 and theta3 alone, re-identified the same way from 10 poses.
//! 4. **Search**: a small PSO the same way; the BPNN of BPNN-PSO predicts particle positions.
//! 5. **Servo**: a 50 ms trajectory of 6-D targets compensated tick by tick with [`MODEL`];
//!    the simulated true robot must reach every target.
//! 6. **Measure**: `BENCH <name> <instructions>` lines and the stack high-water mark.

use crate::bench::{self, Counter};
use crate::reference as host;
use crate::scenario::{self, Net, ID_POSES, N, P, SWARM, TICKS, VAL_POSES};
use core::cell::RefCell;
use core::hint::black_box;
use core::mem::MaybeUninit;
use cortex_m::interrupt::{self as irq, Mutex};
use cortex_m_rt::{entry, exception, ExceptionFrame};
use cortex_m_semihosting::{debug, hio, hprintln};
use heapless::Vec;
use kinecal::compensate::{compensate, Target, Tracker};
use kinecal::identify::fitness::PositionFitness;
use kinecal::identify::lm::{rms_error, FixedLm, Levenberg, LmError, LmProgress};
use kinecal::identify::pso::PsoError;
use kinecal::io::csv::CsvReader;
use kinecal::io::snapshot::Snapshot;
use kinecal::model::frame::orientation_error;
use kinecal::{ForwardKinematics, Param};
use kinecal::{Frame, Joint, Measurement, Robot};
use nalgebra::Vector3;

/// The measurement file, as the host generated it (`src/generate.rs`).
static CSV: &[u8] = include_bytes!("../data/measurements.csv");

/// Host reference values that are compared in `f32`, stored as `f32` (half the flash of the
/// `f64` tables in `reference.rs`; converted when the image is built).
static NOMINAL_FK: [[f32; 3]; 4] = to_f32(&host::NOMINAL_FK);
static COUPLED_FK: [[f32; 3]; 4] = to_f32(&host::COUPLED_FK);
static JACOBIAN: [[f32; 3]; P] = to_f32(&host::JACOBIAN);
static TRUE_ROWS: [[f32; 4]; N] = to_f32(&host::TRUE_ROWS);
static COMMANDS: [[f32; N]; TICKS] = to_f32(&host::COMMANDS);
static POSE6D_VALUES: [[f32; P]; 1] = to_f32(&[host::POSE6D_VALUES]);
static POSE6D_AXES: [[f32; 3]; 3] = to_f32(&host::POSE6D_AXES);

const fn to_f32<const R: usize, const C: usize>(a: &[[f64; C]; R]) -> [[f32; C]; R] {
    let mut out = [[0.0; C]; R];
    let mut i = 0;
    while i < R {
        let mut j = 0;
        while j < C {
            out[i][j] = a[i][j] as f32;
            j += 1;
        }
        i += 1;
    }
    out
}

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
type Lm = Levenberg<f32, N, 0, FixedLm<f32, P>>;
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
    pso_particle: f32,
}

/// Self-check results.
struct Checks {
    failed: u32,
    passed: u32,
}

impl Checks {
    fn check(&mut self, name: &str, ok: bool, detail: core::fmt::Arguments) {
        if ok {
            self.passed += 1;
            hprintln!("CHECK ok   {}: {}", name, detail);
        } else {
            self.failed += 1;
            hprintln!("CHECK FAIL {}: {}", name, detail);
        }
    }
    /// `|got - want| <= tol`.
    fn close(&mut self, name: &str, got: f64, want: f64, tol: f64) {
        let ok = (got - want).abs() <= tol;
        // Decimals to show the tolerance with, ⌈−log₁₀ tol⌉ for the powers of ten used here,
        // without libm's log10 (~0.9 KB of flash).
        let (mut d, mut x) = (0u8, tol);
        while x < 0.999 && d < 9 {
            x *= 10.0;
            d += 1;
        }
        self.check(
            name,
            ok,
            format_args!(
                "{} vs host f64 {} (tolerance {})",
                fx(got, 6),
                fx(want, 6),
                fx(tol, d)
            ),
        );
    }
}

/// A real printed with `d` decimals by integer arithmetic: keeps core's float formatting
/// (~20 KB of flash) out of the image.
struct Fixed(f64, u8);

impl core::fmt::Display for Fixed {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let Fixed(x, d) = *self;
        if !x.is_finite() {
            return f.write_str(if x.is_nan() {
                "NaN"
            } else if x > 0.0 {
                "inf"
            } else {
                "-inf"
            });
        }
        // Up to 9 decimals, from a table (no `u64::pow`).
        const POW10: [u64; 10] = [
            1,
            10,
            100,
            1_000,
            10_000,
            100_000,
            1_000_000,
            10_000_000,
            100_000_000,
            1_000_000_000,
        ];
        let d = d.min(9);
        let scale = POW10[d as usize];
        let m = libm::round(x.abs() * scale as f64) as u64;
        let sign = if x < 0.0 && m != 0 { "-" } else { "" };
        if d == 0 {
            write!(f, "{sign}{m}")
        } else {
            write!(f, "{sign}{}.{:0w$}", m / scale, m % scale, w = d as usize)
        }
    }
}

fn fx(x: impl Into<f64>, decimals: u8) -> Fixed {
    Fixed(x.into(), decimals)
}

/// A UART receive FIFO: at most 16 bytes per read, as the hardware hands them over.
struct Uart {
    rx: &'static [u8],
}

impl embedded_io::ErrorType for Uart {
    type Error = core::convert::Infallible;
}

impl embedded_io::Read for Uart {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        let n = buf.len().min(16).min(self.rx.len());
        buf[..n].copy_from_slice(&self.rx[..n]);
        self.rx = &self.rx[n..];
        Ok(n)
    }
}

/// A fresh static slot for a big value, so it does not live on the stack.
macro_rules! slot {
    ($ty:ty) => {
        cortex_m::singleton!(: MaybeUninit<$ty> = MaybeUninit::uninit()).unwrap_or_else(|| fail("slot taken twice"))
    };
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

/// The servo tick while background work runs: the robot holds a pose, compensated every
/// period with whatever model [`MODEL`] holds at that moment.
struct Servo {
    tracker: Tracker<f32, N>,
    target: Target<f32>,
    nominal: [f32; N],
    worst: u32,
    faults: u32,
}

impl Servo {
    fn new() -> Self {
        let nominal = scenario::nominal_joints::<f32>(0);
        let mut fk = ForwardKinematics::new();
        fk_f32(&mut fk, &scenario::nominal::<f32>(), &nominal);
        let target = Target::Pose(fk.flange_pose());
        Self {
            tracker: Tracker::new(scenario::compensation()),
            target,
            nominal,
            worst: 0,
            faults: 0,
        }
    }

    fn tick(&mut self) {
        let r = irq::free(|cs| {
            MODEL
                .borrow(cs)
                .borrow()
                .as_ref()
                .map(|m| track(&mut self.tracker, m, &self.target, &self.nominal))
        });
        if !matches!(r, Some(Ok(_))) {
            self.faults += 1;
        }
    }
}

/// Background work in 1 kHz periods: each period runs the servo tick, then `slice` until the
/// period's remaining instructions are used up or `slice` reports that the work is done.
struct Idle {
    periods: u32,
    slices: u32,
    total: u32,
    worst_slice: u32,
    /// Instructions of the slice that wrote the snapshot (0: none).
    snapshot: u32,
}

/// What one idle slice did.
enum Work {
    /// A bounded step of the algorithm; more to do.
    Step,
    /// Wrote the snapshot to flash instead of stepping.
    Snapshot,
    /// The algorithm has finished.
    Done,
}

impl Idle {
    fn run<F: FnMut() -> Work>(
        counter: &mut Counter,
        servo: &mut Servo,
        limit_periods: u32,
        mut slice: F,
    ) -> Self {
        Self::run_dyn(counter, servo, limit_periods, &mut slice)
    }

    /// [`Idle::run`] for any slice (one copy of the scheduler for every stage).
    #[inline(never)]
    fn run_dyn(
        counter: &mut Counter,
        servo: &mut Servo,
        limit_periods: u32,
        slice: &mut dyn FnMut() -> Work,
    ) -> Self {
        let mut s = Idle {
            periods: 0,
            slices: 0,
            total: 0,
            worst_slice: 0,
            snapshot: 0,
        };
        loop {
            s.periods += 1;
            let ((), tick) = counter.insns_of(|| servo.tick());
            servo.worst = servo.worst.max(tick);
            let mut left = PERIOD_INSNS.saturating_sub(tick);
            loop {
                let (work, n) = counter.insns_of(&mut *slice);
                s.slices += 1;
                s.total += n;
                match work {
                    Work::Snapshot => s.snapshot = n,
                    Work::Step | Work::Done => s.worst_slice = s.worst_slice.max(n),
                }
                if let Work::Done = work {
                    return s;
                }
                if n >= left {
                    break;
                }
                left -= n;
            }
            if s.periods >= limit_periods {
                fail("background work did not finish in time");
            }
        }
    }

    fn report(&self, what: &str, checks: &mut Checks) {
        hprintln!(
            "{}: {} slices in {} servo periods, {} instructions in all, worst slice {}, snapshot slice {}",
            what,
            self.slices,
            self.periods,
            self.total,
            self.worst_slice,
            self.snapshot
        );
        checks.check(
            "idle.slice_bounded",
            self.worst_slice <= SLICE_LIMIT_INSNS,
            format_args!(
                "{what}: worst slice {} ≤ {} instructions",
                self.worst_slice, SLICE_LIMIT_INSNS
            ),
        );
    }
}

/// Stage 1: records in over the UART, split by the carried `set` column.
#[inline(never)]
fn stream(
    counter: &mut Counter,
    checks: &mut Checks,
    id: &mut Vec<Measurement<f32, N>, ID_POSES>,
    val: &mut Vec<Measurement<f32, N>, VAL_POSES>,
) {
    let ((sums, errors), insns) = counter.insns_of(|| {
        let mut sums = [0.0f64; 2];
        let mut errors = 0u32;
        let mut reader = match CsvReader::<Uart, N, 128, 4>::new(Uart { rx: CSV }) {
            Ok(r) => r,
            Err(e) => fail_fmt(format_args!(
                "CSV header: {} at line {}",
                e.kind.describe(),
                e.line
            )),
        };
        let (set, temp) = match (reader.extra_index("set"), reader.extra_index("temp_c")) {
            (Some(s), Some(t)) => (s, t),
            _ => fail("CSV lacks the set/temp_c columns"),
        };
        while let Some(rec) = reader.next_record() {
            match rec {
                Ok(r) => {
                    sums[0] += r.q_deg.iter().sum::<f64>() + r.xyz_mm.iter().sum::<f64>();
                    sums[1] += r.extra[temp];
                    let full = if r.extra[set] == 0.0 {
                        id.push(r.measurement()).is_err()
                    } else {
                        val.push(r.measurement()).is_err()
                    };
                    errors += u32::from(full);
                }
                Err(e) => {
                    hprintln!(
                        "CSV line {} column {}: {}",
                        e.line,
                        e.column,
                        e.kind.describe()
                    );
                    errors += 1;
                }
            }
        }
        (sums, errors)
    });
    hprintln!(
        "stream: {} + {} records over the UART in {} instructions",
        id.len(),
        val.len(),
        insns
    );
    checks.check(
        "csv.records",
        id.len() == ID_POSES && val.len() == VAL_POSES && errors == 0,
        format_args!(
            "{} identification + {} held-out poses, {} errors",
            id.len(),
            val.len(),
            errors
        ),
    );
    checks.close("csv.sum", sums[0], host::CSV_SUMS[0], 1e-6);
    checks.close("csv.temp_sum", sums[1], host::CSV_SUMS[1], 1e-9);
}

/// Stage 2: f32 kinematics against the host's f64.
#[inline(never)]
fn kinematics(checks: &mut Checks, id: &[Measurement<f32, N>]) {
    let nominal = scenario::nominal::<f32>();
    let mut fk = ForwardKinematics::<f32, N>::new();
    let worst = fk_worst(&mut fk, &nominal, id, &NOMINAL_FK);
    checks.check(
        "fk.f32",
        worst < 2e-3,
        format_args!("max |p_f32 - p_f64| = {} µm", fx(worst * 1e3, 3)),
    );
    // The FANUC way of reading J3 (from the horizontal, q3 = J3 + J2): same readings, other
    // points.
    let worst = fk_worst(&mut fk, &scenario::coupled(), id, &COUPLED_FK);
    checks.check(
        "fk.coupled_f32",
        worst < 2e-3,
        format_args!("max |p_f32 - p_f64| = {} µm", fx(worst * 1e3, 3)),
    );

    fk_f32(&mut fk, &nominal, &id[0].q);
    let mut cols = [Vector3::zeros(); P];
    let ok = fk
        .identification_jacobian(&nominal, scenario::params().as_slice(), &mut cols)
        .is_ok();
    let mut worst = 0.0f32;
    for (c, want) in cols.iter().zip(JACOBIAN.iter()) {
        let w = Vector3::from(*want);
        worst = worst.max((c - w).norm() / w.norm().max(1.0));
    }
    checks.check(
        "jacobian.f32",
        ok && worst < 1e-5,
        format_args!("max relative column error {} ppm", fx(worst * 1e6, 3)),
    );
    checks.close(
        "fk.nominal_rms_mm",
        rms_error(&nominal, id) as f64,
        host::NOMINAL_RMS_MM,
        1e-4,
    );
}

/// Stage 3: LM in idle slices, with a snapshot halfway that a fresh solver resumes from.
#[inline(never)]
fn identify(
    counter: &mut Counter,
    checks: &mut Checks,
    bench: &mut Stateful,
    servo: &mut Servo,
    shared: &mut Shared,
    id: &[Measurement<f32, N>],
    val: &[Measurement<f32, N>],
) {
    let Shared { flash, lm: lm_slot } = shared;
    let lm = place(&mut **lm_slot, new_lm as NewLm);
    // One pose into the normal equations (poses 2..=49 of the first pass; the first call also
    // validates the data, the 50th also analyses identifiability). The run continues from here.
    let _ = lm_step(lm, id, 1);
    bench.lm_pose = lm_per_pose(counter, lm, id, ID_POSES as u32 - 2);
    let mut saved: Option<(usize, u32)> = None;
    let mut error = None;
    let idle = Idle::run(counter, servo, 10_000, || {
        let p = lm.progress();
        if saved.is_none() && p.iteration * 2 >= host::LM_ITERATIONS {
            // Halfway: this slice writes the state to flash instead of stepping.
            let mut w: &mut [u8] = &mut flash[..];
            saved = save(&*lm, &mut w)
                .ok()
                .map(|()| (SNAPSHOT_BYTES - w.len(), p.iteration));
            return Work::Snapshot;
        }
        match lm_step(lm, id, LM_SLICE) {
            Ok(p) if p.stopped.is_some() => Work::Done,
            Ok(_) => Work::Step,
            Err(e) => {
                error = Some(e);
                Work::Done
            }
        }
    });
    if let Some(e) = error {
        fail_fmt(format_args!("LM refused the data: {:?}", e));
    }
    let p = lm.progress();
    hprintln!(
        "identify: LM {:?} after {} iterations (host f64: {}), cost {} mm²",
        p.stopped,
        p.iteration,
        host::LM_ITERATIONS,
        fx(p.cost, 6)
    );
    idle.report("identify", checks);
    let model = lm.robot().clone();
    checks.close(
        "lm.id_rms_mm",
        rms_error(&model, id) as f64,
        host::LM_ID_RMS_MM,
        1e-3,
    );
    checks.close(
        "lm.val_rms_mm",
        rms_error(&model, val) as f64,
        host::LM_VAL_RMS_MM,
        1e-3,
    );
    let mut fk = ForwardKinematics::<f32, N>::new();
    let mut worst = 0.0f32;
    for (m, want) in val.iter().zip(host::LM_VAL_PREDICTED.iter()) {
        worst = worst.max((fk_f32(&mut fk, &model, &m.q) - v3(want)).norm());
    }
    checks.check(
        "lm.model_vs_host",
        worst < 5e-3,
        format_args!(
            "f32 and f64 identified models differ by {} µm at most on held-out poses",
            fx(worst * 1e3, 3)
        ),
    );

    // Power lost at the snapshot: a fresh solver restored from flash runs to the end again.
    let (len, at) = saved.unwrap_or_else(|| fail("LM finished before its snapshot"));
    let first = lm.progress();
    // The same slot: the first solver is done with (its end and model are kept).
    let lm = place(&mut **lm_slot, new_lm as NewLm);
    let restored = restore(lm, &flash[..len]);
    let mut steps = 0u32;
    let end = loop {
        match lm_step(lm, id, LM_SLICE) {
            Ok(p) if p.stopped.is_some() => break Some(p),
            Ok(_) if steps < 100_000 => steps += 1,
            _ => break None,
        }
    };
    checks.check(
        "lm.snapshot_resume",
        restored.is_ok() && end == Some(first) && lm.robot() == &model,
        format_args!("{len}-byte snapshot at iteration {at}, restored into a fresh solver: {:?}, same end: {}", restored, end == Some(first)),
    );
    irq::free(|cs| *MODEL.borrow(cs).borrow_mut() = Some(model));
}

/// Stage 3b: the tool as a 6-DoF probe with two further reflectors. Observations of
/// a known error of the probe and the wrist (weighted 6-D observations of reflector 1, position
/// observations of reflectors 2 and 3, computed here from the truth at the first
/// identification poses) in the held-out poses' storage; LM from the nominal probe must find
/// the host's `f64` values, the probe's orientation included.
#[inline(never)]
fn probe(
    counter: &mut Counter,
    checks: &mut Checks,
    bench: &mut Stateful,
    servo: &mut Servo,
    lm_slot: &mut MaybeUninit<Result<Lm, LmError>>,
    id: &[Measurement<f32, N>],
    data: &mut Vec<Measurement<f32, N>, VAL_POSES>,
) {
    const SIX_D: usize = scenario::POSE6D_POSES;
    const ALL: usize = SIX_D + scenario::POINT_OBS;
    const _: () = assert!(ALL <= VAL_POSES);
    data.clear();
    scenario::pose6d_observations(
        &scenario::probe_truth(),
        |i| id[i].q,
        |m| {
            let _ = data.push(m);
        },
    );
    let lm = place(lm_slot, new_probe_lm as NewLm);
    // Accumulation pass at the nominal probe: 6-D observations 2..=8, then reflector
    // observations 9..=19 (the first call also validates the data, the last also analyses
    // identifiability). The run continues from here.
    let _ = lm_step(lm, data, 1);
    bench.lm_pose6d = lm_per_pose(counter, lm, data, SIX_D as u32 - 1);
    bench.lm_point_multi = lm_per_pose(counter, lm, data, (ALL - SIX_D) as u32 - 1);
    // The rest in idle slices while the servo holds its pose.
    let (idle, end) = lm_idle(counter, servo, lm, data);
    // Largest differences from the host's values: lengths (mm), angles (rad), and the angle
    // between the identified probe frames (rad).
    let robot = lm.robot();
    let (mut mm, mut rad) = (0.0f32, 0.0f32);
    for (p, want) in scenario::pose6d_params()
        .iter()
        .zip(POSE6D_VALUES[0].iter())
    {
        let Some(got) = stored_value(robot, *p) else {
            continue;
        };
        let e = (got - want).abs();
        if p.is_length() {
            mm = mm.max(e);
        } else {
            rad = rad.max(e);
        }
    }
    let [x, y, z] = POSE6D_AXES.map(Vector3::from);
    let want = Frame {
        x,
        y,
        z,
        o: Vector3::zeros(),
    };
    let axes = orientation_error(robot.tool_axes(), &want).norm();
    let p = end.unwrap_or_else(|| lm.progress());
    hprintln!(
        "probe: LM {:?} after {} iterations (host f64: {}), {} 6-D and {} reflector observations",
        p.stopped,
        p.iteration,
        host::POSE6D_ITERATIONS,
        SIX_D,
        ALL - SIX_D
    );
    idle.report("probe", checks);
    checks.check(
        "lm.probe_6d",
        end.is_some() && mm <= 2e-3 && rad <= 2e-6 && axes <= 2e-6,
        format_args!(
            "24 parameters from the nominal probe vs host f64: within {} µm, {} µrad, probe frame (tool.rx/ry/rz) within {} µrad",
            fx(mm * 1e3, 3),
            fx(rad * 1e6, 3),
            fx(axes * 1e6, 3)
        ),
    );
}

/// Stage 3c: a quick re-calibration after a re-mastering. The controller's model is the true
/// robot with theta2 and theta3 off by [`scenario::REMASTER_DEG`] (the robot was re-mastered
/// since); LM over those two parameters alone (the others held), on the first
/// [`scenario::REMASTER_POSES`] identification poses, in idle slices, must find the host's
/// true rows again within what the tracker's noise allows.
#[inline(never)]
fn remaster(
    counter: &mut Counter,
    checks: &mut Checks,
    bench: &mut Stateful,
    servo: &mut Servo,
    lm_slot: &mut MaybeUninit<Result<Lm, LmError>>,
    id: &[Measurement<f32, N>],
) {
    const POSES: usize = scenario::REMASTER_POSES;
    let data = &id[..POSES];
    let lm = place(lm_slot, new_remaster_lm as NewLm);
    // Poses 2..=9 of the accumulation pass (the first call also validates the data, the last
    // also analyses identifiability). The run continues from here.
    let _ = lm_step(lm, data, 1);
    bench.lm_remaster = lm_per_pose(counter, lm, data, POSES as u32 - 2);
    let (idle, end) = lm_idle(counter, servo, lm, data);
    idle.report("remaster", checks);
    let joints = lm.robot().joints();
    let mut worst = 0.0f32;
    for j in 1..3 {
        worst = worst.max((joints[j].theta - TRUE_ROWS[j][2]).abs());
    }
    checks.check(
        "lm.remaster",
        end.is_some() && worst <= scenario::REMASTER_TOLERANCE_RAD as f32,
        format_args!(
            "theta2, theta3 within {} µrad of the truth",
            fx(worst * 1e6, 3)
        ),
    );
}

/// A reflector coordinate or row value of `robot` (`None` for the probe frame's angles, which
/// are compared as a frame: their roll/pitch/yaw would link 6 KB of inverse trigonometry).
fn stored_value(robot: &Robot<f32, N>, p: Param) -> Option<f32> {
    if let Some((k, axis)) = p.tool_point() {
        return robot.tool_point(k).map(|v| v[axis]);
    }
    let j = robot.joints().get(p.joint()?)?;
    match p {
        Param::Alpha(_) => Some(j.alpha),
        Param::A(_) => Some(j.a),
        Param::Theta(_) => Some(j.theta),
        Param::D(_) => Some(j.d),
        _ => None,
    }
}

/// A constructor of the LM solver for one stage: plain functions, so that one copy of
/// [`place`] builds them all.
type NewLm = fn() -> Result<Lm, LmError>;

fn new_lm() -> Result<Lm, LmError> {
    lm_of(scenario::nominal(), scenario::params())
}

fn new_probe_lm() -> Result<Lm, LmError> {
    lm_of(scenario::nominal_probe(), scenario::pose6d_params())
}

/// The re-mastering's solver: theta2 and theta3 from the model before the re-mastering.
fn new_remaster_lm() -> Result<Lm, LmError> {
    lm_of(
        true_robot(scenario::REMASTER_DEG.to_radians() as f32),
        scenario::remaster_params(),
    )
}

/// The solver over `set` from `start`, with the scenario's settings (one copy for every stage).
#[inline(never)]
fn lm_of(start: Robot<f32, N>, set: kinecal::model::param::ParamSet<P>) -> Result<Lm, LmError> {
    Levenberg::new(start, FixedLm::new(set), scenario::lm_config())
}

/// Instructions per pose of `lm`'s accumulation pass: `calls` single-pose steps over `data`
/// (see [`Counter::per_call_once`]; one copy for every LM stage).
#[inline(never)]
fn lm_per_pose(
    counter: &mut Counter,
    lm: &mut Lm,
    data: &[Measurement<f32, N>],
    calls: u32,
) -> f32 {
    counter.per_call_once(calls, || {
        let _ = black_box(lm_step(black_box(&mut *lm), data, 1));
    })
}

/// `lm` over `data` in idle slices until it stops: the scheduler's record and the progress it
/// stopped with (`None`: the data were refused).
#[inline(never)]
fn lm_idle(
    counter: &mut Counter,
    servo: &mut Servo,
    lm: &mut Lm,
    data: &[Measurement<f32, N>],
) -> (Idle, Option<LmProgress<f32>>) {
    let mut end = None;
    let idle = Idle::run(counter, servo, 10_000, || {
        match lm_step(lm, data, LM_SLICE) {
            Ok(p) if p.stopped.is_some() => {
                end = Some(p);
                Work::Done
            }
            Ok(_) => Work::Step,
            Err(_) => Work::Done,
        }
    });
    (idle, end)
}

/// Stage 4: a small PSO in idle slices, with a snapshot and resume as for LM.
#[inline(never)]
fn search(
    counter: &mut Counter,
    checks: &mut Checks,
    bench: &mut Stateful,
    servo: &mut Servo,
    id: &[Measurement<f32, N>],
    flash: &mut [u8; SNAPSHOT_BYTES],
) {
    let nominal = scenario::nominal::<f32>();
    let params = scenario::params();
    let mut fitness =
        PositionFitness::new(&nominal, &params, id).unwrap_or_else(|_| fail("fitness setup"));
    // One static slot serves both swarms (the first is done with when the second is built):
    // 6.6 KB of RAM less than a slot each.
    let slot = slot!(Result<Swarm, PsoError>);
    let swarm = place(&mut *slot, || {
        Swarm::new(scenario::pso_config(), scenario::PSO_SEED)
    });
    // One particle (move + fitness over the 50 poses): the first iteration's particles but the
    // last (whose call also ends the iteration), after the initial swarm. The run continues.
    let _ = pso_step(swarm, &mut fitness, SWARM);
    bench.pso_particle = counter.per_call_once(SWARM as u32 - 1, || {
        let _ = black_box(pso_step(black_box(&mut *swarm), &mut fitness, 1));
    });
    let mut saved: Option<(usize, u32)> = None;
    let idle = Idle::run(counter, servo, 10_000, || {
        let p = swarm.progress();
        if saved.is_none() && p.iteration * 2 >= scenario::PSO_ITERATIONS {
            let mut w: &mut [u8] = &mut flash[..];
            saved = save(&*swarm, &mut w)
                .ok()
                .map(|()| (SNAPSHOT_BYTES - w.len(), p.iteration));
            return Work::Snapshot;
        }
        match pso_step(swarm, &mut fitness, PSO_SLICE) {
            Ok(p) if p.stopped.is_some() => Work::Done,
            Ok(_) => Work::Step,
            Err(_) => fail("PSO refused the objective"),
        }
    });
    let first = swarm.progress();
    let history = swarm.history();
    let start = history.first().copied().unwrap_or(f32::INFINITY);
    hprintln!(
        "search: PSO {} particles x {} iterations, best {} mm² (initial swarm {} mm², host f64 {} mm², nominal {} mm²)",
        SWARM,
        first.iteration,
        fx(first.best_fitness, 3),
        fx(start, 3),
        fx(host::PSO_BEST_MM2, 3),
        fx(host::NOMINAL_COST_MM2, 3)
    );
    idle.report("search", checks);
    checks.check(
        "pso.improves",
        first.best_fitness < start && first.best_fitness.is_finite(),
        format_args!(
            "best fitness {} < initial swarm's {}",
            fx(first.best_fitness, 3),
            fx(start, 3)
        ),
    );
    let best = *swarm.best_position();

    // Resume from the snapshot in a swarm drawn from another seed: everything must be replaced.
    let (len, at) = saved.unwrap_or_else(|| fail("PSO finished before its snapshot"));
    let swarm = place(slot, || {
        Swarm::new(scenario::pso_config(), scenario::PSO_SEED + 1)
    });
    let restored = restore(swarm, &flash[..len]);
    let end = loop {
        match pso_step(swarm, &mut fitness, PSO_SLICE) {
            Ok(p) if p.stopped.is_some() => break Some(p),
            Ok(_) => {}
            Err(_) => break None,
        }
    };
    checks.check(
        "pso.snapshot_resume",
        // Bit for bit (and one comparison of 96 bytes instead of 24 unrolled float ones).
        restored.is_ok()
            && end == Some(first)
            && swarm.best_position().map(f32::to_bits) == best.map(f32::to_bits),
        format_args!("{len}-byte snapshot at iteration {at}, restored into a swarm of another seed: {:?}, same end: {}", restored, end == Some(first)),
    );

    checks.check(
        "servo.hold",
        servo.faults == 0 && servo.worst <= PERIOD_INSNS,
        format_args!(
            "held pose through all background work, worst tick {} instructions, {} faults",
            servo.worst, servo.faults
        ),
    );
}

/// BPNN-PSO's network as the controller uses it: trained on the host (here: the seeded net the
/// host also builds), it predicts particle positions; checked against the host's f64 output.
#[inline(never)]
fn predict(checks: &mut Checks) -> &'static mut Net<f32> {
    let net = place(slot!(Result<Net<f32>, ()>), || Ok(scenario::net()));
    let out = net.forward(&scenario::net_input());
    let worst = out
        .iter()
        .zip(host::NET_OUTPUT.iter())
        .map(|(a, b)| (*a as f64 - b).abs())
        .fold(0.0, f64::max);
    checks.check(
        "bpnn.forward",
        worst < 1e-5,
        format_args!("max |y_f32 - y_f64| = {}e-6", fx(worst * 1e6, 3)),
    );
    net
}

/// Stage 5: the trajectory, one compensated 6-D target per 1 ms tick.
#[inline(never)]
fn trajectory(counter: &mut Counter, checks: &mut Checks) {
    let nominal = scenario::nominal::<f32>();
    let truth = true_robot(0.0);
    let mut fk = ForwardKinematics::<f32, N>::new();
    let mut tracker = Tracker::new(scenario::compensation());
    let (mut worst_tick, mut faults) = (0u32, 0u32);
    let (mut err2, mut worst_err, mut worst_raw, mut worst_dq) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
    for (k, want) in COMMANDS.iter().enumerate() {
        // The interpolator's output for this tick: nominal joints and the pose they give.
        let qn = scenario::nominal_joints::<f32>(k);
        fk_f32(&mut fk, &nominal, &qn);
        let target = Target::Pose(fk.flange_pose());
        let (r, insns) = counter.insns_of(|| {
            irq::free(|cs| {
                MODEL
                    .borrow(cs)
                    .borrow()
                    .as_ref()
                    .map(|m| track(&mut tracker, m, &target, &qn))
            })
        });
        worst_tick = worst_tick.max(insns);
        let q = match r {
            Some(Ok(s)) => s.q,
            _ => {
                faults += 1;
                continue;
            }
        };
        // Where the real robot goes with and without compensation.
        let e = (fk_f32(&mut fk, &truth, &q) - target.point()).norm();
        let raw = (fk_f32(&mut fk, &truth, &qn) - target.point()).norm();
        err2 += e * e;
        worst_err = worst_err.max(e);
        worst_raw = worst_raw.max(raw);
        for (a, b) in q.iter().zip(want.iter()) {
            worst_dq = worst_dq.max((a - b).abs());
        }
    }
    let rms = libm::sqrtf(err2 / TICKS as f32);
    hprintln!(
        "servo: {} ticks, true robot off target by {} mm RMS, {} mm max (uncompensated {} mm max)",
        TICKS,
        fx(rms, 4),
        fx(worst_err, 4),
        fx(worst_raw, 3)
    );
    checks.check(
        "servo.deadline",
        faults == 0 && worst_tick <= PERIOD_INSNS,
        format_args!(
            "{} of {} ticks compensated, worst tick {} of {} instructions",
            TICKS as u32 - faults,
            TICKS,
            worst_tick,
            PERIOD_INSNS
        ),
    );
    checks.check(
        "servo.accuracy",
        faults == 0 && rms <= 0.03 && worst_err <= 0.1 && worst_raw > 10.0 * worst_err,
        format_args!(
            "RMS {} mm ≤ 0.03, max {} mm ≤ 0.1, uncompensated {} mm",
            fx(rms, 4),
            fx(worst_err, 4),
            fx(worst_raw, 3)
        ),
    );
    checks.check(
        "servo.vs_host",
        worst_dq < 2e-5,
        format_args!(
            "joint commands within {} µrad of the host's f64 ones",
            fx(worst_dq * 1e6, 3)
        ),
    );
}

/// The simulated physical robot (the truth the measurements came from), with theta2 and
/// theta3 less `remastered` (rad): the model from before a re-mastering.
fn true_robot(remastered: f32) -> Robot<f32, N> {
    let joints: [Joint<f32>; N] = core::array::from_fn(|j| {
        let r = TRUE_ROWS[j];
        let off = if j == 1 || j == 2 { remastered } else { 0.0 };
        Joint::mdh(r[0], r[1], r[2] - off, r[3])
    });
    let t = scenario::TOOL_MM;
    Robot::new(
        Frame::identity(),
        joints,
        Vector3::new(t[0] as f32, t[1] as f32, t[2] as f32),
    )
    .unwrap_or_else(|_| fail("true robot"))
}

/// Stage 6: instruction counts of the building blocks (see `bench.rs` for the method).
#[inline(never)]
fn benches(counter: &mut Counter, id: &[Measurement<f32, N>], stateful: &Stateful, net: &Net<f32>) {
    let robot = scenario::nominal::<f32>();
    let robot64 = scenario::nominal::<f64>();
    let q = id[0].q;
    let q64 = q.map(|v| v as f64);
    let mut fk = new_fk::<f32>();
    let mut fk64 = new_fk::<f64>();
    let set = scenario::params();

    let n = counter.per_call(|| {
        black_box(fk_f32(black_box(&mut fk), black_box(&robot), black_box(&q)));
    });
    report("fk_f32", n);
    let n = counter.per_call(|| {
        black_box(fk_f64(
            black_box(&mut fk64),
            black_box(&robot64),
            black_box(&q64),
        ));
    });
    report("fk_f64", n);
    fk_f32(&mut fk, &robot, &q);
    let mut cols = [Vector3::zeros(); P];
    let n = counter.per_call(|| {
        jacobian_f32(
            black_box(&fk),
            black_box(&robot),
            black_box(set.as_slice()),
            black_box(&mut cols),
        );
    });
    report("jacobian_f32", n);

    // One 6-D target from the nominal seed (a cold start), with the identified model.
    let model =
        irq::free(|cs| MODEL.borrow(cs).borrow().clone()).unwrap_or_else(|| fail("no model"));
    let qn = scenario::nominal_joints::<f32>(0);
    fk_f32(&mut fk, &robot, &qn);
    let target = Target::Pose(fk.flange_pose());
    let cfg = scenario::compensation();
    if let Ok(s) = compensate_f32(&model, &target, &qn, &cfg) {
        hprintln!(
            "compensate: cold start from the nominal seed, {} Newton steps",
            s.iterations
        );
    }
    let n = counter.per_call(|| {
        let _ = black_box(compensate_f32(
            black_box(&model),
            black_box(&target),
            black_box(&qn),
            &cfg,
        ));
    });
    report("compensate_f32", n);

    report("lm_pose_f32", stateful.lm_pose);
    report("lm_pose6d_f32", stateful.lm_pose6d);
    report("lm_point_multi_f32", stateful.lm_point_multi);
    report("lm_remaster_f32", stateful.lm_remaster);
    report("pso_particle_f32", stateful.pso_particle);

    let x = scenario::net_input::<f32>();
    let n = counter.per_call(|| {
        black_box(bpnn_forward_f32(black_box(net), black_box(&x)));
    });
    report("bpnn_forward_f32", n);
}

fn report(name: &str, insns: f32) {
    hprintln!("BENCH {} {}", name, libm::roundf(insns) as u32);
}

#[inline(never)]
fn fk_f32(fk: &mut ForwardKinematics<f32, N>, robot: &Robot<f32, N>, q: &[f32; N]) -> Vector3<f32> {
    fk.compute(robot, q)
}

/// Largest distance (mm) of `robot`'s f32 points at the first poses of `id` from the host's.
#[inline(never)]
fn fk_worst(
    fk: &mut ForwardKinematics<f32, N>,
    robot: &Robot<f32, N>,
    id: &[Measurement<f32, N>],
    want: &[[f32; 3]],
) -> f32 {
    let mut worst = 0.0f32;
    for (m, w) in id.iter().zip(want.iter()) {
        let p = fk_f32(fk, robot, &m.q);
        worst = worst.max((p - Vector3::from(*w)).norm());
    }
    worst
}

#[inline(never)]
fn fk_f64(fk: &mut ForwardKinematics<f64, N>, robot: &Robot<f64, N>, q: &[f64; N]) -> Vector3<f64> {
    fk.compute(robot, q)
}

#[inline(never)]
fn jacobian_f32(
    fk: &ForwardKinematics<f32, N>,
    robot: &Robot<f32, N>,
    set: &[Param],
    out: &mut [Vector3<f32>; P],
) {
    let _ = fk.identification_jacobian(robot, set, out);
}

#[inline(never)]
fn compensate_f32(
    robot: &Robot<f32, N>,
    target: &Target<f32>,
    seed: &[f32; N],
    cfg: &kinecal::compensate::Config<f32>,
) -> Result<kinecal::compensate::Solution<f32, N>, kinecal::compensate::CompensateError<f32, N>> {
    compensate(robot, target, seed, cfg)
}

#[inline(never)]
fn lm_step(
    lm: &mut Lm,
    data: &[Measurement<f32, N>],
    budget: usize,
) -> Result<LmProgress<f32>, LmError> {
    lm.step(data, budget)
}

#[inline(never)]
fn pso_step(
    swarm: &mut Swarm,
    fitness: &mut PositionFitness<'_, f32, N, 0, P>,
    budget: usize,
) -> Result<kinecal::identify::pso::PsoProgress<f32>, PsoError> {
    swarm.step(fitness, budget)
}

#[inline(never)]
fn save<S: Snapshot>(
    stepper: &S,
    flash: &mut &mut [u8],
) -> Result<(), kinecal::io::snapshot::SnapshotError> {
    stepper.save(flash)
}

#[inline(never)]
fn restore<S: Snapshot>(
    stepper: &mut S,
    mut flash: &[u8],
) -> Result<(), kinecal::io::snapshot::SnapshotError> {
    stepper.restore(&mut flash)
}

#[inline(never)]
fn track(
    tracker: &mut Tracker<f32, N>,
    model: &Robot<f32, N>,
    target: &Target<f32>,
    nominal: &[f32; N],
) -> Result<kinecal::compensate::Solution<f32, N>, kinecal::compensate::CompensateError<f32, N>> {
    tracker.next(model, target, nominal)
}

#[inline(never)]
fn bpnn_forward_f32(net: &Net<f32>, x: &[f32; P]) -> [f32; P] {
    net.forward(x)
}

/// A fresh kinematics workspace (out of line: one copy of its initialisation per scalar).
#[inline(never)]
fn new_fk<T: kinecal::Real>() -> ForwardKinematics<T, N> {
    ForwardKinematics::new()
}

fn v3(a: &[f64; 3]) -> Vector3<f32> {
    Vector3::new(a[0] as f32, a[1] as f32, a[2] as f32)
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
