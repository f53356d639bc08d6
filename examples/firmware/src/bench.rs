//! Exact instruction counts and the stack high-water mark, on QEMU.
//!
//! The runner starts QEMU with `-icount shift=0`: the virtual clock advances exactly 1 ns per
//! executed instruction, and SysTick (on the 25 MHz core clock of the MPS2 board) ticks once per
//! 40 ns, so SysTick counts instructions in steps of 40. Repeating a measured call `REPS` times
//! and dividing brings the step below one instruction; the loop's own overhead is measured the
//! same way and subtracted. [`Counter::new`] verifies the 40-to-1 ratio on a loop of known
//! length, so a run without `-icount` fails instead of printing wall-clock noise.
//!
//! A stepper's unit of work (one LM pose, one PSO particle) changes its state, so it cannot be
//! repeated on the same state: [`Counter::per_call_once`] measures a run of consecutive units
//! once instead (resolution 40 / units).
//!
//! `bench_start`/`bench_stop` bracket one measured call (or run) as well, for QEMU's
//! instruction-counting plugin: `.ci/crosscheck-insncount` compares both in CI.

use core::hint::black_box;
use core::ptr;
use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;

/// Instructions per SysTick tick under `-icount shift=0` on the MPS2 board (25 MHz core clock).
pub const INSNS_PER_TICK: u32 = 40;
/// Repetitions of every measured call: the count's resolution is `INSNS_PER_TICK / REPS`.
const REPS: u32 = 256;
const MASK: u32 = 0x00FF_FFFF;

/// Free-running SysTick, read as an instruction counter.
pub struct Counter {
    syst: SYST,
    /// Instructions of one iteration of an empty measured loop.
    overhead: f32,
    /// Markers placed so far (the plugin numbers marker pairs in execution order).
    marks: u32,
}

#[derive(Debug)]
pub struct NotInstructionCount {
    pub ticks: u32,
    pub expected: u32,
}

impl Counter {
    /// Starts SysTick and checks that it counts instructions.
    pub fn new(mut syst: SYST) -> Result<Self, NotInstructionCount> {
        syst.set_clock_source(SystClkSource::Core);
        syst.set_reload(MASK);
        syst.clear_current();
        syst.disable_interrupt();
        syst.enable_counter();
        let mut c = Self {
            syst,
            overhead: 0.0,
            marks: 0,
        };
        // 2 instructions per iteration: 400,000 instructions apart = 10,000 ticks.
        let a = c.ticks_of(|| spin(100_000));
        let b = c.ticks_of(|| spin(300_000));
        let expected = 400_000 / INSNS_PER_TICK;
        let ticks = b.wrapping_sub(a);
        if ticks.abs_diff(expected) > 1 {
            return Err(NotInstructionCount { ticks, expected });
        }
        c.overhead = c.per_call_raw(marker_free);
        Ok(c)
    }

    /// SysTick ticks spent in `f` (one call; at most 2^24 ticks).
    fn ticks_of<F: FnOnce()>(&mut self, f: F) -> u32 {
        let _ = self.syst.has_wrapped();
        let s = SYST::get_current();
        f();
        let e = SYST::get_current();
        let wrapped = self.syst.has_wrapped();
        let t = s.wrapping_sub(e) & MASK;
        // One wrap is accounted for by the mask; a measured span longer than 2^24 ticks
        // (671 M instructions) is not something this firmware does.
        if wrapped && t == 0 {
            MASK + 1
        } else {
            t
        }
    }

    /// Instructions of one run of `f` (resolution 40): for long spans where ±40 does not matter.
    pub fn insns_of<R, F: FnOnce() -> R>(&mut self, f: F) -> (R, u32) {
        let mut out = None;
        let t = self.ticks_of(|| out = Some(f()));
        match out {
            Some(r) => (r, t * INSNS_PER_TICK),
            None => unreachable!("f ran"),
        }
    }

