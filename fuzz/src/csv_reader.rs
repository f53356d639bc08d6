//! The streaming CSV reader over a fault-injecting `embedded_io::Read`.
//!
//! Input: [`FaultPlan::LEN`] bytes of fault plan (short reads of 1..k bytes, a transient error
//! every n-th call, a persistent error after n bytes), then the file.
//!
//! Invariants:
//! - `no-panic`;
//! - `record-matches-fault-free`: every record the faulty reader yields equals the record of the
//!   same line in the fault-free parse (an error may be returned for it instead);
//! - `short-reads-transparent`: with short reads but no errors, the sequence of results is
//!   exactly the fault-free one;
//! - `records-finite`: a record's joint readings are finite, and its point unless the file
//!   names its points (`x_NAME` columns: the point is NaN by design);
//! - `no-extra-cells`: a record's line has no more cells than the header (cells beyond the
//!   header are not silently dropped);
//! - `no-records-after-persistent-error`: once the source fails for good, no record appears;
//! - `terminates`: the iteration ends within lines + injected errors + 2 calls.

use super::{invariant, skip, FaultPlan, FaultReader};
use kinecal::io::csv::{CsvError, CsvReader, Record};

const N: usize = 3;
const L: usize = 96;
const X: usize = 3;

type Rec = Record<N, X>;

fn same(a: &Rec, b: &Rec) -> bool {
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    a.line == b.line
        && bits(&a.q_deg) == bits(&b.q_deg)
        && bits(&a.xyz_mm) == bits(&b.xyz_mm)
        && bits(&a.extra) == bits(&b.extra)
}

fn same_result(a: &Result<Rec, CsvError>, b: &Result<Rec, CsvError>) -> bool {
    match (a, b) {
        (Ok(a), Ok(b)) => same(a, b),
        (Err(a), Err(b)) => a == b,
        _ => false,
    }
}

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    if data.len() < FaultPlan::LEN {
        return;
    }
    let plan = FaultPlan::decode(&data[..FaultPlan::LEN]);
    let text = &data[FaultPlan::LEN..];
    let lines = text.iter().filter(|b| **b == b'\n').count() + 1;

    // The fault-free parse.
    let Ok(mut clean) = CsvReader::<_, N, L, X>::new(text) else {
        return;
    };
    let mut reference: Vec<Result<Rec, CsvError>> = Vec::new();
    while let Some(r) = clean.next_record() {
        reference.push(r);
        invariant!(
            "terminates",
            reference.len() <= lines + 2,
            "fault-free reader"
        );
    }

    // The header's cell count: the first line neither blank nor a comment.
    let text_lines: Vec<&[u8]> = text.split(|b| *b == b'\n').collect();
    let header_cells = text_lines
        .iter()
        .find(|l| {
            let t = l.trim_ascii();
            !(t.is_empty() || t[0] == b'#')
        })
        .map(|l| l.split(|b| *b == b',').count())
        .unwrap_or(0);

    // A file of named points (`x_NAME` columns instead of `x`, docs/formats.md) carries its
    // points as extra columns; the record's own point is NaN by design.
    let named = clean.named_points();
    for r in reference.iter().flatten() {
        invariant!(
            "records-finite",
            r.q_deg.iter().all(|v| v.is_finite())
                && (named || r.xyz_mm.iter().all(|v| v.is_finite()))
        );
        let cells = text_lines
            .get(r.line as usize - 1)
            .map(|l| l.split(|b| *b == b',').count())
            .unwrap_or(0);
        if !skip("csv-extra-cells") {
            invariant!(
                "no-extra-cells",
                cells <= header_cells,
                "line {} has {cells} cells, the header {header_cells}",
                r.line
            );
        }
    }

    // The same file through the fault injector.
    let mut src = FaultReader::new(text, plan);
    let persistent = src.persistent_injected.clone();
    let mut faulty = match CsvReader::<_, N, L, X>::new(&mut src) {
        Ok(r) => r,
        Err(_) => {
            invariant!(
                "short-reads-transparent",
                !plan.error_free(),
                "header refused"
            );
            return;
        }
    };
    let mut got: Vec<Result<Rec, CsvError>> = Vec::new();
    let mut failed_for_good = false;
    let mut calls = 0usize;
    loop {
        calls += 1;
        let Some(r) = faulty.next_record() else { break };
        match &r {
            Ok(rec) => {
                invariant!(
                    "no-records-after-persistent-error",
                    !failed_for_good,
                    "record of line {} after the source failed for good",
                    rec.line
                );
                let reference_rec = reference.iter().flatten().find(|c| c.line == rec.line);
                if !skip("csv-transient-corrupts") || plan.error_free() {
                    invariant!(
                        "record-matches-fault-free",
                        reference_rec.is_some_and(|c| same(c, rec)),
                        "line {}: got {:?}, fault-free {:?}",
                        rec.line,
                        rec,
                        reference_rec
                    );
                }
            }
            Err(e) => {
                if e.kind == kinecal::io::csv::CsvErrorKind::Io && persistent.get() > 0 {
                    failed_for_good = true;
                }
            }
        }
        got.push(r);
        if failed_for_good && got.iter().rev().take(4).all(|r| r.is_err()) && calls > 4 {
            // A source that fails for good may keep failing; a caller stops here.
            break;
        }
        // Every call consumes a byte or an injected error, and errors are at most one per
        // read call: a hard cap while the loop runs, the exact bound after it.
        invariant!(
            "terminates",
            calls <= 2 * text.len() + lines + 8,
            "{calls} calls for {lines} lines"
        );
    }
    drop(faulty);
    invariant!(
        "terminates",
        calls <= lines + 2 + src.transient_injected as usize + if failed_for_good { 5 } else { 0 },
        "{calls} calls for {lines} lines and {} transient errors",
        src.transient_injected
    );
    if plan.error_free() {
        invariant!(
            "short-reads-transparent",
            got.len() == reference.len()
                && got.iter().zip(&reference).all(|(a, b)| same_result(a, b)),
            "got {got:?}\nfault-free {reference:?}"
        );
    }
}
