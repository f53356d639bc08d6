//! Capsule geometry of measurement planning: the segment–segment distance against brute-force
//! sampling (general, parallel, collinear, crossing and degenerate segments), and the scene's
//! rules (which capsule pairs are compared, the sign of the incidence angle, the beam).

use kinecal::planning::capsule::{segment_distance, Capsule};
use kinecal::planning::cell::{Scene, Tracker, Violation};
use kinecal::{ForwardKinematics, Frame, Joint, Robot};
use nalgebra::Vector3;
use proptest::prelude::*;

/// Minimum distance over a fine grid of both segments, refined around the best cell: an
/// upper bound on the true distance that converges to it.
fn brute(p0: Vector3<f64>, p1: Vector3<f64>, q0: Vector3<f64>, q1: Vector3<f64>) -> f64 {
    let n = 400;
    let mut best = (f64::INFINITY, 0.0, 0.0);
    for i in 0..=n {
        let s = i as f64 / n as f64;
        let a = p0 + (p1 - p0) * s;
        for j in 0..=n {
            let t = j as f64 / n as f64;
            let d = (a - (q0 + (q1 - q0) * t)).norm();
            if d < best.0 {
                best = (d, s, t);
            }
        }
    }
    // Refine: a finer grid around the best cell.
    let (_, s0, t0) = best;
    let h = 1.0 / n as f64;
    let m = 200;
    for i in 0..=m {
        let s = (s0 - h + 2.0 * h * i as f64 / m as f64).clamp(0.0, 1.0);
        let a = p0 + (p1 - p0) * s;
        for j in 0..=m {
            let t = (t0 - h + 2.0 * h * j as f64 / m as f64).clamp(0.0, 1.0);
            let d = (a - (q0 + (q1 - q0) * t)).norm();
            best.0 = best.0.min(d);
        }
    }
    best.0
}

fn v(x: f64, y: f64, z: f64) -> Vector3<f64> {
    Vector3::new(x, y, z)
}

fn check(p0: Vector3<f64>, p1: Vector3<f64>, q0: Vector3<f64>, q1: Vector3<f64>) {
    let c = segment_distance(&p0, &p1, &q0, &q1);
    let b = brute(p0, p1, q0, q1);
    let scale = 1.0 + (p1 - p0).norm() + (q1 - q0).norm();
    // The returned points are on the segments and realise the returned distance.
    assert!(
        (0.0..=1.0).contains(&c.s) && (0.0..=1.0).contains(&c.t),
        "{c:?}"
    );
    let real = ((p0 + (p1 - p0) * c.s) - (q0 + (q1 - q0) * c.t)).norm();
    assert!((real - c.distance).abs() < 1e-9 * scale, "{c:?} vs {real}");
    // Never above the sampled minimum, and not below it by more than the refined grid step.
    assert!(
        c.distance <= b + 1e-9 * scale,
        "algorithm {} > brute force {b}",
        c.distance
    );
    assert!(
        b - c.distance < 1e-4 * scale,
        "algorithm {} ≪ brute force {b}",
        c.distance
    );
    // Symmetric in the order of the segments and of their end points.
    let r = segment_distance(&q1, &q0, &p1, &p0);
    assert!((r.distance - c.distance).abs() < 1e-9 * scale);
}

