//! Which tested candidate a round adds ([`choose`]), what it left out for its size
//! ([`too_small`]), and whether the data cannot tell it from a candidate of another cause
//! ([`twin`]).

use super::candidates::CandidateKind;
use super::Tested;
use crate::output::numfmt::sig;

/// Which tested candidate to add: among those that pass the test (p ≤ `threshold`) and reach a
/// held-out RMS of at most `max_rms` mm, the one with the fewest parameters whose held-out mean
/// squared error is within one standard error of the best one's (the "one-standard-error rule"
/// of Hastie, Tibshirani & Friedman, §7.10: the standard error of the best model's
/// cross-validated error).
/// A table can imitate a scale error or a once-per-turn error; when the data cannot tell them
/// apart, the simpler effect is the better name. Ties go to the lower held-out error.
pub fn choose(tested: &[Tested], errors: &[&[f64]], threshold: f64, max_rms: f64) -> Option<usize> {
    let ok: Vec<usize> = (0..tested.len())
        .filter(|&i| tested[i].test.p <= threshold && tested[i].validation_rms_mm <= max_rms)
        .collect();
    let best = *ok.iter().min_by(|a, b| {
        tested[**a]
            .validation_rms_mm
            .total_cmp(&tested[**b].validation_rms_mm)
    })?;
    let mean = |e: &[f64]| e.iter().sum::<f64>() / e.len().max(1) as f64;
    let eb = errors[best];
    let mb = mean(eb);
    let se = (eb.iter().map(|x| (x - mb) * (x - mb)).sum::<f64>()
        / (eb.len().max(2) - 1) as f64
        / eb.len().max(1) as f64)
        .sqrt();
    ok.into_iter()
        .filter(|&i| mean(errors[i]) <= mb + se)
        .min_by(|a, b| {
            tested[*a].parameters.cmp(&tested[*b].parameters).then(
                tested[*a]
                    .validation_rms_mm
                    .total_cmp(&tested[*b].validation_rms_mm),
            )
        })
}

/// The candidate of `tested` with the lowest held-out RMS among those that pass the test
/// (p ≤ `threshold`), with its relative drop of the held-out RMS from `rms`: what [`choose`]
/// left out only for its size, when it chose nothing.
pub fn too_small(tested: &[Tested], threshold: f64, rms: f64) -> Option<(&Tested, f64)> {
    let t = tested
        .iter()
        .filter(|t| t.test.p <= threshold && t.validation_rms_mm < rms)
        .min_by(|a, b| a.validation_rms_mm.total_cmp(&b.validation_rms_mm))?;
    Some((t, 1.0 - t.validation_rms_mm / rms))
}

/// Another candidate of `tested` that explains the held-out errors as well as the `chosen` one
/// (it passes the test, reaches `max_rms` and its mean squared error is within one standard
/// error of the chosen one's, as in [`choose`]) while describing a different cause the data
/// must tell apart: a thermal expansion and a drift of the tracker. On poses in one region of
/// the workspace, an arm that warms with time and a tracker that drifts with time move the
/// points alike; naming either would put the other's cause into the model.
pub fn twin(
    tested: &[Tested],
    errors: &[&[f64]],
    (threshold, max_rms): (f64, f64),
    chosen: usize,
) -> Option<usize> {
    let cause = |k: CandidateKind| match k {
        CandidateKind::Thermal { .. } => Some(0),
        CandidateKind::Drift { .. } => Some(1),
        _ => None,
    };
    let mine = cause(tested.get(chosen)?.candidate.kind)?;
    let mean = |e: &[f64]| e.iter().sum::<f64>() / e.len().max(1) as f64;
    let ec = errors.get(chosen)?;
    let mc = mean(ec);
    let se = |e: &[f64]| {
        let m = mean(e);
        (e.iter().map(|x| (x - m) * (x - m)).sum::<f64>()
            / (e.len().max(2) - 1) as f64
            / e.len().max(1) as f64)
            .sqrt()
    };
    (0..tested.len()).find(|&j| {
        let t = &tested[j];
        cause(t.candidate.kind).is_some_and(|c| c != mine)
            && t.test.p <= threshold
            && t.validation_rms_mm <= max_rms
            && errors.get(j).is_some_and(|e| {
                let slack = se(ec).max(se(e));
                (mean(e) - mc).abs() <= slack
            })
    })
}

/// How the reason of a [`twin`] refusal begins.
const TWIN: &str = "the data cannot tell it from";

/// Why neither twin is named ([`twin`]).
pub fn twin_reason(chosen: &Tested, other: &Tested) -> String {
    format!(
        "{TWIN} {} (cross-validated RMS {} against {} mm): on poses in one region of the \
         workspace an arm that warms and a tracker that drifts move the points alike",
        other.candidate.label(),
        sig(chosen.validation_rms_mm, 4),
        sig(other.validation_rms_mm, 4)
    )
}
