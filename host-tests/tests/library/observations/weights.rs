//! Weighted data: noisy readings discounted by their σ.

use super::*;

/// Held-out RMS (mm, noise-free poses) of the fit of `data` over the full set, base unknown.
fn held_out(
    nominal: &Robot<f64, 6, V>,
    data: &[Measurement<f64, 6>],
    valid: &[Measurement<f64, 6>],
) -> (f64, f64, usize) {
    let set = ParamSet::<P>::full(6, true).unwrap();
    let mut lm = Levenberg::fixed(nominal.clone(), set, LmConfig::default()).unwrap();
    lm.run(data).unwrap();
    let p = (0..lm.params().len()).filter(|k| lm.is_active(*k)).count();
    (
        rms_error(lm.robot(), valid),
        library_cost(lm.robot(), data),
        p,
    )
}

/// 5 % of the readings with 10× the noise, weighted by 1/σ (σ as the tracker reports it),
/// identify as well as data without them; unweighted, clearly worse.
#[test]
fn weights_discount_noisy_readings() {
    let nominal = ur10(Vector3::new(0.0, 0.0, 109.0));
    let set = ParamSet::<P>::full(6, true).unwrap();
    let (mut sc, mut sw, mut su) = (0.0, 0.0, 0.0);
    for seed in 0..8u64 {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(100 + seed);
        let truth = RefRobot::from_robot(&truth_of(&nominal, &set, &[], &mut rng));
        let n = 100;
        let poses: Vec<[f64; 6]> = (0..n).map(|_| random_q(&mut rng)).collect();
        let mut bad = vec![false; n];
        let mut count = 0;
        while count < n / 20 {
            let i = rng.random_range(0..n);
            if !bad[i] {
                bad[i] = true;
                count += 1;
            }
        }
        let noise: Vec<[f64; 6]> = (0..n).map(|_| normals(&mut rng)).collect();
        // The same draws: the clean set's reading i is σ·e_i, a noisy one 10σ·e_i.
        let clean: Vec<Measurement<f64, 6>> = (0..n)
            .map(|i| observe(&truth, poses[i], 0, SIGMA, false, &noise[i]))
            .collect();
        let weighted: Vec<Measurement<f64, 6>> = (0..n)
            .map(|i| {
                let s = if bad[i] { 10.0 * SIGMA } else { SIGMA };
                observe(&truth, poses[i], 0, s, false, &noise[i])
            })
            .collect();
        let unweighted: Vec<Measurement<f64, 6>> = weighted
            .iter()
            .map(|m| Measurement {
                weight: Vector3::repeat(1.0 / SIGMA),
                ..*m
            })
            .collect();
        let valid: Vec<Measurement<f64, 6>> = (0..200)
            .map(|_| observe(&truth, random_q(&mut rng), 0, SIGMA, false, &[0.0; 6]))
            .collect();
        let (c, _, _) = held_out(&nominal, &clean, &valid);
        let (w, w_cost, p) = held_out(&nominal, &weighted, &valid);
        let (u, _, _) = held_out(&nominal, &unweighted, &valid);
        let nu = (3 * n - p) as f64;
        eprintln!(
            "seed {seed}: held-out RMS clean {c:.4} mm, weighted {w:.4} ({:.2}×), unweighted {u:.4} \
             ({:.2}×); weighted χ²/ν {:.3}",
            w / c,
            u / c,
            w_cost / nu
        );
        // One fit's held-out RMS is itself a noisy number (seed 3: 1.17× the clean fit's).
        assert!(w < 1.3 * c && u > w, "seed {seed}");
        // With the true σ the weighted cost is χ² with ν degrees of freedom: within 4√(2/ν).
        assert!(
            (w_cost / nu - 1.0).abs() < 4.0 * (2.0 / nu).sqrt(),
            "seed {seed}"
        );
        sc += c * c;
        sw += w * w;
        su += u * u;
    }
    // Over the eight seeds: the noisy readings weighted by 1/σ cost what their lost information
    // predicts (95 % of the readings: √(1/0.95) = 1.03× the clean RMS); unweighted, their
    // variance is spread over all (0.95 + 0.05·100 = 5.95 times: ~2.4×).
    let (w, u) = ((sw / sc).sqrt(), (su / sc).sqrt());
    eprintln!("over all seeds: weighted {w:.3}× the clean held-out RMS, unweighted {u:.3}×");
    assert!(w < 1.2, "{w}");
    assert!(u > 1.5 * w, "{u} vs {w}");
}