#[test]
fn special_cases_match_brute_force_and_exact_values() {
    // Crossing at right angles, 3 apart.
    let c = segment_distance(
        &v(-1.0, 0.0, 0.0),
        &v(1.0, 0.0, 0.0),
        &v(0.0, -1.0, 3.0),
        &v(0.0, 1.0, 3.0),
    );
    assert!(
        (c.distance - 3.0).abs() < 1e-12 && (c.s - 0.5).abs() < 1e-12 && (c.t - 0.5).abs() < 1e-12
    );
    // Parallel, overlapping: the perpendicular distance.
    let c = segment_distance(
        &v(0.0, 0.0, 0.0),
        &v(10.0, 0.0, 0.0),
        &v(3.0, 2.0, 0.0),
        &v(20.0, 2.0, 0.0),
    );
    assert!((c.distance - 2.0).abs() < 1e-12, "{c:?}");
    // Parallel, disjoint along the axis: end point to end point.
    let c = segment_distance(
        &v(0.0, 0.0, 0.0),
        &v(1.0, 0.0, 0.0),
        &v(4.0, 4.0, 0.0),
        &v(9.0, 4.0, 0.0),
    );
    assert!((c.distance - 5.0).abs() < 1e-12, "{c:?}");
    // Anti-parallel, disjoint.
    let c = segment_distance(
        &v(0.0, 0.0, 0.0),
        &v(1.0, 0.0, 0.0),
        &v(9.0, 4.0, 0.0),
        &v(4.0, 4.0, 0.0),
    );
    assert!((c.distance - 5.0).abs() < 1e-12, "{c:?}");
    // Collinear, overlapping and disjoint.
    let c = segment_distance(
        &v(0.0, 0.0, 0.0),
        &v(5.0, 0.0, 0.0),
        &v(3.0, 0.0, 0.0),
        &v(8.0, 0.0, 0.0),
    );
    assert!(c.distance.abs() < 1e-12);
    let c = segment_distance(
        &v(0.0, 0.0, 0.0),
        &v(5.0, 0.0, 0.0),
        &v(7.0, 0.0, 0.0),
        &v(8.0, 0.0, 0.0),
    );
    assert!((c.distance - 2.0).abs() < 1e-12);
    // Both degenerate (points).
    let c = segment_distance(
        &v(1.0, 2.0, 3.0),
        &v(1.0, 2.0, 3.0),
        &v(4.0, 6.0, 3.0),
        &v(4.0, 6.0, 3.0),
    );
    assert!((c.distance - 5.0).abs() < 1e-12);
    // One degenerate: point to segment interior and beyond its end.
    let c = segment_distance(
        &v(0.0, 3.0, 0.0),
        &v(0.0, 3.0, 0.0),
        &v(-5.0, 0.0, 0.0),
        &v(5.0, 0.0, 0.0),
    );
    assert!((c.distance - 3.0).abs() < 1e-12 && (c.t - 0.5).abs() < 1e-12);
    let c = segment_distance(
        &v(-5.0, 0.0, 0.0),
        &v(5.0, 0.0, 0.0),
        &v(8.0, 4.0, 0.0),
        &v(8.0, 4.0, 0.0),
    );
    assert!((c.distance - 5.0).abs() < 1e-12 && (c.s - 1.0).abs() < 1e-12);
    // Intersecting.
    let c = segment_distance(
        &v(0.0, 0.0, 0.0),
        &v(2.0, 2.0, 2.0),
        &v(2.0, 0.0, 0.0),
        &v(0.0, 2.0, 2.0),
    );
    assert!(c.distance < 1e-12);
    // Nearly parallel (1e-9 rad) and nearly degenerate (1e-13 mm) still agree with sampling.
    check(
        v(0.0, 0.0, 0.0),
        v(1000.0, 0.0, 0.0),
        v(200.0, 50.0, 0.0),
        v(1300.0, 50.0 + 1.1e-6, 0.0),
    );
    check(
        v(0.0, 0.0, 0.0),
        v(1e-13, 0.0, 0.0),
        v(200.0, 50.0, 7.0),
        v(-300.0, 40.0, 9.0),
    );
    check(
        v(0.0, 0.0, 0.0),
        v(1000.0, 0.0, 0.0),
        v(1000.0 + 1e-7, 1e-7, 0.0),
        v(2000.0, 0.0, 0.0),
    );
    // Non-finite input: no panic, a non-finite distance.
    let c = segment_distance(
        &v(f64::NAN, 0.0, 0.0),
        &v(1.0, 0.0, 0.0),
        &v(0.0, 1.0, 0.0),
        &v(1.0, 1.0, 0.0),
    );
    assert!(!c.distance.is_finite());
}

