//! 6-D data: theta6 and the tool orientation recovered, in agreement with the reference solver.

use super::*;

/// `Rz(theta6)·R_tool`: where the measured frame sits relative to joint 6's axis at reading 0
/// (what 6-D data see of theta6 and the tool axes together).
fn last_link_rotation(r: &RefRobot) -> Matrix3<f64> {
    Rotation3::from_axis_angle(&Vector3::z_axis(), r.joints[5].theta).into_inner() * r.tool_axes
}

/// 6-D data (0.02 mm, 0.005°, weighted 1/σ) determine theta6 and the tool orientation; the
/// same poses' points alone do not (no point moves with the tool axes, and turning joint 6's
/// zero only turns the tool point about joint 6's axis, which the tool point's x and y do as
/// well; at the nominal point, on that axis, it moves nothing). The library's fit and the
/// reference solver's agree, and the cost over its degrees of freedom is χ².
#[test]
fn six_d_data_recover_theta6_and_tool_orientation() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(6);
    let mut nominal = ur10(Vector3::new(0.0, 0.0, 109.0));
    nominal
        .set_tool_axes(Frame::from_xyz_rpy(
            [0.0; 3],
            [deg(5.0), deg(-10.0), deg(30.0)],
        ))
        .unwrap();
    let set = six_d_set();
    let truth = truth_of(
        &nominal,
        &set,
        &[
            (Param::Theta(5), deg(0.25)),
            (Param::ToolRx, deg(0.12)),
            (Param::ToolRy, deg(-0.09)),
        ],
        &mut rng,
    );
    let reference_truth = RefRobot::from_robot(&truth);
    let poses: Vec<[f64; 6]> = (0..50).map(|_| random_q(&mut rng)).collect();
    let data: Vec<Measurement<f64, 6>> = poses
        .iter()
        .map(|q| observe(&reference_truth, *q, 0, SIGMA, true, &normals(&mut rng)))
        .collect();
    let points: Vec<Measurement<f64, 6>> = data
        .iter()
        .map(|m| Measurement {
            orientation: None,
            orientation_weight: 0.0,
            ..*m
        })
        .collect();
    let valid: Vec<[f64; 6]> = (0..50).map(|_| random_q(&mut rng)).collect();

    let lm = fit(&nominal, &set, &data);
    let held: Vec<Param> = lm.unidentifiable().collect();
    let fitted = RefRobot::from_robot(lm.robot());
    let theta6_err = (fitted.joints[5].theta - reference_truth.joints[5].theta).abs();
    let axes_err = angle_between(&fitted.tool_axes, &reference_truth.tool_axes);
    let last_err = angle_between(
        &last_link_rotation(&fitted),
        &last_link_rotation(&reference_truth),
    );
    let (gap_p, gap_r) = prediction_rms(&fitted, &reference_truth, &valid);
    let rms = rms_error(lm.robot(), &data);
    let rms_rot = rms_orientation_error(lm.robot(), &data).unwrap();
    // Standard errors at the truth, from the reference's Jacobian (whitened residuals).
    let params = active(&lm);
    let data_ref: Vec<RefObservation> = data.iter().map(to_ref).collect();
    let se = standard_errors(&reference_truth, &params, &data_ref);
    let se_of = |p: Param| se[params.iter().position(|x| *x == p).unwrap()];
    let se_theta6 = se_of(Param::Theta(5));
    let se_axes = se_of(Param::ToolRx).hypot(se_of(Param::ToolRy));
    eprintln!(
        "6-D: held {held:?}; theta6 error {:.2e}° (σ {:.2e}°), tool axes {:.2e}° (σ {:.2e}°), \
         Rz(theta6)·R_tool {:.2e}°; held-out RMS prediction vs truth {gap_p:.4} mm {:.2e}°; \
         fit RMS {rms:.4} mm {:.2e}°",
        theta6_err.to_degrees(),
        se_theta6.to_degrees(),
        axes_err.to_degrees(),
        se_axes.to_degrees(),
        last_err.to_degrees(),
        gap_r.to_degrees(),
        rms_rot.to_degrees()
    );
    assert!(!held.contains(&Param::Theta(5)), "{held:?}");
    assert!(!held.contains(&Param::ToolRx) && !held.contains(&Param::ToolRy));
    // Within four standard errors (theta6 was moved by 0.25°, the tool axes by 0.15°).
    assert!(theta6_err < 4.0 * se_theta6, "theta6 off by {theta6_err}");
    assert!(axes_err < 4.0 * se_axes, "tool axes off by {axes_err}");
    assert!(last_err < 4.0 * se_axes.hypot(se_theta6));
    // Held-out poses, noise-free: better than one reading.
    assert!(gap_p < SIGMA && gap_r < sigma_rot(), "{gap_p} {gap_r}");

    // Positions alone: tool.rx/ry have no column, theta6 none at the start (held at nominal,
    // 0.25° and 0.15° from the truth, and kept held as the model moves: from then on it only
    // repeats tool.x/y), and the rest still fits the points.
    let lp = fit(&nominal, &set, &points);
    let held_p: Vec<Param> = lp.unidentifiable().collect();
    eprintln!("positions only: held {held_p:?}");
    for p in [Param::Theta(5), Param::ToolRx, Param::ToolRy] {
        assert!(held_p.contains(&p), "{p:?} not held: {held_p:?}");
    }
    let fitted_p = RefRobot::from_robot(lp.robot());
    assert_eq!(fitted_p.joints[5].theta, nominal.joints()[5].theta);
    assert_eq!(lp.robot().tool_axes(), nominal.tool_axes());
    assert!(
        angle_between(
            &last_link_rotation(&fitted_p),
            &last_link_rotation(&reference_truth)
        ) > deg(0.2)
    );
    assert!(rms_error(lp.robot(), &points) < 2.0 * SIGMA);

    // The reference solver on the same data and parameters, from the same start. Models are
    // compared by their predictions at the data's and at held-out poses (the held tool.rz
    // leaves theta6 and the tool axes free to trade a rotation about z6 between them, to second
    // order of the steps: 1.6e-6 rad here, different for every path), and by
    // Rz(theta6)·R_tool, which that trade leaves alone.
    let rf = ref_fit(&RefRobot::from_robot(&nominal), &params, &data_ref);
    // The reference solver itself: noise-free data of the library's fit (a model of the
    // family the held parameters allow: the truth is not, as its alpha3/alpha4 moves make
    // the axes d3, d4 slide along not quite parallel) are fitted back from nominal. Not to
    // rounding: nalgebra's angle is acos((trace − 1)/2), and next to zero acos(1 − 1.1e-16)
    // is 1.5e-8 rad, so orientation residuals below ~1e-8 rad are lost: it stops 2e-8 mm and
    // 3e-10 rad off (with an atan2 angle instead: 6e-13 mm). With noise, angles ~1e-4 rad,
    // the same acos is good to ~1e-11 rad.
    let exact_data: Vec<RefObservation> = poses
        .iter()
        .map(|q| to_ref(&observe(&fitted, *q, 0, SIGMA, true, &[0.0; 6])))
        .collect();
    let rf0 = ref_fit(&RefRobot::from_robot(&nominal), &params, &exact_data);
    let (tp, tr) = prediction_gap(&rf0.robot, &fitted, &valid, 1);
    eprintln!(
        "reference on noise-free data: cost {:.1e}, held-out predictions off the model by \
         {tp:.1e} mm {tr:.1e} rad",
        rf0.cost
    );
    assert!(
        rf0.cost < 1e-8 && tp < 1e-6 && tr < 1e-8,
        "{} {tp} {tr}",
        rf0.cost
    );
    let lib_cost = library_cost(lm.robot(), &data);
    let sv = &rf.singular_values;
    eprintln!(
        "reference: {} steps, cost {:.9}, library {:.9}, reference's residuals at the library's \
         model {:.9}; {} singular values of the scaled Jacobian, {:.2e} .. {:.2e}",
        rf.iterations,
        rf.cost,
        lib_cost,
        fitted.cost(&data_ref),
        sv.len(),
        sv[sv.len() - 1],
        sv[0],
    );
    // The reference's residuals take the orientation error's angle from acos of the trace,
    // ~1e-11 rad off at these angles (5e-8 of σ_rot per row): its cost is good to ~1e-7.
    assert!((lib_cost - fitted.cost(&data_ref)).abs() < 2e-7 * lib_cost);
    assert!((lib_cost - rf.cost).abs() < 2e-7 * lib_cost);
    // Default settings (a 1e-9 ridge; they stop once a step promises less than 1e-10 of the
    // cost): the whitened residuals may still be up to √(1e-10·cost) from the minimum's:
    // times σ, 3e-6 mm and 1.4e-8 rad here (measured: 3e-8 mm, 3e-10 rad). Run to the exact
    // minimum (see
    // `exact`): 1e-7 mm and 1e-11 rad (measured 2e-10 mm, 1.4e-12 rad: the reference's acos
    // angle, ~1e-11 rad per residual, is what is left; with an atan2 angle 4e-12 mm, 9e-15 rad).
    let bound = (LmConfig::<f64>::default().cost_tolerance * lib_cost).sqrt();
    let exact_fit = fit_with(&nominal, &set, &data, exact(), &[Param::ToolRz]);
    assert_eq!(active(&exact_fit), params);
    for (what, lib, tol_p, tol_r) in [
        (
            "default",
            fitted.clone(),
            bound * SIGMA,
            bound * sigma_rot(),
        ),
        (
            "exact",
            RefRobot::from_robot(exact_fit.robot()),
            1e-7,
            1e-11,
        ),
    ] {
        let (dp, dr) = prediction_gap(&lib, &rf.robot, &poses, 1);
        let (vp, vr) = prediction_gap(&lib, &rf.robot, &valid, 1);
        let dl = angle_between(&last_link_rotation(&lib), &last_link_rotation(&rf.robot));
        eprintln!(
            "  library ({what}) vs reference: predictions {dp:.1e} mm {dr:.1e} rad (held-out \
             {vp:.1e} mm {vr:.1e} rad), Rz(theta6)·R_tool {dl:.1e} rad, theta6 {:.1e} rad",
            (rf.robot.joints[5].theta - lib.joints[5].theta).abs()
        );
        assert!(dp.max(vp) < tol_p, "{what}: {dp} {vp} mm");
        assert!(dr.max(vr).max(dl) < tol_r, "{what}: {dr} {vr} {dl} rad");
    }

    // χ²: with the true σ, cost / (rows − parameters) is χ² over its degrees of freedom,
    // mean 1, standard deviation √(2/ν) (0.09 for ν = 300 − 30); 4 of them either way.
    let nu = (rows(&data) - params.len()) as f64;
    let chi = lib_cost / nu;
    eprintln!("χ²/ν = {chi:.3} (ν = {nu})");
    assert!((chi - 1.0).abs() < 4.0 * (2.0 / nu).sqrt(), "{chi}");
}
