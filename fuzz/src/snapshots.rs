//! Every snapshot decoder: `Levenberg`, `Pso` (plain and `restore_using`), `Bpnn`.
//!
//! Input: a selector byte (stepper), a flag byte (bit 0: rewrite the header's length and CRC
//! to match the payload, so the fuzzer reaches the payload decoders), then the snapshot.
//!
//! Invariants:
//! - `no-panic`;
//! - `error-leaves-unchanged`: a refused snapshot leaves the stepper as it was (same save);
//! - `restored-finite`: an accepted snapshot gives a state whose numbers are finite (fitness
//!   values may be +∞ before evaluation, never NaN);
//! - `save-restore-canonical`: saving a restored stepper writes the bytes it was restored from;
//! - `steps-after-restore`: after either outcome the stepper steps on its data and stays finite.

use super::{invariant, robot_finite, skip, VecWriter};
use kinecal::identify::bpnn::{Bpnn, BpnnConfig};
use kinecal::identify::fitness::Objective;
use kinecal::identify::lm::{FixedLevenberg, LmConfig};
use kinecal::identify::pso::{Pso, PsoConfig};
use kinecal::io::snapshot::{crc32, Snapshot, HEADER_LEN};
use kinecal::model::param::ParamSet;

pub struct Bowl;
impl Objective<f64> for Bowl {
    fn dimension(&self) -> usize {
        3
    }
    fn fitness(&mut self, x: &[f64]) -> f64 {
        (x[0] - 0.3).powi(2) + (x[1] + 0.2).powi(2) + x[2] * x[2]
    }
}

type Lm = FixedLevenberg<f64, 3, kinecal::Inline<8>, 16>;
type Swarm = Pso<f64, 4, 3, 16>;
type Net = Bpnn<f64, 2, 3, 1>;

fn save<S: Snapshot>(s: &S) -> Vec<u8> {
    let mut w = VecWriter::default();
    s.save(&mut w).expect("save");
    w.0
}

fn fix_header(b: &mut [u8]) {
    if b.len() >= HEADER_LEN {
        let len = (b.len() - HEADER_LEN) as u32;
        let crc = crc32(&b[HEADER_LEN..]);
        b[12..16].copy_from_slice(&len.to_le_bytes());
        b[16..20].copy_from_slice(&crc.to_le_bytes());
    }
}

/// The bytes a successful restore consumed (header + the length it states).
fn consumed(b: &[u8]) -> &[u8] {
    let len = u32::from_le_bytes([b[12], b[13], b[14], b[15]]) as usize;
    &b[..HEADER_LEN + len]
}

fn check_canonical<S: Snapshot>(s: &S, input: &[u8]) {
    if skip("snapshot-canonical") {
        return;
    }
    let again = save(s);
    invariant!(
        "save-restore-canonical",
        again == consumed(input),
        "saved {} bytes vs {} restored",
        again.len(),
        consumed(input).len()
    );
}

pub fn lm_setup() -> (Lm, Vec<kinecal::Measurement<f64, 3>>) {
    let truth = super::perturbed(&super::arm3::<kinecal::Inline<8>>());
    let data = super::simulate(&truth, 12);
    let mut lm = Lm::fixed(
        super::arm3::<kinecal::Inline<8>>(),
        ParamSet::full(3, false).unwrap(),
        LmConfig::default(),
    )
    .unwrap();
    for _ in 0..3 {
        let _ = lm.step(&data, 5);
    }
    (lm, data)
}

pub fn pso_setup() -> Swarm {
    let mut cfg = PsoConfig::new([-1.0; 3], [1.0; 3]).unwrap();
    cfg.max_iterations = 20;
    let mut p = Swarm::new(cfg, 11).unwrap();
    let _ = p.step(&mut Bowl, 6);
    p
}

pub fn bpnn_setup() -> (Net, Vec<[f64; 2]>, Vec<[f64; 1]>) {
    let x: Vec<[f64; 2]> = (0..8)
        .map(|k| [k as f64 * 0.1, 1.0 - k as f64 * 0.05])
        .collect();
    let y: Vec<[f64; 1]> = x.iter().map(|v| [v[0] * v[1]]).collect();
    let mut n = Net::new(BpnnConfig::default(), 5).unwrap();
    n.fit_ranges(&x, &y).unwrap();
    let _ = n.train_epoch(&x, &y);
    (n, x, y)
}

fn lm_state_finite(lm: &Lm) -> bool {
    robot_finite(lm.robot()) && !lm.progress().cost.is_nan()
}

fn pso_state_finite(p: &Swarm) -> bool {
    let fin = |v: &[[f64; 3]; 4]| v.iter().flatten().all(|x| x.is_finite());
    fin(p.positions())
        && fin(p.velocities())
        && fin(p.personal_bests())
        && p.best_position().iter().all(|x| x.is_finite())
        && !p.best_fitness().is_nan()
        && p.personal_best_fitness().iter().all(|f| !f.is_nan())
        && p.history().iter().all(|f| !f.is_nan())
}

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    if data.len() < 2 {
        return;
    }
    let (sel, flags) = (data[0] % 4, data[1]);
    let mut bytes = data[2..].to_vec();
    if flags & 1 == 1 {
        fix_header(&mut bytes);
    }
    match sel {
        0 => {
            let (mut lm, meas) = lm_setup();
            let before = save(&lm);
            match lm.restore(&mut &bytes[..]) {
                Err(_) => invariant!("error-leaves-unchanged", save(&lm) == before),
                Ok(()) => {
                    invariant!(
                        "restored-finite",
                        lm_state_finite(&lm),
                        "{:?} {:?}",
                        lm.robot(),
                        lm.progress()
                    );
                    check_canonical(&lm, &bytes);
                }
            }
            for _ in 0..4 {
                let _ = lm.step(&meas, 7);
                invariant!(
                    "steps-after-restore",
                    lm_state_finite(&lm),
                    "{:?} {:?}",
                    lm.robot(),
                    lm.progress()
                );
            }
        }
        1 | 3 => {
            let mut p = pso_setup();
            let before = save(&p);
            let r = if sel == 1 {
                p.restore(&mut &bytes[..])
            } else {
                let mut scratch = pso_setup();
                p.restore_using(&mut scratch, &mut &bytes[..])
            };
            match r {
                Err(_) => invariant!("error-leaves-unchanged", save(&p) == before),
                Ok(()) => {
                    invariant!("restored-finite", pso_state_finite(&p), "{p:?}");
                    check_canonical(&p, &bytes);
                }
            }
            let best = p.best_fitness();
            for _ in 0..3 {
                let _ = p.step(&mut Bowl, 5);
                invariant!("steps-after-restore", pso_state_finite(&p), "{p:?}");
            }
            invariant!(
                "steps-after-restore",
                p.best_fitness().partial_cmp(&best) != Some(std::cmp::Ordering::Greater),
                "best fitness rose from {best} to {}",
                p.best_fitness()
            );
        }
        _ => {
            let (mut n, x, y) = bpnn_setup();
            let before = save(&n);
            match n.restore(&mut &bytes[..]) {
                Err(_) => invariant!("error-leaves-unchanged", save(&n) == before),
                Ok(()) => {
                    let out = n.forward(&[0.3, 0.7]);
                    invariant!("restored-finite", out[0].is_finite(), "{out:?}");
                    check_canonical(&n, &bytes);
                }
            }
            let _ = n.train_epoch(&x, &y);
            let out = n.forward(&[0.3, 0.7]);
            invariant!("steps-after-restore", out[0].is_finite(), "{out:?}");
        }
    }
}
