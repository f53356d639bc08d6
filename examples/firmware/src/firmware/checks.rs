//! The self-checks' tally and the fixed-point printing of their values.

use cortex_m_semihosting::hprintln;

/// Self-check results.
pub(super) struct Checks {
    pub(super) failed: u32,
    pub(super) passed: u32,
}

impl Checks {
    pub(super) fn check(&mut self, name: &str, ok: bool, detail: core::fmt::Arguments) {
        if ok {
            self.passed += 1;
            hprintln!("CHECK ok   {}: {}", name, detail);
        } else {
            self.failed += 1;
            hprintln!("CHECK FAIL {}: {}", name, detail);
        }
    }
    /// `|got - want| <= tol`.
    pub(super) fn close(&mut self, name: &str, got: f64, want: f64, tol: f64) {
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
pub(super) struct Fixed(f64, u8);

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

pub(super) fn fx(x: impl Into<f64>, decimals: u8) -> Fixed {
    Fixed(x.into(), decimals)
}
