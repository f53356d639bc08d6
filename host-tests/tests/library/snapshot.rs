//! Snapshot and restore: interrupted runs end bit-identical, corrupted snapshots are refused and
//! leave the target untouched.

use crate::pso_sim::*;
use kinecal::identify::bpnn::{Bpnn, BpnnConfig};
use kinecal::identify::fitness::{Objective, PositionFitness};
use kinecal::identify::pso::{Pso, PsoConfig};
use kinecal::io::snapshot::{
    crc32, restore_with, save_with, Crc32, Kind, Snapshot, SnapshotError, HEADER_LEN,
};

fn bytes<S: Snapshot>(s: &S) -> Vec<u8> {
    let mut v = Vec::new();
    s.save(&mut v).unwrap();
    v
}

#[test]
fn crc32_is_the_standard_one() {
    assert_eq!(crc32(b"123456789"), 0xCBF4_3926);
    assert_eq!(crc32(b""), 0);
    let mut c = Crc32::new();
    c.update(b"1234");
    c.update(b"56789");
    assert_eq!(c.value(), 0xCBF4_3926);
}

/// Small swarm on the ER20 problem, so that the exhaustive corruption test stays fast.
type Small = Pso<f64, 6, 24, 16>;

fn er20_problem() -> (
    kinecal::Robot<f64, 6>,
    kinecal::ParamSet<24>,
    Vec<kinecal::Measurement<f64, 6>>,
) {
    let nominal = er20_nominal();
    let truth = with_delta(&nominal, &er20_errors());
    let data = poses(&truth, 50, 0.01, 1);
    (nominal, mdh24(), data)
}

#[test]
fn pso_interrupted_at_every_step_ends_bit_identical() {
    let (nominal, params, data) = er20_problem();
    let mut f = PositionFitness::new(&nominal, &params, &data).unwrap();
    let mut cfg = PsoConfig::<f64, 24>::calibration(params.as_slice()).unwrap();
    cfg.max_iterations = 30;
    type Swarm = Pso<f64, 40, 24, 64>;

    let mut straight = Box::new(Swarm::new(cfg, 9).unwrap());
    straight.run(&mut f).unwrap();

    // Budgets that end calls mid-iteration, on iteration boundaries and across them.
    for budget in [1usize, 13, 40, 57] {
        let mut run = Box::new(Swarm::new(cfg, 9).unwrap());
        let mut calls = 0;
        loop {
            let p = run.step(&mut f, budget).unwrap();
            calls += 1;
            // Power cut: save, then continue in a fresh stepper built with another seed.
            let snap = bytes(&*run);
            let mut fresh = Box::new(Swarm::new(cfg, 1234).unwrap());
            fresh.restore(&mut snap.as_slice()).unwrap();
            assert_eq!(bytes(&*fresh), snap, "restore reproduces the state exactly");
            run = fresh;
            if p.stopped.is_some() {
                break;
            }
        }
        assert!(calls > 1);
        assert_eq!(run.progress(), straight.progress());
        assert_eq!(
            run.best_position().map(f64::to_bits),
            straight.best_position().map(f64::to_bits)
        );
        assert_eq!(
            bytes(&*run),
            bytes(&*straight),
            "budget {budget}: final states differ"
        );
    }
}

