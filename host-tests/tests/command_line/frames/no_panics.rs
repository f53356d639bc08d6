//! No panic on any input: the circle fit, joint axes, base and tool frames.

use super::*;

proptest::proptest! {
    #[test]
    fn circle_and_frames_never_panic(
        pts in proptest::collection::vec(proptest::array::uniform3(proptest::num::f64::ANY), 0..12),
        qs in proptest::collection::vec(proptest::array::uniform6(-1e6f64..1e6), 0..12),
        f32_too in proptest::bool::ANY,
    ) {
        let p: Vec<Vector3<f64>> = pts.iter().map(|a| Vector3::from(*a)).collect();
        let _ = fit_circle(&p);
        if f32_too {
            let p32: Vec<Vector3<f32>> = p.iter().map(|v| v.cast()).collect();
            let _ = fit_circle(&p32);
        }
        let angles: Vec<f64> = qs.iter().map(|q| q[0]).collect();
        let _ = joint_axis(&p, &angles);
        let r: Robot<f64, 6, kinecal::Inline<0>> = robot(&ER20, ER20_TOOL, Frame::identity());
        let n = p.len().min(qs.len());
        let s1 = Sweep { joint: 0, points: &p[..n], q: &qs[..n] };
        let s2 = Sweep { joint: 1, points: &p[..n], q: &qs[..n] };
        let _ = base_from_sweeps(&r, &s1, &s2);
        let s5 = Sweep { joint: 4, points: &p[..n], q: &qs[..n] };
        let s6 = Sweep { joint: 5, points: &p[..n], q: &qs[..n] };
        let _ = tool_from_sweeps(&r, &s5, Some(&s6));
        let bad = Sweep { joint: 9, points: &p[..n], q: &qs[..n] };
        proptest::prop_assert_eq!(bad.axis().unwrap_err(), FramesError::Shape);
    }
}
