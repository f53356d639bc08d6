//! The PSO fitness, its cache, and LM with snapshots honour couplings.

use super::*;
use kinecal_cli::HostRobot;

fn measure<const N: usize>(
    robot: &HostRobot<N>,
    f: &RobotFile,
    n: usize,
    rng: &mut Xoshiro256PlusPlus,
) -> Vec<Measurement<f64, N>> {
    let mut fk = ForwardKinematics::new();
    (0..n)
        .map(|_| {
            let q = arr::<N>(&readings(f, rng));
            Measurement {
                q,
                point: fk.compute(robot, &q),
                ..Default::default()
            }
        })
        .collect()
}

#[test]
fn pso_fitness_cache_and_lm_with_snapshots_honour_couplings() {
    let f = parse(&fanuc_text());
    let nominal: HostRobot<6> = f.to_robot().unwrap();
    let mut truth = nominal.clone();
    let set = ParamSet::<64>::full(6, false).unwrap();
    let delta: Vec<f64> = (0..set.len())
        .map(|k| 1e-3 * ((k * 7 % 11) as f64 - 5.0))
        .collect();
    kinecal::model::param::apply_delta(&mut truth, &set, &delta).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(8);
    let data = measure(&truth, &f, 60, &mut rng);
    // The same data in model angles, for the uncoupled model.
    let plain: HostRobot<6> = uncoupled(&f).to_robot().unwrap();
    let converted: Vec<Measurement<f64, 6>> = data
        .iter()
        .map(|m| Measurement {
            q: arr::<6>(&to_model(&f, &m.q)),
            point: m.point,
            ..Default::default()
        })
        .collect();

    // Fitness: the trigonometry cache (model angles) = the general path = the uncoupled model.
    let mut cache: Vec<JointTrig<f64, 6>> = vec![[(0.0, 0.0); 6]; data.len()];
    let mut fast = PositionFitness::with_cache(&nominal, &set, &data, &mut cache).unwrap();
    let mut general = PositionFitness::new(&nominal, &set, &data).unwrap();
    let mut on_plain = PositionFitness::new(&plain, &set, &converted).unwrap();
    for x in [
        vec![0.0; set.len()],
        delta.iter().map(|d| d * 0.5).collect(),
        delta.clone(),
    ] {
        let (a, b, c) = (fast.fitness(&x), general.fitness(&x), on_plain.fitness(&x));
        assert!(
            (a - b).abs() <= 1e-9 * b.max(1.0),
            "cached {a} vs general {b}"
        );
        assert!(
            (b - c).abs() <= 1e-9 * c.max(1.0),
            "coupled {b} vs converted {c}"
        );
    }
    assert!(fast.fitness(&delta) < 1e-12, "the truth fits exactly");
    assert!(general.fitness(&vec![0.0; set.len()]) > 1.0);

    // LM: coupled model on readings = uncoupled model on model angles; a snapshot at every
    // step resumes bit-identically (the couplings survive the restore).
    use kinecal::io::snapshot::Snapshot;
    let mut a = FixedLevenberg::<f64, 6, HostValues, 64>::fixed(
        nominal.clone(),
        set.clone(),
        LmConfig::default(),
    )
    .unwrap();
    a.run(&data).unwrap();
    let mut b = FixedLevenberg::<f64, 6, HostValues, 64>::fixed(
        plain.clone(),
        set.clone(),
        LmConfig::default(),
    )
    .unwrap();
    b.run(&converted).unwrap();
    assert_eq!(a.robot().couplings(), nominal.couplings());
    for p in set.as_slice() {
        let (x, y) = (
            kinecal::model::param::value(a.robot(), *p).unwrap(),
            kinecal::model::param::value(b.robot(), *p).unwrap(),
        );
        assert!((x - y).abs() <= 1e-9, "{}: {x} vs {y}", p.name(a.robot()));
    }
    let rms = kinecal::identify::lm::rms_error(a.robot(), &data);
    assert!(rms < 1e-4, "rms {rms} {:?}", a.progress());
    let mut lm = FixedLevenberg::<f64, 6, HostValues, 64>::fixed(
        nominal.clone(),
        set.clone(),
        LmConfig::default(),
    )
    .unwrap();
    loop {
        let p = lm.step(&data, 9).unwrap();
        if p.stopped.is_some() {
            break;
        }
        let mut buf = Vec::new();
        lm.save(&mut buf).unwrap();
        let mut fresh =
            Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
        fresh.restore(&mut buf.as_slice()).unwrap();
        lm = fresh;
    }
    assert_eq!(lm.robot(), a.robot());
    // A snapshot of the coupled run does not restore into a solver of the uncoupled robot
    // (the couplings are part of the robot, stored in the snapshot), and the target is kept.
    let mut buf = Vec::new();
    lm.save(&mut buf).unwrap();
    let mut other = FixedLevenberg::<f64, 6, HostValues, 64>::fixed(
        plain.clone(),
        set.clone(),
        LmConfig::default(),
    )
    .unwrap();
    let kept = other.robot().clone();
    assert_eq!(
        other.restore(&mut buf.as_slice()),
        Err(kinecal::io::snapshot::SnapshotError::Shape)
    );
    assert_eq!(other.robot(), &kept);
}
