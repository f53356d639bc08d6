//! Single-precision `sin`/`cos` for joint angles.
//!
//! libm's `sinf` evaluates in software double precision and costs ~1,200 instructions on a
//! Cortex-M4F, which would dominate forward kinematics. This version stays in `f32`: a
//! three-part Cody–Waite reduction by π/2 (exact for |x| up to ~1e4 rad, far beyond any joint
//! reading) and the Cephes minimax polynomials on [−π/4, π/4], max error ≈ 1 ulp there.

// Cephes coefficients and the π/2 split are kept digit for digit as published.
#![allow(clippy::excessive_precision)]

const FRAC_2_PI: f32 = core::f32::consts::FRAC_2_PI;
// π/2 split so that k·DP1 and k·DP2 are exact in f32 for |k| < 2^12.
const DP1: f32 = 1.570_312_5;
const DP2: f32 = 4.837_512_969_970_703_1e-4;
const DP3: f32 = 7.549_789_948_768_648e-8;

/// `(sin x, cos x)` in `f32`. Non-finite input gives NaN, like `sinf`; every finite input gives
/// values in [−1, 1]. Beyond |x| ≈ 6.6e6 rad, far outside any joint range, the result is that of
/// the angle 0: bounded, not accurate (an `f32` holds such an angle only to a few radians, and
/// a robot model refuses such joint values before they get here).
#[inline]
pub fn sincos_f32(x: f32) -> (f32, f32) {
    // Round to nearest quadrant without libm: add and subtract 1.5·2^23 (valid for |x·2/π| < 2^22).
    let t = x * FRAC_2_PI;
    let (x, k) = if t.abs() < 4_194_304.0 {
        const MAGIC: f32 = 12_582_912.0;
        (x, (t + MAGIC) - MAGIC)
    } else {
        // Far outside any joint range: the angle 0 (bounded values; `x − x` keeps NaN and
        // turns ±∞ into NaN).
        #[allow(clippy::eq_op)]
        let zero_or_nan = x - x;
        (zero_or_nan, 0.0)
    };
    let r = ((x - k * DP1) - k * DP2) - k * DP3;
    let z = r * r;
    let s = r + r * z * (-1.666_665_461_1e-1 + z * (8.332_160_873_6e-3 + z * -1.951_529_589_1e-4));
    let c = 1.0 - 0.5 * z
        + z * z
            * (4.166_664_568_298_827e-2
                + z * (-1.388_731_625_493_765e-3 + z * 2.443_315_711_809_948e-5));
    // Quadrant from the low two bits of k (k is an exact small integer here).
    match (k as i32) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

// π/2 in three 33-bit pieces (fdlibm's pio2_1, pio2_2, pio2_3): k·piece is exact for |k| < 2^20.
const PIO2_1: f64 = 1.570_796_326_734_125_614_17e0;
const PIO2_2: f64 = 6.077_100_506_303_965_976_60e-11;
const PIO2_3: f64 = 2.022_266_248_711_166_455_80e-21;
const PIO2_3T: f64 = 8.478_427_660_368_899_569_97e-32;

/// `(sin x, cos x)` in `f64` without libm's `rem_pio2` tables (~8 KB of flash on a Cortex-M):
/// three-part Cody–Waite reduction, exact for |x| < 2^19·π/2 (~8e5 rad), then fdlibm's kernel
/// polynomials on [−π/4, π/4] (error below 1 ulp there). Larger or non-finite input gives NaN
/// for non-finite and a less accurate result for huge angles, never a panic.
#[inline]
pub fn sincos_f64(x: f64) -> (f64, f64) {
    let t = x * core::f64::consts::FRAC_2_PI;
    let k = if t.abs() < 524_288.0 {
        const MAGIC: f64 = 6_755_399_441_055_744.0; // 1.5 · 2^52
        (t + MAGIC) - MAGIC
    } else if t.is_finite() {
        // Far outside any joint range: reduce approximately rather than fail.
        let q = t - libm::trunc(t / 4.0) * 4.0;
        let w = libm::trunc(q);
        return sincos_f64((q - w + (w as i64 & 3) as f64) * core::f64::consts::FRAC_PI_2);
    } else {
        0.0
    };
    let r = (((x - k * PIO2_1) - k * PIO2_2) - k * PIO2_3) - k * PIO2_3T;
    let z = r * r;
    let s = r + r
        * z
        * (-1.666_666_666_666_663_243_48e-1
            + z * (8.333_333_333_322_489_461_24e-3
                + z * (-1.984_126_982_985_794_931_34e-4
                    + z * (2.755_731_370_707_006_767_89e-6
                        + z * (-2.505_076_025_340_686_341_95e-8
                            + z * 1.589_690_995_211_550_102_21e-10)))));
    let c = 1.0 - 0.5 * z
        + z * z
            * (4.166_666_666_666_660_190_37e-2
                + z * (-1.388_888_888_887_410_957_49e-3
                    + z * (2.480_158_728_947_672_941_78e-5
                        + z * (-2.755_731_435_139_066_330_35e-7
                            + z * (2.087_572_321_298_174_827_90e-9
                                + z * -1.135_964_755_778_819_482_65e-11)))));
    // The quadrant without branches (random joint angles would mispredict a `match` half the
    // time): odd quadrants swap sine and cosine, and the sign bits follow bit 1 of q and q + 1.
    let q = k as i64 as u64;
    let swap = 0u64.wrapping_sub(q & 1);
    let (sb, cb) = (s.to_bits(), c.to_bits());
    let sin = (sb & !swap) | (cb & swap);
    let cos = (cb & !swap) | (sb & swap);
    (
        f64::from_bits(sin ^ ((q & 2) << 62)),
        f64::from_bits(cos ^ ((q.wrapping_add(1) & 2) << 62)),
    )
}