#[test]
fn paper_sized_swarm_round_trips_in_f32_and_f64() {
    let (nominal, params, data) = er20_problem();
    let mut f = PositionFitness::new(&nominal, &params, &data).unwrap();
    let mut cfg = PsoConfig::<f64, 24>::calibration(params.as_slice()).unwrap();
    cfg.max_iterations = 6;
    let mut a = Box::new(Pso::<f64, 200, 24>::new(cfg, 3).unwrap());
    let mut b = Box::new(Pso::<f64, 200, 24>::new(cfg, 3).unwrap());
    a.step(&mut f, 733).unwrap();
    let snap = bytes(&*a);
    b.restore(&mut snap.as_slice()).unwrap();
    a.run(&mut f).unwrap();
    b.run(&mut f).unwrap();
    assert_eq!(bytes(&*a), bytes(&*b));

    let n32: kinecal::Robot<f32, 6> = nominal.cast().unwrap();
    let d32: Vec<kinecal::Measurement<f32, 6>> = data
        .iter()
        .map(|m| kinecal::Measurement::new(m.q.map(|v| v as f32), m.point.map(|v| v as f32)))
        .collect();
    let mut g = PositionFitness::new(&n32, &params, &d32).unwrap();
    let mut c32 = PsoConfig::<f32, 24>::calibration(params.as_slice()).unwrap();
    c32.max_iterations = 6;
    let mut a = Box::new(Pso::<f32, 200, 24>::new(c32, 3).unwrap());
    let mut b = Box::new(Pso::<f32, 200, 24>::new(c32, 4).unwrap());
    a.step(&mut g, 333).unwrap();
    let snap = bytes(&*a);
    // An f32 swarm of 200 × 24 is 4 arrays of 19,200 bytes plus config and history.
    assert!(
        snap.len() > 4 * 19_200 && snap.len() < 4 * 19_200 + 2_000,
        "{}",
        snap.len()
    );
    b.restore(&mut snap.as_slice()).unwrap();
    a.run(&mut g).unwrap();
    b.run(&mut g).unwrap();
    assert_eq!(
        a.best_position().map(f32::to_bits),
        b.best_position().map(f32::to_bits)
    );
    assert_eq!(bytes(&*a), bytes(&*b));
}

/// Restoring `snap` into `target` must fail and leave it exactly as it was.
fn refused<S: Snapshot>(target: &mut S, snap: &[u8]) -> SnapshotError {
    let before = bytes(target);
    let err = target.restore(&mut &snap[..]).unwrap_err();
    assert_eq!(
        bytes(target),
        before,
        "a refused snapshot changed the target ({err:?})"
    );
    err
}

#[test]
fn corrupted_snapshots_are_refused_and_change_nothing() {
    let (nominal, params, data) = er20_problem();
    let mut f = PositionFitness::new(&nominal, &params, &data).unwrap();
    let mut cfg = PsoConfig::<f64, 24>::calibration(params.as_slice()).unwrap();
    cfg.max_iterations = 5;
    let mut source = Small::new(cfg, 1).unwrap();
    source.step(&mut f, 20).unwrap();
    let good = bytes(&source);
    let mut target = Small::new(cfg, 2).unwrap();
    target.step(&mut f, 3).unwrap();

    // Every single flipped bit pattern at every byte position.
    for i in 0..good.len() {
        for mask in [0x01u8, 0x80, 0xFF] {
            let mut bad = good.clone();
            bad[i] ^= mask;
            refused(&mut target, &bad);
        }
    }
    // Every truncation.
    for len in 0..good.len() {
        let e = refused(&mut target, &good[..len]);
        assert!(
            matches!(e, SnapshotError::UnexpectedEof | SnapshotError::Length),
            "{len}: {e:?}"
        );
    }
    // Header fields give specific errors.
    let mut bad = good.clone();
    bad[4..6].copy_from_slice(&2u16.to_le_bytes());
    assert_eq!(refused(&mut target, &bad), SnapshotError::Version(2));
    bad = good.clone();
    bad[0] = b'X';
    assert_eq!(refused(&mut target, &bad), SnapshotError::BadMagic);
    bad = good.clone();
    bad[HEADER_LEN + 100] ^= 0x10;
    assert_eq!(refused(&mut target, &bad), SnapshotError::Checksum);

    // The uncorrupted snapshot still restores into the untouched target.
    target.restore(&mut good.as_slice()).unwrap();
    assert_eq!(bytes(&target), good);

    // The same through a scratch swarm instead of a copy on the stack.
    let mut other = Small::new(cfg, 3).unwrap();
    let mut scratch = Small::new(cfg, 4).unwrap();
    let before = bytes(&other);
    let mut bad = good.clone();
    bad[HEADER_LEN + 200] ^= 0x20;
    assert_eq!(
        other
            .restore_using(&mut scratch, &mut bad.as_slice())
            .unwrap_err(),
        SnapshotError::Checksum
    );
    assert_eq!(bytes(&other), before);
    other
        .restore_using(&mut scratch, &mut good.as_slice())
        .unwrap();
    assert_eq!(bytes(&other), good);
}

