//! A stated 1-σ far below the file's others: one row whose `sigma_mm` (or `sx_mm`…) lost its
//! decimal point or unit (1e-5 among 0.02) weighs as millions of the others, the fit follows
//! that row alone and stalls, and the refusal that follows blames good rows. Such a σ is
//! refused (exit 2) naming its line: no instrument is [`TINY_SHARE`] as uncertain on one row
//! as on the rest of its session.

use crate::output::numfmt::sig;

/// A σ below this share of the file's median σ is refused.
pub const TINY_SHARE: f64 = 1e-3;

/// Refuses (exit 2) the smallest of `sigmas` (line, σ in the file's column `column`) when it is
/// below [`TINY_SHARE`] of their median.
pub fn refuse_tiny(sigmas: &[(u64, f64)], column: &str, origin: &str) -> anyhow::Result<()> {
    let mut values: Vec<f64> = sigmas
        .iter()
        .map(|(_, s)| *s)
        .filter(|s| s.is_finite() && *s > 0.0)
        .collect();
    if values.len() < 3 {
        return Ok(());
    }
    values.sort_by(f64::total_cmp);
    let median = values[values.len() / 2];
    let Some(&(line, s)) = sigmas
        .iter()
        .filter(|(_, s)| s.is_finite() && *s > 0.0)
        .min_by(|a, b| a.1.total_cmp(&b.1))
    else {
        return Ok(());
    };
    if s < TINY_SHARE * median {
        crate::refuse!(
            "{origin}:{line}: {column} {s} is {} times below the file's median σ ({}): a σ that \
             small weighs the row as millions of the others and the fit follows it alone; \
             correct it (a lost decimal point or unit?), or give --ignore-sigma",
            sig(median / s, 2),
            sig(median, 3)
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_sigma_a_thousand_times_below_the_median_is_refused() {
        let mut rows: Vec<(u64, f64)> = (2..30).map(|l| (l, 0.02 + 0.001 * l as f64)).collect();
        assert!(refuse_tiny(&rows, "sigma_mm", "s.csv").is_ok());
        rows.push((40, 0.0005));
        assert!(
            refuse_tiny(&rows, "sigma_mm", "s.csv").is_ok(),
            "40× below is a σ"
        );
        rows.push((41, 1e-5));
        let e = refuse_tiny(&rows, "sigma_mm", "s.csv")
            .unwrap_err()
            .to_string();
        assert!(e.contains("s.csv:41: sigma_mm 0.00001"), "{e}");
    }
}
