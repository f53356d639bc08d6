//! Simulate, identify with LM, compensate: the whole loop on the true robot and on files.

use super::*;

/// Simulated laser-tracker data (80 poses, 10 µm noise) from a robot with hidden geometry
/// errors and a hidden effect; LM identifies geometry + the effect's values; then 100 random
/// targets with seeds off by 0.3° are compensated on the identified model and checked on the
/// true robot: RMS ≤ 0.03 mm, max ≤ 0.1 mm (the "done when"), in f64 and f32.
#[test]
fn identified_model_compensates_the_true_robot() {
    for (case, fx) in [
        (0u64, Fx::None),
        (1, Fx::Compliance),
        (2, Fx::Cyclic),
        (3, Fx::Table),
    ] {
        let mut rng = Rng::seed_from_u64(900 + case);
        let nominal = er20();
        let mut truth = with_geometry_errors(&nominal, &mut rng);
        // The table here: knots every 30° on joint 2, ±0.2 mrad (few enough values for 80 poses).
        match fx {
            Fx::Table => {
                let knots: Vec<f64> = (0..13).map(|_| rng.random_range(-2e-4..2e-4)).collect();
                truth
                    .effects_mut()
                    .push(
                        EffectKind::Table,
                        1,
                        6,
                        0,
                        -std::f64::consts::PI,
                        30f64.to_radians(),
                        &knots,
                    )
                    .unwrap();
            }
            fx => add_effects(&mut truth, fx, &mut rng),
        }
        // The model to identify: nominal geometry, the same effect structure with zero values,
        // and the base roughly known (a few mm, 0.2°: e.g. from the circle-point method).
        let mut model = nominal.clone();
        let b = *truth.base();
        let mut base = Frame::from_xyz_rpy([b.o.x + 3.0, b.o.y - 2.0, b.o.z + 4.0], b.rpy());
        base.rotate_in_parent(&Vector3::new(0.002, -0.003, 0.001));
        model.set_base(base).unwrap();
        for (i, e) in truth.effects().iter().enumerate() {
            let zeros = vec![0.0; truth.effects().values_of(i).len()];
            model
                .effects_mut()
                .push(
                    e.kind,
                    e.joint as usize,
                    6,
                    e.order,
                    e.start,
                    e.step,
                    &zeros,
                )
                .unwrap();
        }
        let noise = Normal::new(0.0, 0.01).unwrap();
        let mut fk = ForwardKinematics::new();
        let data: Vec<Measurement<f64, 6>> = (0..80)
            .map(|_| {
                let q: [f64; 6] = core::array::from_fn(|_| deg(rng.random_range(-170.0..170.0)));
                let p = fk.compute(&truth, &q);
                Measurement {
                    q,
                    point: p + Vector3::new(
                        noise.sample(&mut rng),
                        noise.sample(&mut rng),
                        noise.sample(&mut rng),
                    ),
                    ..Default::default()
                }
            })
            .collect();
        let set = geometry_set(6).with_effects(&model).unwrap();
        let mut lm = Box::new(
            FixedLevenberg::<f64, 6, V, 64>::fixed(model.clone(), set, LmConfig::default())
                .unwrap(),
        );
        let p = lm.run(&data).unwrap();
        let identified = lm.robot().clone();
        let id32: Robot<f32, 6, V> = identified.cast().unwrap();

        let cfg = Config::default();
        let (mut before, mut nominal_err, mut after, mut after32) =
            (vec![], vec![], vec![], vec![]);
        let mut n = 0;
        while n < 100 {
            let q = er20_config(&mut rng);
            let target = target_of(&truth, &q, false);
            let seed = perturb(&q, 0.3, &mut rng);
            // Targets where the identified model is singular are not what this measures.
            let sol = match compensate(&identified, &target, &seed, &cfg) {
                Ok(s) => s,
                Err(CompensateError::Singular(_)) => continue,
                Err(e) => panic!("case {case}: {e:?}"),
            };
            n += 1;
            before.push(miss(&truth, &seed, &target).0);
            nominal_err.push(
                miss(
                    &truth,
                    &compensate(&model, &target, &seed, &cfg)
                        .map(|s| s.q)
                        .unwrap_or(seed),
                    &target,
                )
                .0,
            );
            after.push(miss(&truth, &sol.q, &target).0);
            let t32 = Target::Point(target.point().cast::<f32>());
            let s32 = compensate(&id32, &t32, &seed.map(|v| v as f32), &Config::default()).unwrap();
            after32.push(miss(&truth, &s32.q.map(|v| v as f64), &target).0);
        }
        let rms = |v: &[f64]| (v.iter().map(|x| x * x).sum::<f64>() / v.len() as f64).sqrt();
        let max = |v: &[f64]| v.iter().cloned().fold(0.0, f64::max);
        eprintln!(
            "{fx:?}: LM {} iterations ({:?}); seed error RMS {:.3} mm; nominal-model compensation RMS {:.3} max {:.3}; identified: RMS {:.4} max {:.4} mm (f32: RMS {:.4} max {:.4})",
            p.iteration, p.stopped, rms(&before), rms(&nominal_err), max(&nominal_err), rms(&after), max(&after), rms(&after32), max(&after32)
        );
        assert!(
            rms(&after) <= 0.03 && max(&after) <= 0.1,
            "{fx:?}: RMS {} max {}",
            rms(&after),
            max(&after)
        );
        assert!(rms(&after32) <= 0.03 && max(&after32) <= 0.1);
        assert!(
            rms(&nominal_err) > 0.3,
            "the nominal model should be far off"
        );
    }
}