#[test]
fn snapshots_of_another_kind_scalar_or_size_are_refused() {
    let cfg = PsoConfig::<f64, 2>::new([-1.0; 2], [1.0; 2]).unwrap();
    let mut target = Pso::<f64, 4, 2>::new(cfg, 0).unwrap();

    let other_size = Pso::<f64, 5, 2>::new(cfg, 0).unwrap();
    assert_eq!(
        refused(&mut target, &bytes(&other_size)),
        SnapshotError::Shape
    );
    let other_history = Pso::<f64, 4, 2, 8>::new(cfg, 0).unwrap();
    assert_eq!(
        refused(&mut target, &bytes(&other_history)),
        SnapshotError::Shape
    );

    let c32 = PsoConfig::<f32, 2>::new([-1.0; 2], [1.0; 2]).unwrap();
    let single = Pso::<f32, 4, 2>::new(c32, 0).unwrap();
    assert_eq!(
        refused(&mut target, &bytes(&single)),
        SnapshotError::Scalar(4)
    );

    let net = Bpnn::<f64, 2, 3, 2>::new(BpnnConfig::default(), 0).unwrap();
    assert_eq!(
        refused(&mut target, &bytes(&net)),
        SnapshotError::Kind(Kind::Bpnn as u16)
    );

    // A snapshot with a valid checksum but an impossible state is refused too: write NaN into
    // the first lower bound (after the 20-byte header, 3 shape words and 3 coefficients) and
    // recompute the CRC; then a phase tag that does not exist.
    let good = bytes(&target);
    let mut forged = good.clone();
    forged[HEADER_LEN + 12 + 24..HEADER_LEN + 12 + 32].copy_from_slice(&f64::NAN.to_le_bytes());
    let crc = crc32(&forged[HEADER_LEN..]);
    forged[16..20].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(refused(&mut target, &forged), SnapshotError::Invalid);
    // Phase tag: after shape (12), coefficients (24), bounds (32), velocity settings (16),
    // max_iterations (4), target (8), window (4), tolerance (8) and the generator (32).
    let phase = HEADER_LEN + 12 + 24 + 32 + 16 + 4 + 8 + 4 + 8 + 32;
    let mut forged = good.clone();
    forged[phase] = 9;
    let crc = crc32(&forged[HEADER_LEN..]);
    forged[16..20].copy_from_slice(&crc.to_le_bytes());
    assert_eq!(refused(&mut target, &forged), SnapshotError::Invalid);
}

#[test]
fn bpnn_training_continues_bit_identical_after_restore() {
    let xs: Vec<[f64; 3]> = (0..40)
        .map(|i| {
            [
                (i as f64 * 0.31).sin(),
                (i as f64 * 0.17).cos(),
                i as f64 / 40.0,
            ]
        })
        .collect();
    let ys: Vec<[f64; 2]> = xs
        .iter()
        .map(|x| [x[0] * x[1] + x[2], (x[0] - x[2]).tanh()])
        .collect();
    let mut a = Bpnn::<f64, 3, 5, 2>::new(BpnnConfig::default(), 8).unwrap();
    a.fit_ranges(&xs, &ys).unwrap();
    for _ in 0..7 {
        a.train_epoch(&xs, &ys).unwrap();
    }
    let snap = bytes(&a);
    let mut b = Bpnn::<f64, 3, 5, 2>::new(
        BpnnConfig {
            batch: 4,
            ..BpnnConfig::default()
        },
        99,
    )
    .unwrap();
    b.restore(&mut snap.as_slice()).unwrap();
    for _ in 0..11 {
        let (la, lb) = (
            a.train_epoch(&xs, &ys).unwrap(),
            b.train_epoch(&xs, &ys).unwrap(),
        );
        assert_eq!(la.to_bits(), lb.to_bits());
    }
    assert_eq!(
        a.forward(&[0.2, 0.4, 0.6]).map(f64::to_bits),
        b.forward(&[0.2, 0.4, 0.6]).map(f64::to_bits)
    );
    assert_eq!(bytes(&a), bytes(&b));

    // Corruption anywhere is refused, leaving the net as it was.
    let good = bytes(&a);
    for i in (0..good.len()).step_by(3) {
        let mut bad = good.clone();
        bad[i] ^= 0x04;
        refused(&mut b, &bad);
    }
    let cfg = PsoConfig::<f64, 2>::new([-1.0; 2], [1.0; 2]).unwrap();
    let swarm = Pso::<f64, 4, 2>::new(cfg, 0).unwrap();
    assert_eq!(
        refused(&mut b, &bytes(&swarm)),
        SnapshotError::Kind(Kind::Pso as u16)
    );
}

