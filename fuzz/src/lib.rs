//! The fuzz targets' bodies and the helpers they share: value generators, the fault-injecting reader, reference
//! robots, known-issue gates and invariant assertions.

// The targets, one module each: `run(data)` takes one input and asserts the target's invariants.
// The cargo-fuzz binaries in fuzz_targets/ call them; host-tests/tests/library/fuzz_corpus.rs
// replays the committed corpus and regressions through them with the stable toolchain.
pub mod compensation;
pub mod construction;
pub mod csv_reader;
pub mod decimal;
pub mod kinematics;
pub mod measurement_file;
pub mod model_blob;
pub mod robot_file;
pub mod snapshots;
pub mod steppers;
pub mod urdf;

use arbitrary::{Arbitrary, Unstructured};
use kinecal::{Frame, Joint, Robot};
use nalgebra::Vector3;
use std::sync::OnceLock;

/// True when the known issue `name` is listed in `KINECAL_FUZZ_SKIP` (comma separated): the
/// target then skips inputs that would trip that (already reported) invariant, so that a long
/// campaign can explore past it. Unset, every invariant is asserted.
pub fn skip(name: &str) -> bool {
    static SKIP: OnceLock<Vec<String>> = OnceLock::new();
    SKIP.get_or_init(|| {
        std::env::var("KINECAL_FUZZ_SKIP")
            .unwrap_or_default()
            .split(',')
            .map(|s| s.trim().to_string())
            .filter(|s| !s.is_empty())
            .collect()
    })
    .iter()
    .any(|s| s == name || s == "all")
}

/// Asserts an invariant with its name (the name is what the report and the regressions use).
macro_rules! invariant {
    ($name:expr, $cond:expr $(,)?) => {{
        // Bound first: `!(a <= b)` is meant (NaN fails the invariant).
        let held: bool = $cond;
        if !held {
            panic!("invariant `{}` failed: {}", $name, stringify!($cond));
        }
    }};
    ($name:expr, $cond:expr, $($fmt:tt)+) => {{
        let held: bool = $cond;
        if !held {
            panic!("invariant `{}` failed: {}: {}", $name, stringify!($cond), format!($($fmt)+));
        }
    }};
}
pub(crate) use invariant;

/// Extreme and special values the generators mix in.
pub const SPECIAL: [f64; 16] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    1e-300,
    f64::MIN_POSITIVE,
    5e-324,
    1e15,
    -1e15,
    1e154,
    1e308,
    -1e308,
    f64::MAX,
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
];

/// Any `f64`: mostly `nominal ± spread`, sometimes a special value or raw bits (NaN, ∞, huge).
pub fn any_f64(u: &mut Unstructured, nominal: f64, spread: f64) -> f64 {
    match u.int_in_range(0..=9u8).unwrap_or(9) {
        0 => f64::from_bits(u64::arbitrary(u).unwrap_or(0)),
        1 => SPECIAL[u.int_in_range(0..=15usize).unwrap_or(0)],
        _ => near(u, nominal, spread),
    }
}

/// A finite `f64`, sometimes extreme (up to ±`f64::MAX`), mostly `nominal ± spread`.
pub fn finite_f64(u: &mut Unstructured, nominal: f64, spread: f64) -> f64 {
    let v = any_f64(u, nominal, spread);
    if v.is_finite() {
        v
    } else {
        nominal
    }
}

/// `nominal ± spread` (uniform in a 32-bit grid), `nominal` when the input is exhausted.
pub fn near(u: &mut Unstructured, nominal: f64, spread: f64) -> f64 {
    let k = i32::arbitrary(u).unwrap_or(0);
    nominal + spread * (k as f64 / i32::MAX as f64)
}

/// Bytes-driven xorshift for short-read sizes.
fn xorshift(s: &mut u32) -> u32 {
    let mut x = *s;
    x ^= x << 13;
    x ^= x >> 17;
    x ^= x << 5;
    *s = x;
    x
}

/// The plan of a [`FaultReader`], decoded from the first [`FaultPlan::LEN`] input bytes.
#[derive(Clone, Copy, Debug)]
pub struct FaultPlan {
    /// Largest read (1..=64 bytes); each read returns 1..=max_chunk bytes.
    pub max_chunk: usize,
    /// Every `transient_every`-th read call fails once (0 = never).
    pub transient_every: u32,
    /// Reads fail for good once this many bytes were delivered (None = never).
    pub fail_after: Option<usize>,
    /// Seed of the short-read sizes.
    pub seed: u32,
}

