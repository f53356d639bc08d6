//! Snapshots of a run over 6-D and multi-reflector observations resume bit-identical.

use super::*;

/// A run over 6-D observations of one point and position observations of two more, saved and
/// restored into a fresh solver after every call, ends bit-identical to the uninterrupted run
/// (the snapshot carries the further tool points and the tool axes).
#[test]
fn snapshots_keep_tool_points_and_axes() {
    use kinecal::io::snapshot::Snapshot;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
    let mut nominal = ur10(Vector3::new(0.0, 0.0, 109.0));
    nominal
        .set_tool_point(1, Vector3::new(70.0, 0.0, 100.0))
        .unwrap();
    nominal
        .set_tool_point(2, Vector3::new(-30.0, 55.0, 95.0))
        .unwrap();
    nominal
        .set_tool_axes(Frame::from_xyz_rpy(
            [0.0; 3],
            [deg(5.0), deg(-10.0), deg(30.0)],
        ))
        .unwrap();
    let mut set = six_d_set();
    for k in 1..3u8 {
        for a in 0..3u8 {
            set.push(Param::ToolPoint(k, a)).unwrap();
        }
    }
    let truth = RefRobot::from_robot(&truth_of(
        &nominal,
        &set,
        &[(Param::ToolRx, deg(0.1)), (Param::ToolRy, deg(-0.1))],
        &mut rng,
    ));
    let data: Vec<Measurement<f64, 6>> = (0..25)
        .flat_map(|_| {
            let q = random_q(&mut rng);
            let n = [normals(&mut rng), normals(&mut rng), normals(&mut rng)];
            (0..3).map(move |k| (q, k, n[k]))
        })
        .map(|(q, k, n)| observe(&truth, q, k, SIGMA, k == 0, &n))
        .collect();
    let reference = fit(&nominal, &set, &data);
    let mut lm = Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
    lm.hold(Param::ToolRz).unwrap();
    let mut restores = 0;
    while lm.step(&data, 7).unwrap().stopped.is_none() {
        let mut buf = Vec::new();
        lm.save(&mut buf).unwrap();
        let mut fresh: Lm =
            Levenberg::fixed(nominal.clone(), set.clone(), LmConfig::default()).unwrap();
        // (A snapshot restores into a solver with the same holds.)
        fresh.hold(Param::ToolRz).unwrap();
        fresh.restore(&mut buf.as_slice()).unwrap();
        lm = fresh;
        restores += 1;
    }
    assert!(restores > 10);
    assert_eq!(lm.robot(), reference.robot());
    assert_eq!(lm.progress(), reference.progress());
    assert_ne!(lm.robot().tool_axes(), nominal.tool_axes());
    assert_ne!(lm.robot().tool_point(2), nominal.tool_point(2));
}