/// The helpers the other steppers (the LM in `kinecal::identify::lm`) build their snapshots from.
#[test]
fn container_helpers_round_trip_every_field_type() {
    let mut buf = Vec::new();
    let rows = [[1.5f64, -2.25], [f64::INFINITY, 0.0]];
    let rng = {
        use rand_xoshiro::rand_core::SeedableRng;
        rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(5)
    };
    save_with::<f64, _, _>(&mut buf, Kind::Levenberg, |e| {
        e.u8(7)?;
        e.bool(true)?;
        e.u16(0xBEEF)?;
        e.u32(123_456)?;
        e.u64(u64::MAX - 1)?;
        e.usize(42)?;
        e.real(-0.125f64)?;
        e.reals(&[1.0f64, 2.0, 3.0])?;
        e.real_rows(&rows)?;
        e.rng(&rng)
    })
    .unwrap();
    // Header + 1 + 1 + 2 + 4 + 8 + 4 + 8 + 24 + 32 + 32 payload bytes.
    assert_eq!(buf.len(), HEADER_LEN + 116);
    let read = restore_with::<f64, _, _, _>(&mut buf.as_slice(), Kind::Levenberg, |d| {
        let a = (
            d.u8()?,
            d.bool()?,
            d.u16()?,
            d.u32()?,
            d.u64()?,
            d.usize()?,
            d.real::<f64>()?,
        );
        let mut v = [0.0f64; 3];
        d.reals(&mut v)?;
        let mut r = [[0.0f64; 2]; 2];
        d.real_rows(&mut r)?;
        let g = d.rng()?;
        Ok((a, v, r, g))
    })
    .unwrap();
    assert_eq!(read.0, (7, true, 0xBEEF, 123_456, u64::MAX - 1, 42, -0.125));
    assert_eq!(read.1, [1.0, 2.0, 3.0]);
    assert_eq!(read.2, rows);
    assert_eq!(read.3, rng);

    // Reading less than was written, or more, is a length error; f32 readers refuse f64 data.
    let short = restore_with::<f64, _, _, _>(&mut buf.as_slice(), Kind::Levenberg, |d| d.u8());
    assert_eq!(short.unwrap_err(), SnapshotError::Length);
    let long = restore_with::<f64, _, _, _>(&mut buf.as_slice(), Kind::Levenberg, |d| {
        let mut all = [0u8; 117];
        d.bytes(&mut all)
    });
    assert_eq!(long.unwrap_err(), SnapshotError::Length);
    let single = restore_with::<f32, _, _, _>(&mut buf.as_slice(), Kind::Levenberg, |d| d.u8());
    assert_eq!(single.unwrap_err(), SnapshotError::Scalar(8));

    // A writer that runs out of room reports an I/O error.
    let mut small = [0u8; 10];
    let r = save_with::<f64, _, _>(&mut &mut small[..], Kind::Levenberg, |e| e.u64(1));
    assert_eq!(r.unwrap_err(), SnapshotError::Io);
}

#[test]
fn objective_is_unaffected_by_restore() {
    // Restoring a swarm does not need the problem: the fitness of the best position after a
    // restore is the same number the original swarm recorded.
    {
        let (nominal, params, data) = er20_problem();
        let mut f = PositionFitness::new(&nominal, &params, &data).unwrap();
        let mut cfg = PsoConfig::<f64, 24>::calibration(params.as_slice()).unwrap();
        cfg.max_iterations = 3;
        let mut a = Small::new(cfg, 1).unwrap();
        a.run(&mut f).unwrap();
        let mut b = Small::new(cfg, 2).unwrap();
        b.restore(&mut bytes(&a).as_slice()).unwrap();
        assert_eq!(
            f.fitness(b.best_position()).to_bits(),
            a.best_fitness().to_bits()
        );
    };
}