impl FaultPlan {
    /// Bytes of input the plan takes.
    pub const LEN: usize = 6;

    /// The plan of `b` (shorter input: no faults, one-byte reads).
    pub fn decode(b: &[u8]) -> FaultPlan {
        let g = |i: usize| b.get(i).copied().unwrap_or(0);
        let transient = g(1);
        let persistent = u16::from_le_bytes([g(2), g(3)]);
        FaultPlan {
            max_chunk: 1 + (g(0) as usize % 64),
            transient_every: if transient < 128 {
                0
            } else {
                (transient - 126) as u32
            },
            fail_after: if persistent >= 0x8000 {
                Some((persistent - 0x8000) as usize)
            } else {
                None
            },
            seed: u16::from_le_bytes([g(4), g(5)]) as u32 | 0x1_0000,
        }
    }

    /// True when the plan injects no error (short reads only).
    pub fn error_free(&self) -> bool {
        self.transient_every == 0 && self.fail_after.is_none()
    }
}

/// The error a [`FaultReader`] injects.
#[derive(Debug)]
pub struct InjectedError;

impl core::fmt::Display for InjectedError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("injected I/O error")
    }
}
impl core::error::Error for InjectedError {}
impl embedded_io::Error for InjectedError {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

/// An `embedded_io::Read` over bytes that injects faults (after smoltcp's `FaultInjector`):
/// short reads, transient errors (the next call succeeds) and a persistent error once a given
/// number of bytes was delivered.
#[derive(Debug)]
pub struct FaultReader<'a> {
    data: &'a [u8],
    pos: usize,
    plan: FaultPlan,
    rng: u32,
    calls: u32,
    /// Transient errors returned so far.
    pub transient_injected: u32,
    /// Persistent errors returned so far (shared, so a caller can watch it while a reader
    /// owns a borrow of this one).
    pub persistent_injected: std::rc::Rc<core::cell::Cell<u32>>,
}

impl<'a> FaultReader<'a> {
    /// A reader of `data` following `plan`.
    pub fn new(data: &'a [u8], plan: FaultPlan) -> Self {
        FaultReader {
            data,
            pos: 0,
            plan,
            rng: plan.seed,
            calls: 0,
            transient_injected: 0,
            persistent_injected: Default::default(),
        }
    }
}

impl embedded_io::ErrorType for FaultReader<'_> {
    type Error = InjectedError;
}

impl embedded_io::Read for FaultReader<'_> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, InjectedError> {
        if buf.is_empty() {
            return Ok(0);
        }
        self.calls = self.calls.wrapping_add(1);
        if let Some(n) = self.plan.fail_after {
            if n < self.data.len() && self.pos >= n {
                self.persistent_injected
                    .set(self.persistent_injected.get() + 1);
                return Err(InjectedError);
            }
        }
        if self.plan.transient_every != 0 && self.calls.is_multiple_of(self.plan.transient_every) {
            self.transient_injected += 1;
            return Err(InjectedError);
        }
        let k = 1 + xorshift(&mut self.rng) as usize % self.plan.max_chunk;
        let mut end = (self.pos + k)
            .min(self.data.len())
            .min(self.pos + buf.len());
        if let Some(n) = self.plan.fail_after {
            if n > self.pos {
                end = end.min(n);
            }
        }
        let got = end - self.pos;
        buf[..got].copy_from_slice(&self.data[self.pos..end]);
        self.pos = end;
        Ok(got)
    }
}

/// The 3-joint arm of the compensation example (f64, mm, rad), its effect values kept in `V`.
pub fn arm3<V: kinecal::ValueStorage>() -> Robot<f64, 3, V> {
    Robot::new(
        Frame::identity(),
        [
            Joint::mdh_deg(0.0, 0.0, 0.0, 400.0),
            Joint::mdh_deg(90.0, 100.0, 0.0, 0.0),
            Joint::mdh_deg(0.0, 500.0, 0.0, 0.0),
        ],
        Vector3::new(300.0, 0.0, 0.0),
    )
    .expect("nominal arm")
}