fn pt() -> impl Strategy<Value = Vector3<f64>> {
    (-100.0..100.0f64, -100.0..100.0f64, -100.0..100.0f64).prop_map(|(x, y, z)| v(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    #[test]
    fn general_segments_match_brute_force(p0 in pt(), p1 in pt(), q0 in pt(), q1 in pt()) {
        check(p0, p1, q0, q1);
    }

    #[test]
    fn parallel_segments_match_brute_force(p0 in pt(), dir in pt(), off in pt(), s in -2.0..2.0f64, t in -2.0..2.0f64, len in 0.1..2.0f64) {
        // q is p's direction scaled (possibly reversed), shifted anywhere.
        let q0 = p0 + off;
        check(p0, p0 + dir, q0 + dir * s, q0 + dir * (s + t * len));
    }

    #[test]
    fn collinear_segments_match_brute_force(p0 in pt(), dir in pt(), a in -3.0..3.0f64, b in -3.0..3.0f64) {
        check(p0, p0 + dir, p0 + dir * a, p0 + dir * b);
    }

    #[test]
    fn degenerate_segments_match_brute_force(p0 in pt(), q0 in pt(), q1 in pt()) {
        check(p0, p0, q0, q1);
        check(q0, q1, p0, p0);
        check(p0, p0, q0, q0);
    }

    #[test]
    fn capsule_clearance_is_distance_minus_radii(p0 in pt(), p1 in pt(), q0 in pt(), q1 in pt(), ra in 0.0..30.0f64, rb in 0.0..30.0f64) {
        let a = Capsule::new(p0, p1, ra);
        let b = Capsule::new(q0, q1, rb);
        // The segments' distance is checked against brute force by the tests above (with a
        // tolerance that grows with the segments: near-crossing ones have sharp minima the
        // grid only approaches); here: the clearance is exactly that distance minus the radii,
        // and never above the sampled minimum.
        let d = segment_distance(&p0, &p1, &q0, &q1).distance;
        let c = a.clearance(&b);
        prop_assert!((c - (d - ra - rb)).abs() < 1e-9 * (1.0 + d + ra + rb), "{c} vs {d}");
        prop_assert!(c <= brute(p0, p1, q0, q1) - ra - rb + 1e-9);
    }
}

/// A planar 3R arm along x (all axes vertical), a tool 50 mm above the flange.
fn arm() -> Robot<f64, 3, kinecal::Inline<0>> {
    let j = |a: f64| Joint::mdh_deg(0.0, a, 0.0, 0.0);
    Robot::new(
        Frame::identity(),
        [j(0.0), j(500.0), j(400.0)],
        Vector3::new(100.0, 0.0, 50.0),
    )
    .unwrap()
}

fn tracker(x: f64, y: f64, z: f64) -> Tracker<f64> {
    Tracker {
        position: v(x, y, z),
        max_incidence: 30f64.to_radians(),
        beam_radius: 5.0,
    }
}

#[test]
fn incidence_is_measured_against_the_beam_towards_the_tracker() {
    let robot = arm();
    let mut fk = ForwardKinematics::new();
    fk.compute(&robot, &[0.0, 0.0, 0.0]);
    // The tool z axis is +z; the point is at (1000, 0, 50).
    let above: Scene<f64, 4, 4> = Scene::new(tracker(1000.0, 0.0, 3000.0), None).unwrap();
    let a = above.check(&robot, &fk, true);
    assert!(a.feasible() && a.incidence.abs() < 1e-9, "{a:?}");
    // Tracker straight below: the reflector faces away: 180°, infeasible.
    let below: Scene<f64, 4, 4> = Scene::new(tracker(1000.0, 0.0, -3000.0), None).unwrap();
    let b = below.check(&robot, &fk, true);
    assert_eq!(b.violation, Some(Violation::Incidence));
    assert!((b.incidence.to_degrees() - 180.0).abs() < 1e-6);
    // 29° and 31° off the axis.
    for (deg, ok) in [(29.0f64, true), (31.0, false)] {
        let r = 3000.0;
        let s: Scene<f64, 4, 4> = Scene::new(
            tracker(
                1000.0 + r * deg.to_radians().sin(),
                0.0,
                50.0 + r * deg.to_radians().cos(),
            ),
            None,
        )
        .unwrap();
        let c = s.check(&robot, &fk, true);
        assert_eq!(c.feasible(), ok, "{deg}°: {c:?}");
        assert!((c.incidence.to_degrees() - deg).abs() < 1e-9);
    }
}

/// The incidence is the measured frame's z axis against the beam: a tool turned 20° about y
/// by `[tool] rpy_deg` (`Robot::set_tool_axes`) faces a tracker 20° off the flange axis head on
/// (the flange's axis was used: 20° reported, and a tracker on the flange axis accepted at 0°
/// although the reflector looked 20° away).
#[test]
fn incidence_is_measured_along_the_tool_axes() {
    let mut robot = arm();
    let turn = 20f64.to_radians();
    let (s, c) = turn.sin_cos();
    // The measured frame's axes in the flange frame: a rotation of 20° about y.
    robot
        .set_tool_axes(Frame {
            x: v(c, 0.0, -s),
            y: v(0.0, 1.0, 0.0),
            z: v(s, 0.0, c),
            o: Vector3::zeros(),
        })
        .unwrap();
    let mut fk = ForwardKinematics::new();
    fk.compute(&robot, &[0.0, 0.0, 0.0]);
    let r = 3000.0;
    let along_tool = tracker(1000.0 + r * s, 0.0, 50.0 + r * c);
    let scene: Scene<f64, 4, 4> = Scene::new(along_tool, None).unwrap();
    let a = scene.check(&robot, &fk, true);
    assert!(
        a.feasible() && a.incidence.to_degrees().abs() < 1e-6,
        "{a:?}"
    );
    let along_flange: Scene<f64, 4, 4> = Scene::new(tracker(1000.0, 0.0, 3000.0), None).unwrap();
    let b = along_flange.check(&robot, &fk, true);
    assert!((b.incidence.to_degrees() - 20.0).abs() < 1e-3, "{b:?}");
}

/// A floor and no link capsules (a cell file with a tracker and `[floor]` only): the measured
/// point below the floor passed (6 of 40 planned poses under it); it is a violation now, and
/// its height above the floor the clearance.
#[test]
fn the_measured_point_is_kept_above_the_floor_without_capsules() {
    let robot = arm();
    let mut fk = ForwardKinematics::new();
    fk.compute(&robot, &[0.0, 0.0, 0.0]);
    // The point is at z = 50.
    let above: Scene<f64, 4, 4> = Scene::new(tracker(1000.0, 0.0, 3000.0), Some(20.0)).unwrap();
    let a = above.check(&robot, &fk, true);
    assert!(a.feasible() && (a.clearance - 30.0).abs() < 1e-9, "{a:?}");
    assert!((above.clearance(&fk) - 30.0).abs() < 1e-9);
    let over: Scene<f64, 4, 4> = Scene::new(tracker(1000.0, 0.0, 3000.0), Some(60.0)).unwrap();
    assert_eq!(
        over.check(&robot, &fk, true).violation,
        Some(Violation::PointBelowFloor)
    );
    assert!((over.clearance(&fk) + 10.0).abs() < 1e-9);
}

#[test]
fn neighbouring_bodies_are_not_compared_and_the_beam_ignores_the_reflector_body() {
    let robot = arm();
    let mut fk = ForwardKinematics::new();
    // Capsules on frames 0, 1, 3 (none on 2): 0–1 and 1–3 are neighbours, 0–3 are compared.
    let mut s: Scene<f64, 8, 4> = Scene::new(tracker(1000.0, 0.0, 3000.0), Some(-100.0)).unwrap();
    s.add_link_capsule(0, Capsule::new(v(0.0, 0.0, 0.0), v(0.0, 0.0, 10.0), 20.0))
        .unwrap();
    s.add_link_capsule(1, Capsule::new(v(0.0, 0.0, 0.0), v(500.0, 0.0, 0.0), 20.0))
        .unwrap();
    s.add_link_capsule(
        3,
        Capsule::new(v(-100.0, 0.0, 0.0), v(80.0, 0.0, 0.0), 20.0),
    )
    .unwrap();
    assert!(!s.compared(0, 1) && !s.compared(1, 2) && s.compared(0, 2));
    fk.compute(&robot, &[0.0, 0.0, 0.0]);
    assert!(s.check(&robot, &fk, true).feasible());
    // Fold the arm back over the base: link 3's capsule reaches the base capsule.
    let q = [0.0, std::f64::consts::PI * 0.999, 0.0];
    fk.compute(&robot, &q);
    // (The point is then at (0, 0, 50), 18.7° off the tracker's beam: incidence is fine.)
    assert!(s.check(&robot, &fk, false).feasible());
    let folded = s.check(&robot, &fk, true);
    assert_eq!(
        folded.violation,
        Some(Violation::SelfCollision {
            first: 0,
            second: 2
        })
    );
    assert!(
        (s.clearance(&fk) + 20.0).abs() < 0.1,
        "{}",
        s.clearance(&fk)
    );
    // The beam may touch the last body's capsule (it holds the reflector) but not an
    // obstacle or another link: put an obstacle across the beam.
    fk.compute(&robot, &[0.0, 0.0, 0.0]);
    let mut blocked = s.clone();
    blocked
        .add_obstacle(Capsule::new(
            v(900.0, -50.0, 1500.0),
            v(1100.0, 50.0, 1500.0),
            30.0,
        ))
        .unwrap();
    assert_eq!(
        blocked.check(&robot, &fk, true).violation,
        Some(Violation::BeamObstacle { obstacle: 0 })
    );
    // The floor: lower it under the base capsule's bottom, then raise it above.
    let mut floor: Scene<f64, 8, 4> =
        Scene::new(tracker(1000.0, 0.0, 3000.0), Some(-19.0)).unwrap();
    floor
        .add_link_capsule(0, Capsule::new(v(0.0, 0.0, 0.0), v(0.0, 0.0, 10.0), 20.0))
        .unwrap();
    assert_eq!(
        floor.check(&robot, &fk, true).violation,
        Some(Violation::Floor { link: 0 })
    );
}

/// The wrist aiming of the pose sampler works for other arms than the 6R it was tuned on:
/// a 7-joint arm (KUKA LBR iiwa-like rows), aiming at random targets about 3 m away.
#[test]
fn wrist_aiming_converges_on_a_seven_joint_arm() {
    use kinecal::planning::pose_pool::{aim_wrist, uniform_configuration};
    use rand::SeedableRng;
    let rows = [
        Joint::mdh_deg(0.0, 0.0, 0.0, 340.0),
        Joint::mdh_deg(-90.0, 0.0, 0.0, 0.0),
        Joint::mdh_deg(90.0, 0.0, 0.0, 400.0),
        Joint::mdh_deg(90.0, 0.0, 0.0, 0.0),
        Joint::mdh_deg(-90.0, 0.0, 0.0, 400.0),
        Joint::mdh_deg(-90.0, 0.0, 0.0, 0.0),
        Joint::mdh_deg(90.0, 0.0, 0.0, 126.0),
    ];
    let robot: Robot<f64, 7, kinecal::Inline<0>> =
        Robot::new(Frame::identity(), rows, Vector3::new(0.0, 0.0, 100.0)).unwrap();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(4);
    let mut fk = ForwardKinematics::new();
    let mut ok = 0;
    for k in 0..200 {
        let mut q = uniform_configuration(&mut rng, &robot);
        let a = k as f64 * 0.7;
        let target = v(3000.0 * a.cos(), 3000.0 * a.sin(), 500.0);
        if aim_wrist(&robot, &mut fk, &mut q, &target, 1e-6) {
            ok += 1;
            fk.compute(&robot, &q);
            let z = fk.frames[6].z;
            let d = (target - fk.point).normalize();
            assert!(
                z.dot(&d) > (1e-5f64).cos(),
                "aimed badly: {}",
                z.dot(&d).acos()
            );
            assert!(robot.within_limits(&q));
        }
    }
    assert!(ok >= 150, "aiming converged for {ok} of 200 configurations");
}
