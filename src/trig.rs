//! Single-precision `sin`/`cos` for joint angles.
//!
//! libm's `sinf` evaluates in software double precision and costs ~1,200 instructions on a
//! Cortex-M4F, which would dominate forward kinematics. This version stays in `f32`: a
//! three-part Cody–Waite reduction by π/2 (exact for |x| up to ~1e4 rad, far beyond any joint
//! reading) and the Cephes minimax polynomials on [−π/4, π/4], max error ≈ 1 ulp there.

const FRAC_2_PI: f32 = core::f32::consts::FRAC_2_PI;
// π/2 split so that k·DP1 and k·DP2 are exact in f32 for |k| < 2^12.
const DP1: f32 = 1.570_312_5;
const DP2: f32 = 4.837_512_969_970_703_1e-4;
const DP3: f32 = 7.549_789_948_768_648e-8;

/// `(sin x, cos x)` in `f32`. Non-finite input gives NaN, like `sinf`.
#[inline]
pub fn sincos_f32(x: f32) -> (f32, f32) {
    // Round to nearest quadrant without libm: add and subtract 1.5·2^23 (valid for |x·2/π| < 2^22).
    let t = x * FRAC_2_PI;
    let k = if t.abs() < 4_194_304.0 {
        const MAGIC: f32 = 12_582_912.0;
        (t + MAGIC) - MAGIC
    } else {
        // Far outside any joint range: give up accuracy, not safety.
        0.0
    };
    let r = ((x - k * DP1) - k * DP2) - k * DP3;
    let z = r * r;
    let s = r + r * z * (-1.666_665_461_1e-1 + z * (8.332_160_873_6e-3 + z * -1.951_529_589_1e-4));
    let c = 1.0 - 0.5 * z
        + z * z * (4.166_664_568_298_827e-2 + z * (-1.388_731_625_493_765e-3 + z * 2.443_315_711_809_948e-5));
    // Quadrant from the low two bits of k (k is an exact small integer here).
    match (k as i32) & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}
