//! The CLI's measurement file reader (`formats::measurements::read_bytes`) and writer.
//!
//! Input: one byte choosing the joint count (3 or 6), then the file.
//!
//! Invariants:
//! - `no-panic`;
//! - `accepted-finite`: every accepted record has finite joint readings and point;
//! - `write-read-round-trip`: `read_bytes(to_csv_string(data))` gives the same records (values
//!   as the writer rounds them, extra cells NaN when not finite) and extra column names.

use super::invariant;
use kinecal_cli::formats::measurements::{
    read_bytes, to_csv_string, Dataset, Q_DECIMALS, XYZ_DECIMALS,
};

fn check<const N: usize>(bytes: &[u8]) {
    let Ok(data) = read_bytes::<N>(bytes) else {
        return;
    };
    for r in &data.records {
        invariant!(
            "accepted-finite",
            r.q_deg.iter().chain(r.xyz_mm.iter()).all(|v| v.is_finite()),
            "{r:?}"
        );
    }
    let text = to_csv_string(&data);
    let back: Result<Dataset<N>, _> = read_bytes::<N>(text.as_bytes());
    invariant!("write-read-round-trip", back.is_ok(), "{text}\n{back:?}");
    let back = back.unwrap();
    invariant!(
        "write-read-round-trip",
        back.extra_names == data.extra_names && back.len() == data.len(),
        "{text}"
    );
    let rounded = |v: f64, d: usize| format!("{v:.d$}").parse::<f64>().unwrap();
    for (a, b) in data.records.iter().zip(&back.records) {
        let ok = a
            .q_deg
            .iter()
            .zip(&b.q_deg)
            .all(|(x, y)| rounded(*x, Q_DECIMALS).to_bits() == y.to_bits())
            && a.xyz_mm
                .iter()
                .zip(&b.xyz_mm)
                .all(|(x, y)| rounded(*x, XYZ_DECIMALS).to_bits() == y.to_bits())
            && a.extra.len() == b.extra.len()
            && a.extra.iter().zip(&b.extra).all(|(x, y)| {
                if x.is_finite() {
                    x.to_bits() == y.to_bits()
                } else {
                    y.is_nan()
                }
            });
        invariant!("write-read-round-trip", ok, "{a:?} vs {b:?}\n{text}");
    }
}

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    let Some((&sel, bytes)) = data.split_first() else {
        return;
    };
    if sel & 1 == 0 {
        check::<3>(bytes)
    } else {
        check::<6>(bytes)
    }
}
