//! A small decimal-to-`f64` parser for the `lean-parse` feature (firmware: no core float parser).

/// Exact powers of ten representable in `f64` (Clinger's fast path).
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];

/// Largest integer below which every integer is exactly an `f64`.
const EXACT_INT: u64 = 1 << 53;

/// Parses a decimal number (`-12.5`, `3e-4`, `nan`, `inf`) without core's float parser, which
/// costs ~16 KB of flash and ~11k instructions per cell on a Cortex-M4F.
///
/// Write the number as `M · 10^e` with `M` the integer of its significant digits (leading and
/// trailing zeros removed). **Correctly rounded** — bit-identical to `str::parse::<f64>` — when
/// `M ≤ 2^53` and either `-22 ≤ e ≤ 22`, or `e > 22` with `M · 10^(e-22) ≤ 2^53` (Clinger's fast
/// path: one exact integer converted and one multiplication or division by an exactly
/// representable power of ten, each correctly rounded). That covers every number with at most
/// 15 significant digits, magnitude below 1e37 and no significant digit beyond the 22nd decimal
/// place: every measurement file (degrees and millimetres with ≤ 15 digits).
///
/// Outside the fast path (more than 2^53 in the digits, |value| ≥ 1e37, significant digits
/// beyond the 22nd decimal, subnormals) the result is **not** always correctly rounded: it is
/// within 16 ulp of core's (at most 16 roundings — the mantissa, up to 14 multiplications or
/// divisions by 1e22, the last power of ten — each within 2^-53 of the value); measured at most
/// 6 ulp over 400,000 random numbers of up to 22 digits with exponents -345..320
/// (`host-tests/tests/command_line/csv_hardening.rs`). Overflow to infinity and underflow to zero happen
/// within the same bound of the right place. `nan`/`inf` parse, so the caller can name them as
/// non-finite instead of "not a number".
pub fn parse_decimal(s: &str) -> Option<f64> {
    let b = s.as_bytes();
    let (neg, mut i) = match b.first() {
        Some(b'-') => (true, 1),
        Some(b'+') => (false, 1),
        _ => (false, 0),
    };
    // Bytes, not `&s[i..]`: no char-boundary check, whose panic path costs ~1.7 KB of flash.
    let rest = b.get(i..).unwrap_or(&[]);
    let special = if rest.eq_ignore_ascii_case(b"nan") {
        Some(f64::NAN)
    } else if rest.eq_ignore_ascii_case(b"inf") || rest.eq_ignore_ascii_case(b"infinity") {
        Some(f64::INFINITY)
    } else {
        None
    };
    if let Some(v) = special {
        return Some(if neg { -v } else { v });
    }
    let mut mantissa: u64 = 0;
    let mut digits = 0u32;
    let mut exp10: i64 = 0;
    let mut truncated = false;
    let mut seen_digit = false;
    let mut seen_point = false;
    while i < b.len() {
        let c = b[i];
        if c.is_ascii_digit() {
            seen_digit = true;
            if mantissa == 0 && c == b'0' {
                // Leading zeros carry no significance.
                if seen_point {
                    exp10 -= 1;
                }
            } else if digits < 19 {
                mantissa = mantissa * 10 + (c - b'0') as u64;
                digits += 1;
                if seen_point {
                    exp10 -= 1;
                }
            } else {
                truncated |= c != b'0';
                if !seen_point {
                    exp10 += 1;
                }
            }
        } else if c == b'.' && !seen_point {
            seen_point = true;
        } else {
            break;
        }
        i += 1;
    }
    if !seen_digit {
        return None;
    }
    if i < b.len() {
        if b[i] != b'e' && b[i] != b'E' {
            return None;
        }
        i += 1;
        let (eneg, start) = match b.get(i) {
            Some(b'-') => (true, i + 1),
            Some(b'+') => (false, i + 1),
            _ => (false, i),
        };
        if start >= b.len() {
            return None;
        }
        let mut e: i64 = 0;
        for &c in &b[start..] {
            if !c.is_ascii_digit() {
                return None;
            }
            e = (e * 10 + (c - b'0') as i64).min(100_000);
        }
        exp10 += if eneg { -e } else { e };
    }
    // Trailing zeros carry no significance either: `1.500000000000000000` is 15 · 10^-1.
    while mantissa != 0 && mantissa % 10 == 0 {
        mantissa /= 10;
        exp10 += 1;
    }
    // Clinger's fast path, extended: a large exponent moved into the mantissa while it stays
    // an exact integer (`1e23` = 10 · 1e22).
    if !truncated && (23..=22 + 15).contains(&exp10) {
        let m = mantissa.saturating_mul(POW10[(exp10 - 22) as usize] as u64);
        if m <= EXACT_INT {
            mantissa = m;
            exp10 = 22;
        }
    }
    let v = if mantissa == 0 {
        0.0
    } else if !truncated && mantissa <= EXACT_INT && (-22..=22).contains(&exp10) {
        let m = mantissa as f64;
        if exp10 >= 0 {
            m * POW10[exp10 as usize]
        } else {
            m / POW10[(-exp10) as usize]
        }
    } else if exp10 > 330 {
        f64::INFINITY
    } else if exp10 < -360 {
        0.0
    } else {
        let mut v = mantissa as f64;
        let mut e = exp10;
        while e > 22 {
            v *= 1e22;
            e -= 22;
        }
        while e < -22 {
            v /= 1e22;
            e += 22;
        }
        if e >= 0 {
            v * POW10[e as usize]
        } else {
            v / POW10[(-e) as usize]
        }
    };
    Some(if neg { -v } else { v })
}