/// The nominal UR10 of `data/ur10/robot.toml`.
pub fn ur10<V: kinecal::ValueStorage>() -> Robot<f64, 6, V> {
    let mut rows = [
        Joint::mdh_deg(0.0, 0.0, 0.0, 118.0),
        Joint::mdh_deg(90.0, 0.0, 180.0, 0.0),
        Joint::mdh_deg(0.0, 612.7, 0.0, 0.0),
        Joint::mdh_deg(0.0, 571.6, 0.0, 163.9),
        Joint::mdh_deg(-90.0, 0.0, 0.0, 115.7),
        Joint::mdh_deg(90.0, 0.0, 180.0, 92.2),
    ];
    for r in rows.iter_mut() {
        r.lower = -2.0 * std::f64::consts::PI;
        r.upper = 2.0 * std::f64::consts::PI;
    }
    Robot::new(Frame::identity(), rows, Vector3::new(0.0, 0.0, 109.0)).expect("nominal UR10")
}

/// Every number of a robot's description (rows, base, tool, effect values, coupling ratios).
pub fn robot_numbers<const N: usize, V: kinecal::ValueStorage>(r: &Robot<f64, N, V>) -> Vec<f64> {
    let mut v = Vec::new();
    for j in r.joints() {
        v.extend([j.alpha, j.a, j.theta, j.d, j.beta, j.lower, j.upper]);
    }
    let b = r.base();
    for c in [b.x, b.y, b.z, b.o] {
        v.extend(c.iter().copied());
    }
    v.extend(r.tool().iter().copied());
    v.extend(r.effects().values().iter().copied());
    for e in r.effects().iter() {
        v.extend([e.start, e.step]);
    }
    for (_, _, ratio) in r.couplings().iter() {
        v.push(ratio);
    }
    v
}

/// True when every number of the robot is finite and its reach is finite and positive.
pub fn robot_finite<const N: usize, V: kinecal::ValueStorage>(r: &Robot<f64, N, V>) -> bool {
    robot_numbers(r).iter().all(|x| x.is_finite()) && r.reach().is_finite() && r.reach() > 0.0
}

/// Largest magnitude of a robot's lengths and effect values (for "moderate" gates).
pub fn robot_magnitude<const N: usize, V: kinecal::ValueStorage>(r: &Robot<f64, N, V>) -> f64 {
    robot_numbers(r).iter().fold(0.0f64, |m, x| m.max(x.abs()))
}

/// A vector's components are all finite.
pub fn vec_finite(v: &Vector3<f64>) -> bool {
    v.iter().all(|x| x.is_finite())
}

/// Distance in units in the last place between two finite doubles of the same sign convention
/// (via the ordered integer mapping); `u64::MAX` when one is NaN.
pub fn ulps(a: f64, b: f64) -> u64 {
    if a.is_nan() || b.is_nan() {
        return u64::MAX;
    }
    let key = |x: f64| {
        let i = x.to_bits() as i64;
        if i < 0 {
            i64::MIN - i
        } else {
            i
        }
    };
    (key(a) as i128 - key(b) as i128).unsigned_abs() as u64
}

/// An `embedded_io::Write` into a `Vec<u8>`.
#[derive(Debug, Default)]
pub struct VecWriter(pub Vec<u8>);

impl embedded_io::ErrorType for VecWriter {
    type Error = core::convert::Infallible;
}

impl embedded_io::Write for VecWriter {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.0.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

/// `n` measurements of `robot` at readings spread over the joint range (deterministic).
pub fn simulate<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
    n: usize,
) -> Vec<kinecal::Measurement<f64, N>> {
    (0..n)
        .map(|k| {
            let q: [f64; N] = std::array::from_fn(|j| {
                ((k * 7 + j * 3) % 11) as f64 * 0.37 - 1.8 + 0.01 * j as f64
            });
            kinecal::Measurement {
                q,
                point: kinecal::forward::point(robot, &q),
                ..Default::default()
            }
        })
        .collect()
}

/// The same robot with every row slightly changed (an "identified" robot).
pub fn perturbed<const N: usize, V: kinecal::ValueStorage>(
    robot: &Robot<f64, N, V>,
) -> Robot<f64, N, V> {
    let mut r = robot.clone();
    for i in 0..N {
        let mut j = *r.joint(i).unwrap();
        j.a += 0.3 * (i as f64 + 1.0);
        j.d -= 0.2;
        j.theta += 0.002;
        j.alpha -= 0.001;
        r.set_joint(i, j).unwrap();
    }
    r
}
