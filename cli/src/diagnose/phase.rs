//! The phase of a joint table's knots refined: the best grids of the screen shifted by
//! bisection while the held-out error drops (`phase_search_starts`, `phase_search`).

use super::*;

/// The table grids whose phase is refined: the best `cfg.phase_search_grids` grids (distinct
/// spacings) of every joint table whose family ranks among the best `families` families of the
/// screen.
pub fn phase_search_starts(
    screened: &[Screened],
    cfg: &CatalogueConfig,
    families: usize,
    poses: usize,
) -> Vec<Screened> {
    let grids = cfg.phase_grids_for(poses);
    let mut order: Vec<&Screened> = screened.iter().collect();
    order.sort_by(|a, b| a.linear_rms_mm.total_cmp(&b.linear_rms_mm));
    let mut ranked: Vec<Candidate> = Vec::new();
    for s in &order {
        if ranked.len() >= families {
            break;
        }
        if !ranked.iter().any(|f| f.same_effect(&s.candidate)) {
            ranked.push(s.candidate);
        }
    }
    let mut out: Vec<Screened> = Vec::new();
    for family in ranked
        .iter()
        .filter(|c| matches!(c.kind, CandidateKind::Table { .. }))
    {
        let mut steps: Vec<f64> = Vec::new();
        for s in order.iter().filter(|s| s.candidate.same_effect(family)) {
            let CandidateKind::Table { step, .. } = s.candidate.kind else {
                continue;
            };
            if steps.len() >= grids {
                break;
            }
            if !steps.iter().any(|t| (t - step).abs() < 1e-12) {
                steps.push(step);
                out.push((*s).clone());
            }
        }
    }
    out
}

/// True when `a` and `b` are the same table grid on the same joint.
fn same_grid(a: &Candidate, b: &Candidate) -> bool {
    match (a.kind, b.kind) {
        (
            CandidateKind::Table {
                start: s, step: p, ..
            },
            CandidateKind::Table {
                start: t, step: q, ..
            },
        ) => a.joint == b.joint && (s - t).abs() < 1e-12 && (p - q).abs() < 1e-12,
        _ => false,
    }
}

/// The held-out RMS ratio a phase shift must reach to replace a grid (1 % in mean squared
/// error). Measured: a 10° table at phase 0 (6 noise floors, 600 poses) moved to 1/64 of its
/// pitch for a 0.1 % lower RMS with no threshold; a misalignment that matters (1/32 of the
/// pitch at 10 noise floors) costs ~20 % in mean squared error.
const PHASE_GAIN: f64 = 0.995;

/// Refines the phase of `starts` by bisection: at each of `cfg.phase_levels` levels every grid
/// is shifted by ± half the previous shift (first ±1/(2·pitch_phases) of its spacing) and the
/// best of the three is kept (a shifted grid only when it is clearly better: [`PHASE_GAIN`]).
/// The grids kept are appended to `screened` (the refit takes the best of each family from
/// there).
pub(super) fn phase_search<F>(
    starts: Vec<Screened>,
    screened: &mut Vec<Screened>,
    lo_hi: (&[f64], &[f64]),
    n: usize,
    cfg: &CatalogueConfig,
    screen: F,
) where
    F: Fn(&Candidate) -> Option<Screened> + Sync,
{
    let mut best = starts;
    let mut tried: Vec<Candidate> = Vec::new();
    let mut shift = 0.5 / cfg.pitch_phases.max(1) as f64;
    for _ in 0..cfg.phase_levels {
        let mut variants: Vec<(usize, Candidate)> = Vec::new();
        for (i, s) in best.iter().enumerate() {
            let j = s.candidate.joint;
            for f in [-shift, shift] {
                let Some(v) = shifted(&s.candidate, f, lo_hi.0[j], lo_hi.1[j], n, cfg) else {
                    continue;
                };
                let seen = screened.iter().any(|s| same_grid(&s.candidate, &v))
                    || tried.iter().any(|w| same_grid(w, &v));
                if !seen {
                    tried.push(v);
                    variants.push((i, v));
                }
            }
        }
        // The tables with the most knots first, as the round's screen takes them: each level
        // waits for its last variant, and a large one taken last would leave a core idle.
        let knots = |(_, v): &(usize, Candidate)| match v.kind {
            CandidateKind::Table { knots, .. } => knots,
            _ => 1,
        };
        let results =
            parallel::map_each_largest_first(&variants, knots, |(i, v)| screen(v).map(|s| (*i, s)));
        for (i, s) in results.into_iter().flatten() {
            // A shift must earn its place: the data cannot tell phases apart that change the
            // held-out mean squared error by less than 1 %, and a grid on round angles is the
            // better description of such a table.
            if s.linear_rms_mm < PHASE_GAIN * best[i].linear_rms_mm {
                best[i] = s.clone();
                screened.push(s);
            }
        }
        shift /= 2.0;
    }
}
