//! `kinecal_cli::diagnose::refusal` (cli/src/diagnose/refusal.rs) on its own: which refused
//! finding still stands once the search has ended.

use kinecal_cli::diagnose::candidates::{Candidate, CandidateKind};
use kinecal_cli::diagnose::refusal::{least_rms, standing};
use kinecal_cli::diagnose::significance::PairedTest;
use kinecal_cli::diagnose::{held_back, Found, Round, Tested};

const THERMAL: Candidate = Candidate {
    kind: CandidateKind::Thermal { reference: 20.0 },
    joint: 0,
};
const DRIFT: Candidate = Candidate {
    kind: CandidateKind::Drift { reference: 0.0 },
    joint: 0,
};
const SCALE_J4: Candidate = Candidate {
    kind: CandidateKind::Scale,
    joint: 3,
};

fn tested(candidate: Candidate, validation_rms_mm: f64) -> Tested {
    Tested {
        candidate,
        parameters: 1,
        validation_rms_mm,
        test: PairedTest {
            n: 100,
            mean: 0.1,
            standard_error: 0.01,
            t: 10.0,
            p: 1e-9,
        },
    }
}

/// A round from 1 mm that refused `tested[0]` (as the twin of `tested[1]` when `twin`).
fn refusing(tested: Vec<Tested>, twin: bool) -> Round {
    Round {
        start_rms_mm: 1.0,
        screened: vec![],
        tested,
        threshold: 0.01,
        chosen: Some(0),
        refused: Some("refused".into()),
        twin: twin.then_some(1),
        seconds: 0.0,
    }
}

fn found(candidate: Candidate) -> Found<6> {
    let r = kinecal_cli::simulation::er20_c10();
    Found {
        candidate,
        before_rms_mm: 1.0,
        validation_rms_mm: 0.3,
        test: tested(candidate, 0.3).test,
        threshold: 0.01,
        candidates_compared: 2,
        before: r.clone(),
        after: r,
    }
}

#[test]
fn a_twin_refusal_stands_until_either_family_is_found() {
    let rounds = [refusing(
        vec![tested(THERMAL, 0.2), tested(DRIFT, 0.21)],
        true,
    )];
    let s = standing::<6>(&rounds, &[], 1.0).expect("nothing found since: it stands");
    assert_eq!(s.candidate, THERMAL);
    assert_eq!(s.twin, Some(DRIFT));
    assert!(s.blocks(1.0));
    assert!(s.unexplained().contains("tell them apart"));
    // The twin's family found later: the refusal is replaced, as by its own family.
    assert!(standing(&rounds, &[found(DRIFT)], 0.3).is_none());
    assert!(standing(&rounds, &[found(THERMAL)], 0.3).is_none());
    // Another family found leaves it standing.
    assert!(standing(&rounds, &[found(SCALE_J4)], 0.3).is_some());
}

#[test]
fn a_refusal_the_final_model_beats_does_not_stand_nor_bound_the_floor() {
    let rounds = [refusing(vec![tested(SCALE_J4, 0.5)], false)];
    // The final model reaches 0.4 mm with other effects: 0.5 mm is no bound on the floor.
    assert!(standing::<6>(&rounds, &[found(THERMAL)], 0.4).is_none());
    assert_eq!(
        least_rms::<6>(&rounds, &[found(THERMAL)], 0.4),
        f64::INFINITY
    );
    // Below the final model's 0.8 mm it stands and bounds it, and blocks from 1/√2 of it.
    let s = standing::<6>(&rounds, &[found(THERMAL)], 0.8).unwrap();
    assert_eq!(s.twin, None);
    assert_eq!(least_rms::<6>(&rounds, &[found(THERMAL)], 0.8), 0.5);
    assert!(s.blocks(0.8));
    assert!(!s.blocks(0.7));
    assert!(s.unexplained().contains("joint 4's readings"));
    // An undefined figure never stands.
    let nan = [refusing(vec![tested(SCALE_J4, f64::NAN)], false)];
    assert!(standing::<6>(&nan, &[], 1.0).is_none());
}

#[test]
fn the_lowest_standing_refusal_is_the_one_reported() {
    let rounds = [
        refusing(vec![tested(SCALE_J4, 0.6)], false),
        refusing(vec![tested(THERMAL, 0.3), tested(DRIFT, 0.31)], true),
    ];
    assert_eq!(standing::<6>(&rounds, &[], 1.0).unwrap().candidate, THERMAL);
    assert_eq!(
        standing::<6>(&rounds, &[found(DRIFT)], 1.0)
            .unwrap()
            .candidate,
        SCALE_J4
    );
}

#[test]
fn a_family_refused_once_is_held_back_until_something_is_added() {
    let refused = [(THERMAL, 1), (DRIFT, 1)];
    assert!(held_back(&refused, &THERMAL, 1));
    assert!(held_back(&refused, &DRIFT, 1));
    assert!(!held_back(&refused, &THERMAL, 2));
    assert!(!held_back(&refused, &SCALE_J4, 1));
    // Refused twice: held back for good.
    let twice = [(THERMAL, 1), (THERMAL, 2)];
    assert!(held_back(&twice, &THERMAL, 3));
}