/// `kinecal compensate` end to end on files: a model written with the robot-file writer, a
/// targets file with seeds, points and orientations (plus a wrist-singular and an out-of-reach
/// row), the output read back: every `ok` row's command puts the model on its target.
#[test]
fn command_line_writes_commands_that_reach_the_targets() {
    use kinecal_cli::compensation::{run, Job};
    use kinecal_cli::formats::robot_file::RobotFile;
    use std::fmt::Write as _;
    let dir = tempfile::tempdir().unwrap();
    let mut rng = Rng::seed_from_u64(81);
    let mut truth = with_geometry_errors(&er20(), &mut rng);
    add_effects(&mut truth, Fx::All, &mut rng);
    let model_path = dir.path().join("model.toml");
    RobotFile::from_robot("identified", &truth, true, &[2])
        .save(&model_path)
        .unwrap();
    let model = RobotFile::load(&model_path)
        .unwrap()
        .to_robot::<6>()
        .unwrap();

    for six in [false, true] {
        let mut csv = String::from("# seeds are the nominal joints\nq1,q2,q3,q4,q5,q6,x,y,z");
        csv.push_str(if six { ",rx,ry,rz\n" } else { "\n" });
        let mut targets = Vec::new();
        for i in 0..32 {
            let mut q = er20_config(&mut rng);
            if i == 30 {
                q[4] = 0.0; // wrist singular: matters only for the pose
            }
            let mut f = pose(&model, &q);
            if i == 31 {
                f.o = model.base().o + Vector3::new(0.0, 0.0, 1.5 * model.reach());
            }
            let seed = perturb(&q, 0.3, &mut rng);
            for v in seed {
                write!(csv, "{:.12},", v.to_degrees()).unwrap();
            }
            write!(csv, "{:.9},{:.9},{:.9}", f.o.x, f.o.y, f.o.z).unwrap();
            let rpy = f.rpy();
            if six {
                write!(
                    csv,
                    ",{:.12},{:.12},{:.12}",
                    rpy[0].to_degrees(),
                    rpy[1].to_degrees(),
                    rpy[2].to_degrees()
                )
                .unwrap();
            }
            csv.push('\n');
            let rad = rpy
                .map(|a| (a.to_degrees() * 1e12).round() / 1e12)
                .map(f64::to_radians);
            let t = Frame::from_xyz_rpy([f.o.x, f.o.y, f.o.z], rad);
            targets.push(if six {
                Target::Pose(t)
            } else {
                Target::Point(f.o)
            });
        }
        let t_path = dir.path().join("targets.csv");
        std::fs::write(&t_path, csv).unwrap();
        let out = dir.path().join("q.csv");
        let job = Job::new(&model_path, &t_path, &out);
        let j = run(&job).unwrap();
        assert_eq!(j.targets, 32);
        let text = std::fs::read_to_string(&out).unwrap();
        let mut lines = text.lines();
        let head: Vec<&str> = lines.next().unwrap().split(',').collect();
        assert_eq!(&head[..7], &["q1", "q2", "q3", "q4", "q5", "q6", "status"]);
        let mut statuses = Vec::new();
        for (k, line) in lines.enumerate() {
            let cells: Vec<&str> = line.split(',').collect();
            let q: [f64; 6] =
                core::array::from_fn(|j| cells[j].parse::<f64>().unwrap().to_radians());
            assert!(
                cells[0].split('.').nth(1).unwrap().len() >= 6,
                "at least 6 decimals"
            );
            statuses.push(cells[6].to_string());
            if cells[6] == "ok" {
                let (dp, dw) = miss(&model, &q, &targets[k]);
                assert!(dp < 1e-4 && dw < 1e-7, "row {k}: {dp} mm {dw} rad");
            }
        }
        assert_eq!(statuses.len(), 32);
        assert_eq!(statuses[31], "unreachable");
        if six {
            assert_eq!(statuses[30], "singular");
        }
        let ok = statuses.iter().filter(|s| *s == "ok").count();
        assert!(ok >= 30 - 1, "{statuses:?}");
        assert_eq!(j.ok, ok);
        assert_eq!(j.failed, 32 - ok);

        // Streaming the same rows and the f32 path give the same statuses for the ok rows.
        for (stream, f32) in [(true, false), (false, true)] {
            let mut job = job.clone();
            job.settings.stream = stream;
            job.settings.f32 = f32;
            let j2 = run(&job).unwrap();
            assert_eq!(j2.ok, j.ok, "stream={stream} f32={f32}");
        }
    }

    // Malformed targets files: one line naming the file and the place.
    let bad = dir.path().join("bad.csv");
    std::fs::write(
        &bad,
        "q1,q2,q3,q4,q5,q6,x,y,z,rx,ry\n0,0,0,0,0,0,1,2,3,4,5\n",
    )
    .unwrap();
    let job = Job::new(&model_path, &bad, dir.path().join("q.csv"));
    let e = run(&job).unwrap_err().to_string();
    assert!(e.contains("bad.csv:1:") && e.contains("rz"), "{e}");
    std::fs::write(
        &bad,
        "q1,q2,q3,q4,q5,q6,x,y,z,rx,ry,rz\n0,0,0,0,0,0,1,2,3,4,5,6\n0,0,0,0,0,0,1,2,3,4,,6\n",
    )
    .unwrap();
    let e = run(&job).unwrap_err().to_string();
    assert!(e.contains("bad.csv:3:11") && e.contains("ry"), "{e}");
    std::fs::write(&bad, "q1,q2,q3,q4,q5,q6,x,y,z\n0,0,0,0,0,zero,1,2,3\n").unwrap();
    let e = run(&job).unwrap_err().to_string();
    assert!(e.contains("bad.csv:2:6"), "{e}");
}
