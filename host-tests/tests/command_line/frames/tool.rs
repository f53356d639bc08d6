//! Tool distances from wrist and flange sweeps.

use super::*;

fn tool_case<const N: usize>(
    rows: &Rows,
    tool: [f64; 3],
    rest: [f64; N],
    sweeps: &[usize],
    noise: f64,
) -> kinecal::frames::circle_point::ToolEstimate<f64> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(17);
    let truth: Robot<f64, N, kinecal::Inline<0>> = robot(rows, tool, random_base(&mut rng));
    let data = sweep_data(&truth, &rest, sweeps, 24, 360.0, noise, 4).unwrap();
    let set = SweepSet::from_dataset(&data).unwrap().unwrap();
    tool_from_sweeps(&truth, &set.get(N - 2).unwrap(), set.get(N - 1).as_ref()).unwrap()
}

#[test]
fn tool_distances_from_wrist_and_flange_sweeps() {
    let rest = [10.0, -20.0, 30.0, 15.0, 40.0, 0.0];
    // Point on the flange axis (UR10, ER20): radial at the noise level, axial = d6 + tool z.
    for (name, rows, tool, axial) in [
        ("UR10", &UR10, UR10_TOOL, 92.2 + 109.0),
        ("ER20", &ER20, ER20_TOOL, 125.0 + 100.0),
    ] {
        let t = tool_case::<6>(rows, tool, rest, &[5, 6], 0.015);
        println!(
            "{name}: radial {:?} (resolved {}), axial {:.4} (truth {axial}) by {:?}",
            t.radial, t.radial_resolved, t.axial, t.method
        );
        assert!(!t.radial_resolved && t.radial.unwrap() < 0.02);
        assert_eq!(t.method, AxialMethod::CentreToWristAxis);
        assert!((t.axial - axial).abs() < 0.02);
        // Without the flange sweep: the paper's wrist-circle radius.
        let t = tool_case::<6>(rows, tool, rest, &[5], 0.015);
        assert_eq!(t.method, AxialMethod::WristRadius);
        assert!(t.radial.is_none() && (t.axial - axial).abs() < 0.02);
    }
    // Offset tool: radial = √(x² + y²), axial = d6 + tool z along the flange axis.
    let t = tool_case::<6>(&GENERAL, GENERAL_TOOL, rest, &[5, 6], 0.015);
    let (radial, axial) = (
        GENERAL_TOOL[0].hypot(GENERAL_TOOL[1]),
        110.0 + GENERAL_TOOL[2],
    );
    println!(
        "offset tool: radial {:?} (truth {radial:.4}), axial {:.4} (truth {axial}) by {:?}",
        t.radial, t.axial, t.method
    );
    assert!(t.radial_resolved && t.method == AxialMethod::FlangeAxis);
    assert!((t.radial.unwrap() - radial).abs() < 0.02 && (t.axial - axial).abs() < 0.05);
    // A small offset (0.3 mm): resolved, but the flange axis's direction is poor, so the
    // rotation centre's distance from the wrist axis gives the axial distance.
    let t = tool_case::<6>(&ER20, [0.3, 0.0, 100.0], rest, &[5, 6], 0.015);
    println!(
        "0.3 mm offset: radial {:?}, axial {:.4} (truth 225) by {:?}",
        t.radial, t.axial, t.method
    );
    assert!(
        t.radial_resolved && (t.radial.unwrap() - 0.3).abs() < 0.02,
        "{t:?}"
    );
    assert!(
        t.method == AxialMethod::CentreToWristAxis && (t.axial - 225.0).abs() < 0.02,
        "{t:?}"
    );
    // 7 joints: the last two are the wrist and the flange.
    let t = tool_case::<7>(
        &IIWA,
        [5.0, 0.0, 60.0],
        [0.0, 30.0, 0.0, -40.0, 0.0, 30.0, 0.0],
        &[6, 7],
        0.015,
    );
    assert!(
        t.radial_resolved
            && (t.radial.unwrap() - 5.0).abs() < 0.02
            && (t.axial - 186.0).abs() < 0.05,
        "{t:?}"
    );
}