    fn per_call_raw<F: FnMut()>(&mut self, mut f: F) -> f32 {
        let t = self.ticks_of(|| {
            for _ in 0..black_box(REPS) {
                f();
            }
        });
        (t * INSNS_PER_TICK) as f32 / REPS as f32
    }

    /// Instructions of one call of `f`, loop overhead removed (resolution 40/256).
    /// `f` must do the same work on every call. One extra call is bracketed by the plugin's
    /// markers, and `MEASURE <k> <insns>` is printed for the cross-check (`.ci/crosscheck-insncount`).
    pub fn per_call<F: FnMut()>(&mut self, mut f: F) -> f32 {
        let id = self.next_mark();
        bench_start(id);
        f();
        bench_stop(id);
        let n = self.per_call_raw(f) - self.overhead;
        measured(id, libm::roundf(n) as u32);
        n
    }

    /// Instructions per call of `calls` consecutive calls of a stateful `f` (each call moves a
    /// stepper on by one unit of work, so it cannot be repeated on the same state), measured
    /// once: resolution 40/`calls`. The whole block is bracketed by the plugin's markers and
    /// its total printed as `MEASURE <k> <insns>`.
    pub fn per_call_once<F: FnMut()>(&mut self, calls: u32, mut f: F) -> f32 {
        let id = self.next_mark();
        let t = self.ticks_of(|| {
            bench_start(id);
            for _ in 0..black_box(calls) {
                f();
            }
            bench_stop(id);
        });
        let total = t * INSNS_PER_TICK;
        measured(id, total);
        (total as f32 - self.overhead * calls as f32) / calls as f32
    }

    /// The next marker pair's number.
    fn next_mark(&mut self) -> u32 {
        let id = self.marks;
        self.marks += 1;
        id
    }
}

/// Prints `MEASURE <k> <insns>` (out of line: one copy of the formatting for every measured
/// closure).
#[inline(never)]
fn measured(id: u32, insns: u32) {
    cortex_m_semihosting::hprintln!("MEASURE {} {}", id, insns);
}

#[inline(never)]
fn marker_free() {
    black_box(());
}

/// Exactly `2n` instructions in the loop (n ≥ 1).
#[inline(never)]
fn spin(n: u32) {
    // SAFETY: register-only arithmetic, no memory or stack access.
    unsafe {
        core::arch::asm!("2:", "subs {0}, {0}, #1", "bne 2b", inout(reg) n => _, options(nomem, nostack));
    }
}

static mut MARK: u32 = 0;

/// Start marker for the instruction-counting plugin (distinct body so LTO keeps it apart).
#[no_mangle]
#[inline(never)]
pub extern "C" fn bench_start(id: u32) {
    // SAFETY: single-threaded firmware; a volatile store keeps the body from being removed.
    unsafe { ptr::write_volatile(ptr::addr_of_mut!(MARK), id) }
}

/// Stop marker for the instruction-counting plugin.
#[no_mangle]
#[inline(never)]
pub extern "C" fn bench_stop(id: u32) {
    // SAFETY: as above; `!id` makes the body differ from bench_start's.
    unsafe { ptr::write_volatile(ptr::addr_of_mut!(MARK), !id) }
}

/// Bytes of stack ever used: cortex-m-rt's `paint-stack` fills `_stack_end.._stack_start`
/// with `0xCCCC_CCCC` at reset; the lowest word no longer holding it is the high-water mark.
pub fn stack_high_water() -> usize {
    extern "C" {
        static _stack_start: u32;
        static _stack_end: u32;
    }
    let top = ptr::addr_of!(_stack_start) as usize;
    let mut p = ptr::addr_of!(_stack_end);
    // SAFETY: every address in `_stack_end.._stack_start` is RAM reserved for the stack.
    unsafe {
        while (p as usize) < top && ptr::read_volatile(p) == 0xCCCC_CCCC {
            p = p.add(1);
        }
    }
    top - p as usize
}
