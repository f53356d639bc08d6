//! The `lean-parse` decimal parser (`kinecal::io::csv::parse_decimal`) against core's
//! `str::parse::<f64>`.
//!
//! Invariants:
//! - `no-panic`;
//! - `same-acceptance`: a cell is a number for one parser iff it is for the other (the CSV
//!   reader's errors must not depend on the feature);
//! - `fast-path-exact`: bit-identical results within Clinger's fast path (integer mantissa as
//!   written ≤ 2^53, decimal exponent within ±22);
//! - `nan-agrees`: NaN exactly when core gives NaN.
//!
//! Outside the fast path the largest ulp distance seen is printed whenever it grows
//! (`max ulp outside the fast path: …`), for the report.

use super::{invariant, ulps};
use kinecal::io::csv::parse_decimal;
use std::sync::atomic::{AtomicU64, Ordering};

static MAX_ULP: AtomicU64 = AtomicU64::new(0);

/// `Some(true)` when the text is a plain decimal inside Clinger's fast path.
fn in_fast_path(s: &str) -> bool {
    let b = s.as_bytes();
    let mut i = usize::from(matches!(b.first(), Some(b'-' | b'+')));
    let mut digits: Vec<u8> = Vec::new();
    let mut exp: i64 = 0;
    let mut point = false;
    while i < b.len() && (b[i].is_ascii_digit() || (b[i] == b'.' && !point)) {
        if b[i] == b'.' {
            point = true;
        } else {
            digits.push(b[i] - b'0');
            if point {
                exp -= 1;
            }
        }
        i += 1;
    }
    if i < b.len() {
        if b[i] != b'e' && b[i] != b'E' {
            return false;
        }
        let Ok(e) = s[i + 1..].parse::<i64>() else {
            return false;
        };
        exp = exp.saturating_add(e);
    }
    let first = digits.iter().position(|d| *d != 0);
    let Some(first) = first else {
        return true; // zero
    };
    let mut m: u128 = 0;
    for d in &digits[first..] {
        m = m * 10 + *d as u128;
        if m > 1u128 << 53 {
            return false;
        }
    }
    (-22..=22).contains(&exp)
}

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    let Ok(s) = std::str::from_utf8(data) else {
        return;
    };
    let lean = parse_decimal(s);
    let core = s.parse::<f64>().ok();
    invariant!(
        "same-acceptance",
        lean.is_some() == core.is_some(),
        "{s:?}: lean {lean:?}, core {core:?}"
    );
    let (Some(l), Some(c)) = (lean, core) else {
        return;
    };
    invariant!(
        "nan-agrees",
        l.is_nan() == c.is_nan(),
        "{s:?}: lean {l:?}, core {c:?}"
    );
    if c.is_nan() {
        return;
    }
    if in_fast_path(s) {
        invariant!(
            "fast-path-exact",
            l.to_bits() == c.to_bits(),
            "{s:?}: lean {l:e} ({:#x}), core {c:e} ({:#x})",
            l.to_bits(),
            c.to_bits()
        );
    } else {
        let u = ulps(l, c);
        if u > MAX_ULP.fetch_max(u, Ordering::Relaxed) {
            eprintln!("max ulp outside the fast path: {u} for {s:?} (lean {l:e}, core {c:e})");
        }
    }
}
