//! input reachable through the public API gets a typed error, never an infinite or
//! NaN state or a panic, and a refused call leaves valid state valid.

use kinecal::identify::bpnn::{Bpnn, BpnnConfig, BpnnError, MAX_LEARNING_RATE, MAX_RANGE};
use kinecal::identify::fitness::Objective;
use kinecal::identify::lm::{Levenberg, LmConfig, LmStop};
use kinecal::identify::pso::{Pso, PsoConfig, PsoError, PsoStop};
use kinecal::io::snapshot::{crc32, Snapshot, SnapshotError, HEADER_LEN};
use kinecal::model::effects::EffectError;
use kinecal::model::param::ParamSet;
use kinecal::{
    EffectKind, Effects, ForwardKinematics, Frame, Joint, Measurement, Robot, RobotError,
};
use nalgebra::Vector3;

fn rows() -> [Joint<f64>; 6] {
    [
        Joint::mdh_deg(0.0, 0.0, 0.0, 504.0),
        Joint::mdh_deg(-90.0, 170.0, -90.0, 0.0),
        Joint::mdh_deg(0.0, 780.0, 0.0, 0.0),
        Joint::mdh_deg(-90.0, 140.0, 0.0, 760.0),
        Joint::mdh_deg(90.0, 0.0, 0.0, 0.0),
        Joint::mdh_deg(-90.0, 0.0, 0.0, 125.0),
    ]
}

fn robot() -> Robot<f64, 6> {
    Robot::new(Frame::identity(), rows(), Vector3::new(0.0, 0.0, 100.0)).unwrap()
}

fn finite_fk<V: kinecal::ValueStorage>(r: &Robot<f64, 6, V>) -> bool {
    let p = ForwardKinematics::new().compute(r, &[0.1, -0.2, 0.3, 0.4, -0.5, 0.6]);
    p.iter().all(|v| v.is_finite())
}

/// Patches `bytes` at payload offset `at` and recomputes the CRC: a CRC-valid snapshot.
fn patched(snapshot: &[u8], at: usize, bytes: &[u8]) -> Vec<u8> {
    let mut s = snapshot.to_vec();
    s[HEADER_LEN + at..HEADER_LEN + at + bytes.len()].copy_from_slice(bytes);
    let crc = crc32(&s[HEADER_LEN..]);
    s[16..20].copy_from_slice(&crc.to_le_bytes());
    s
}

fn saved<S: Snapshot>(s: &S) -> Vec<u8> {
    let mut v = Vec::new();
    s.save(&mut v).unwrap();
    v
}

#[test]
fn robot_refuses_magnitudes_no_robot_has() {
    let mut j = rows();
    j[1].a = 1e308;
    let e = Robot::<f64, 6>::new(Frame::identity(), j, Vector3::zeros()).unwrap_err();
    assert_eq!(e, RobotError::OutOfRange);
    j[1].a = f64::NAN;
    let e = Robot::<f64, 6>::new(Frame::identity(), j, Vector3::zeros()).unwrap_err();
    assert_eq!(e, RobotError::NotFinite);
    j = rows();
    j[2].theta = 1e9;
    let e = Robot::<f64, 6>::new(Frame::identity(), j, Vector3::zeros()).unwrap_err();
    assert_eq!(e, RobotError::OutOfRange);
    let e = Robot::<f64, 6>::new(Frame::identity(), rows(), Vector3::new(0.0, 2e6, 0.0));
    assert_eq!(e.unwrap_err(), RobotError::OutOfRange);

    // At the bounds the forward kinematics stay finite.
    let mut j = rows();
    j[1].a = kinecal::model::robot::MAX_LENGTH;
    j[2].d = -kinecal::model::robot::MAX_LENGTH;
    let r = Robot::<f64, 6>::new(Frame::identity(), j, Vector3::zeros()).unwrap();
    assert!(finite_fk(&r));

    // Setters refuse too, and leave the robot as it was.
    let mut r = robot();
    let before = r.clone();
    let mut bad = rows()[0];
    bad.d = -1e300;
    assert_eq!(r.set_joint(0, bad), Err(RobotError::OutOfRange));
    assert_eq!(r.set_joint(6, rows()[0]), Err(RobotError::OutOfRange));
    assert_eq!(
        r.set_tool(Vector3::new(1e300, 0.0, 0.0)),
        Err(RobotError::OutOfRange)
    );
    assert_eq!(r, before);
    assert!(finite_fk(&r));
}

#[test]
fn base_must_be_a_bounded_rotation() {
    let mut scaled = Frame::<f64>::identity();
    scaled.x *= 2.0;
    let mut left = Frame::<f64>::identity();
    left.z = -left.z;
    let mut sheared = Frame::<f64>::identity();
    sheared.y = Vector3::new(0.1, 1.0, 0.0);
    let mut far = Frame::<f64>::identity();
    far.o.x = 1e308;
    for (f, e) in [
        (scaled, RobotError::NotRotation),
        (left, RobotError::NotRotation),
        (sheared, RobotError::NotRotation),
        (far, RobotError::OutOfRange),
    ] {
        assert!(!f.is_rotation() || e == RobotError::OutOfRange);
        assert_eq!(
            Robot::<f64, 6>::new(f, rows(), Vector3::zeros()).unwrap_err(),
            e
        );
        let mut r = robot();
        assert_eq!(r.set_base(f), Err(e));
        assert_eq!(r, robot());
    }
    // A rotation from roll/pitch/yaw, and one rounded to f32, pass.
    let f = Frame::from_xyz_rpy([10.0, -20.0, 30.0], [0.3, -1.2, 2.5]);
    assert!(f.is_rotation());
    assert!(f.cast::<f32>().unwrap().is_rotation());
    assert!(robot().set_base(f).is_ok());
}

#[test]
fn casts_are_checked() {
    // A frame beyond f32's range does not cast to f32.
    let mut f = Frame::<f64>::identity();
    f.o.y = 1e300;
    assert!(f.cast::<f32>().is_none());
    assert!(Frame::<f64>::identity().cast::<f32>().is_some());

    // A table step that rounds to zero in f32: an error, not a silently dropped effect.
    let mut r = robot().with_capacity::<kinecal::Inline<4>>().unwrap();
    r.effects_mut()
        .push(EffectKind::Table, 1, 6, 1, 0.0, 1e-50, &[0.0, 1e-3])
        .unwrap();
    assert_eq!(
        r.cast::<f32>().unwrap_err(),
        RobotError::BadEffect(EffectError::Shape)
    );

    // A valid robot with couplings and effects casts, with every part.
    let mut r = robot().with_capacity::<kinecal::Inline<4>>().unwrap();
    r.set_coupling(2, 1, 1.0).unwrap();
    r.effects_mut()
        .push(EffectKind::Scale, 0, 6, 1, 0.0, 0.0, &[1e-3])
        .unwrap();
    let r32 = r.cast::<f32>().unwrap();
    assert_eq!(r32.effects().len(), 1);
    assert_eq!(r32.couplings().get(2), Some((1, 1.0f32)));
    assert_eq!(r.couplings().cast::<f32>().unwrap(), *r32.couplings());
    let back = r32.cast::<f64>().unwrap();
    assert!(finite_fk(&back));
}

#[test]
fn effects_refuse_joints_beyond_the_robot_and_u16_indices() {
    let mut r = robot().with_capacity::<kinecal::Inline<4>>().unwrap();
    // Joint 7 (index 6) of a 6-joint robot, even when the caller claims 7 joints.
    assert_eq!(
        r.effects_mut()
            .push(EffectKind::Scale, 6, 7, 1, 0.0, 0.0, &[1e-3]),
        Err(EffectError::Joint)
    );
    assert!(r.effects().is_empty());
    // A list of no robot accepts nothing.
    let mut free = Effects::<f64, kinecal::Inline<4>>::default();
    assert_eq!(
        free.push(EffectKind::Scale, 0, 6, 1, 0.0, 0.0, &[1e-3]),
        Err(EffectError::Joint)
    );
    // Values beyond the angle bound are refused.
    assert_eq!(
        r.effects_mut()
            .push(EffectKind::Scale, 0, 6, 1, 0.0, 0.0, &[1e300]),
        Err(EffectError::Shape)
    );

    // More than 65,535 values in all: refused (value indices are u16), no panic, whatever the
    // storage holds (a caller's own storage of 70,000 values on the heap).
    let mut e = Effects::<f64, Huge>::for_joints(2);
    let vals = vec![0.0; 40_000];
    e.push(EffectKind::Table, 0, 2, 1, 0.0, 1e-3, &vals)
        .unwrap();
    assert_eq!(
        e.push(EffectKind::Table, 1, 2, 1, 0.0, 1e-3, &vals),
        Err(EffectError::Capacity)
    );
    assert_eq!(e.len(), 1);
    assert_eq!(e.values().len(), 40_000);
    assert_eq!(e.values_of(0).len(), 40_000);
}

/// A caller's effect-value storage: 70,000 values on the heap, more than value indices address.
#[derive(Clone, Debug, PartialEq)]
struct Huge;

#[derive(Clone, Debug, PartialEq)]
struct HugeValues<T>(Vec<T>);

impl kinecal::ValueStorage for Huge {
    const CAPACITY: usize = 70_000;
    type Buffer<T: kinecal::Real> = HugeValues<T>;
}

impl<T: kinecal::Real> kinecal::ValueBuffer<T> for HugeValues<T> {
    fn empty() -> Self {
        HugeValues(Vec::new())
    }
    fn slots(&self) -> &[T] {
        &self.0
    }
    fn slots_mut(&mut self) -> &mut [T] {
        &mut self.0
    }
    fn reserve_slots(&mut self, len: usize) -> bool {
        if len > self.0.len() {
            self.0.resize(len, T::zero());
        }
        true
    }
    fn release_slots(&mut self, len: usize) {
        self.0.truncate(len);
    }
}

/// A caller's value buffer that breaks its contract (more readable than writable slots): the
/// list refuses to store into it instead of panicking, and stays empty.
#[derive(Clone, Debug, PartialEq)]
struct Lopsided;

#[derive(Clone, Debug, PartialEq)]
struct LopsidedValues<T>(Vec<T>);

impl kinecal::ValueStorage for Lopsided {
    const CAPACITY: usize = 16;
    type Buffer<T: kinecal::Real> = LopsidedValues<T>;
}

impl<T: kinecal::Real> kinecal::ValueBuffer<T> for LopsidedValues<T> {
    fn empty() -> Self {
        LopsidedValues(vec![T::zero(); 16])
    }
    fn slots(&self) -> &[T] {
        &self.0
    }
    fn slots_mut(&mut self) -> &mut [T] {
        &mut self.0[..1]
    }
    fn reserve_slots(&mut self, len: usize) -> bool {
        len <= 16
    }
    fn release_slots(&mut self, _len: usize) {}
}

#[test]
fn a_value_buffer_that_breaks_its_contract_is_refused_not_a_panic() {
    let mut e = Effects::<f64, Lopsided>::for_joints(6);
    assert_eq!(
        e.push(EffectKind::Cyclic, 1, 6, 1, 0.0, 0.0, &[1e-4, 2e-4]),
        Err(EffectError::Capacity)
    );
    assert!(e.is_empty());
    assert_eq!(e.values().len(), 0);
    // One value fits the one writable slot.
    e.push(EffectKind::Scale, 1, 6, 0, 0.0, 0.0, &[1e-4])
        .unwrap();
    assert_eq!(e.values(), &[1e-4]);
}

/// A list without value capacity (`Inline<0>`, the firmware's models) holds no effect, whatever
/// is pushed: [`Effects::is_empty`] says so at compile time.
#[test]
fn a_list_without_value_capacity_stays_empty() {
    let mut e = Effects::<f64, kinecal::Inline<0>>::for_joints(6);
    let pushes: [(EffectKind, u16, f64, f64, &[f64]); 7] = [
        (EffectKind::Scale, 1, 0.0, 0.0, &[1e-3]),
        (EffectKind::Compliance, 1, 0.0, 0.0, &[1e-3]),
        (EffectKind::Cyclic, 1, 0.0, 0.0, &[1e-3, 1e-3]),
        (EffectKind::Table, 1, 0.0, 0.1, &[1e-3, 1e-3]),
        (EffectKind::Thermal, 1, 20.0, 0.0, &[1e-5]),
        (EffectKind::Drift, 1, 1.7e9, 0.0, &[1e-5, 0.0, 0.0]),
        (EffectKind::Scale, 1, 0.0, 0.0, &[]),
    ];
    for (kind, order, start, step, values) in pushes {
        assert!(e.push(kind, 0, 6, order, start, step, values).is_err());
        assert!(e.is_empty());
        assert_eq!(e.len(), 0);
    }
}

#[test]
fn pso_boxes_that_overflow_are_refused() {
    assert_eq!(
        PsoConfig::<f64, 2>::new([-1e308, 0.0], [1e308, 1.0]).unwrap_err(),
        PsoError::Bounds
    );
    // A 1e15 span in f32 with a velocity factor that overflows f32.
    let mut cfg = PsoConfig::<f32, 1>::new([-5e14], [5e14]).unwrap();
    cfg.max_velocity = 1e25;
    assert_eq!(cfg.validate(), Err(PsoError::Bounds));
    assert!(Pso::<f32, 4, 1, 8>::new(cfg, 1).is_err());
    cfg.max_velocity = 0.1;
    cfg.initial_velocity = 1e30;
    assert_eq!(cfg.validate(), Err(PsoError::Bounds));
    // What passes gives finite velocity limits.
    cfg.initial_velocity = 1.0;
    let s = Pso::<f32, 4, 1, 8>::new(cfg, 1).unwrap();
    assert!(s.velocity_limits()[0].is_finite());
    assert!(s.velocities().iter().all(|v| v[0].is_finite()));
}

#[test]
fn bpnn_ranges_and_rates_that_overflow_are_refused() {
    let mut net = Bpnn::<f64, 2, 4, 1>::new(BpnnConfig::default(), 3).unwrap();
    let before = net.forward(&[0.1, 0.2]);
    assert_eq!(
        net.set_ranges(&[-1e308, 0.0], &[1e308, 1.0], &[0.0], &[1.0]),
        Err(BpnnError::NonFinite)
    );
    assert_eq!(
        net.set_ranges(&[0.0, 0.0], &[1.0, 1.0], &[-1e308], &[1e308]),
        Err(BpnnError::NonFinite)
    );
    assert_eq!(net.forward(&[0.1, 0.2]), before);
    for lr in [f64::MAX, f64::INFINITY, 1e7] {
        let cfg = BpnnConfig {
            learning_rate: lr,
            ..BpnnConfig::default()
        };
        assert_eq!(net.set_config(cfg), Err(BpnnError::Config));
        assert_eq!(
            Bpnn::<f64, 2, 4, 1>::new(cfg, 3).unwrap_err(),
            BpnnError::Config
        );
    }
    assert_eq!(net.config(), &BpnnConfig::default());
}

/// Fuzz finding (kinematics/fk-finite-2): a finite reading of 1e308 rad overflowed a
/// harmonic (`3 · q`) or a coupling (`ratio · q`) to infinity and FK gave NaN. Readings beyond
/// ±MAX_ANGLE are clamped, so every finite reading gives a finite point; NaN still gives NaN.
#[test]
fn fk_is_finite_for_every_finite_reading() {
    let mut r = robot().with_capacity::<kinecal::Inline<8>>().unwrap();
    r.set_coupling(2, 1, 1e3).unwrap();
    r.effects_mut()
        .push(EffectKind::Cyclic, 5, 6, 65_535, 0.0, 0.0, &[1e-3, 2e-3])
        .unwrap();
    r.effects_mut()
        .push(EffectKind::Scale, 1, 6, 1, 0.0, 0.0, &[1e3])
        .unwrap();
    let r32 = r.cast::<f32>().unwrap();
    for x in [1e308, -1e308, f64::MAX, 1e5, -3e38] {
        let q = [x, x, x, 0.5, -x, x];
        let p = ForwardKinematics::new().compute(&r, &q);
        assert!(p.iter().all(|v| v.is_finite()), "{x}: {p:?}");
        // The same readings in f32, kept finite there (1e308 is +inf in f32).
        let q32 = q.map(|v| v.clamp(-f32::MAX as f64, f32::MAX as f64) as f32);
        let p32 = ForwardKinematics::new().compute(&r32, &q32);
        assert!(p32.iter().all(|v| v.is_finite()), "{x} in f32: {p32:?}");
    }
    // Beyond it the reading acts as the bound.
    let far = [1.0, -0.5, 1e300, 0.2, 0.3, -1e300];
    let at = [1.0, -0.5, 1e4, 0.2, 0.3, -1e4];
    assert_eq!(
        ForwardKinematics::new().compute(&r, &far),
        ForwardKinematics::new().compute(&r, &at)
    );
    let nan = ForwardKinematics::new().compute(&r, &[f64::NAN, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert!(nan.iter().any(|v| v.is_nan()));
}

/// Fuzz finding (steppers/stays-finite-bpnn-1): an epoch left every weight finite but so
/// large (≈1e237) that the net's output was ±inf, and `train_epoch` returned `Ok`. Now an epoch
/// that leaves a weight beyond `MAX_WEIGHT` is undone as `Diverged`, inputs far outside the
/// range are clamped, and whatever the training, the output stays finite.
#[test]
fn bpnn_output_stays_finite_whatever_the_training() {
    let xs: Vec<[f64; 3]> = (0..12)
        .map(|k| [k as f64 * 1e3, -(k as f64), (k * k) as f64])
        .collect();
    let ys: Vec<[f64; 3]> = (0..12)
        .map(|k| [1e9 * (k % 3) as f64, -5.0 * k as f64, 0.5])
        .collect();
    for lr in [1e-2, 1.0, 1e2, 1e4, MAX_LEARNING_RATE] {
        let cfg = BpnnConfig {
            learning_rate: lr,
            ..BpnnConfig::default()
        };
        let mut net = Bpnn::<f64, 3, 4, 3>::new(cfg, 9).unwrap();
        net.fit_ranges(&xs, &ys).unwrap();
        let mut diverged = 0;
        for _ in 0..20 {
            let before = net.forward(&xs[3]);
            match net.train_epoch(&xs, &ys) {
                Ok(loss) => assert!(loss.is_finite(), "lr {lr}: loss {loss}"),
                Err(BpnnError::Diverged) => {
                    diverged += 1;
                    assert_eq!(net.forward(&xs[3]), before, "a diverged epoch is undone");
                }
                Err(e) => panic!("lr {lr}: {e:?}"),
            }
            for x in xs
                .iter()
                .chain([&[1e300, -1e300, 0.0], &[f64::MAX, 0.0, f64::MIN]])
            {
                let y = net.forward(x);
                assert!(y.iter().all(|v| v.is_finite()), "lr {lr}: {x:?} -> {y:?}");
            }
        }
        if lr >= 1e4 {
            assert!(diverged > 0, "lr {lr} should diverge on this data");
        }
    }
    // Ranges beyond MAX_RANGE are refused (their denormalised output could overflow).
    let mut net = Bpnn::<f32, 1, 4, 1>::new(BpnnConfig::default(), 1).unwrap();
    let big = (MAX_RANGE * 10.0) as f32;
    assert_eq!(
        net.set_ranges(&[0.0], &[1.0], &[-big], &[big]),
        Err(BpnnError::NonFinite)
    );
    let ok = MAX_RANGE as f32;
    net.set_ranges(&[-ok], &[ok], &[-ok], &[ok]).unwrap();
    assert!(net.forward(&[f32::MAX])[0].is_finite());
}

fn lm_data(truth: &Robot<f64, 6>) -> Vec<Measurement<f64, 6>> {
    let mut fk = ForwardKinematics::new();
    (0..40)
        .map(|k| {
            let t = k as f64;
            let q: [f64; 6] = core::array::from_fn(|j| (1.3 * t + 0.7 * j as f64).sin() * 2.0);
            Measurement {
                q,
                point: fk.compute(truth, &q),
                ..Default::default()
            }
        })
        .collect()
}

type Lm = kinecal::identify::lm::FixedLevenberg<f64, 6, kinecal::Inline<0>, 27>;

fn lm_setup() -> (Lm, Vec<Measurement<f64, 6>>) {
    let mut truth = robot();
    let mut j = truth.joints()[2];
    j.a += 0.5;
    truth.set_joint(2, j).unwrap();
    let set = ParamSet::<27>::full(6, false).unwrap();
    let lm = Levenberg::fixed(robot(), set, LmConfig::default()).unwrap();
    (lm, lm_data(&truth))
}

/// Payload offset of the LM's tail fields, counted from the end: 6 reals, 2 usize, 2 u8, 2 u32.
const LM_TAIL: usize = 6 * 8 + 4 + 4 + 1 + 1 + 4 + 4;

#[test]
fn lm_restore_checks_the_state_not_only_the_crc() {
    let (mut lm, data) = lm_setup();
    lm.step(&data, 50).unwrap();
    let good = saved(&lm);
    let payload = good.len() - HEADER_LEN;
    let n = 27;
    let robot_at = 12 + 3 * n; // after N, V, n and the parameter tags
    let lambda_at = payload - LM_TAIL + 3 * 8;
    let nan = f64::NAN.to_le_bytes();
    let cases = [
        patched(&good, robot_at + 12 * 8 + 8, &nan), // joint 1's a
        patched(&good, robot_at + 12 * 8 + 8, &1e308f64.to_le_bytes()),
        patched(&good, robot_at, &2.0f64.to_le_bytes()), // base x axis not unit
        patched(&good, lambda_at, &0.0f64.to_le_bytes()),
        patched(&good, lambda_at, &(-1.0f64).to_le_bytes()),
        patched(&good, lambda_at, &nan),
        patched(&good, lambda_at + 8, &f64::INFINITY.to_le_bytes()), // nu
    ];
    let mut target = lm.clone();
    for bad in &cases {
        assert_eq!(
            target.restore(&mut bad.as_slice()),
            Err(SnapshotError::Invalid)
        );
        assert_eq!(saved(&target), good, "state changed by a refused restore");
    }
    // Still steps to finite values.
    let p = target.run(&data).unwrap();
    assert!(p.cost.is_finite() && p.stopped.is_some());
    assert!(finite_fk(target.robot()));
}

#[test]
fn lm_counters_saturate_and_the_run_stops() {
    let (mut lm, data) = lm_setup();
    lm.step(&data, 50).unwrap();
    let good = saved(&lm);
    let payload = good.len() - HEADER_LEN;
    let bad = patched(&good, payload - 8, &u32::MAX.to_le_bytes()); // iteration
    let bad = patched(&bad, payload - 4, &u32::MAX.to_le_bytes()); // evaluations
    let (mut target, _) = lm_setup();
    target.restore(&mut bad.as_slice()).unwrap();
    assert_eq!(target.progress().iteration, u32::MAX);
    let p = target.run(&data).unwrap();
    assert_eq!(p.stopped, Some(LmStop::MaxIterations));
    assert_eq!(p.iteration, u32::MAX);
    assert_eq!(p.evaluations, u32::MAX);
}

/// `(x − 1)² + (y + 2)²`.
struct Bowl;
impl Objective<f64> for Bowl {
    fn dimension(&self) -> usize {
        2
    }
    fn fitness(&mut self, x: &[f64]) -> f64 {
        (x[0] - 1.0).powi(2) + (x[1] + 2.0).powi(2)
    }
}

type Swarm = Pso<f64, 5, 2, 16>;

/// Payload offset of the PSO's phase byte (f64, D = 2).
const PSO_PHASE: usize = 12 + 3 * 8 + 2 * 2 * 8 + 2 * 8 + 4 + 8 + 4 + 8 + 32;
const PSO_ITERATION: usize = PSO_PHASE + 1 + 4;
const PSO_EVALUATIONS: usize = PSO_ITERATION + 4;
const PSO_POSITION: usize = PSO_EVALUATIONS + 8 + 8 + 4 + 2 * 8 + 8;
const PSO_VELOCITY: usize = PSO_POSITION + 5 * 2 * 8;

fn swarm() -> Swarm {
    let cfg = PsoConfig::new([-5.0, -5.0], [5.0, 5.0]).unwrap();
    let mut s = Swarm::new(cfg, 7).unwrap();
    s.step(&mut Bowl, 12).unwrap();
    s
}

#[test]
fn pso_restore_checks_the_state_not_only_the_crc() {
    let s = swarm();
    let good = saved(&s);
    // The layout assumed here: the first position is the swarm's.
    let x0 = f64::from_le_bytes(good[HEADER_LEN + PSO_POSITION..][..8].try_into().unwrap());
    assert_eq!(x0, s.positions()[0][0]);
    let cases = [
        patched(&good, PSO_POSITION, &6.0f64.to_le_bytes()), // outside the box
        patched(&good, PSO_POSITION + 8, &f64::NAN.to_le_bytes()),
        patched(&good, PSO_VELOCITY, &f64::INFINITY.to_le_bytes()),
        patched(&good, PSO_VELOCITY, &5.0f64.to_le_bytes()), // beyond the limit (1.0)
    ];
    let mut target = swarm();
    for bad in &cases {
        assert_eq!(
            target.restore(&mut bad.as_slice()),
            Err(SnapshotError::Invalid)
        );
        assert_eq!(saved(&target), good);
    }
    let p = target.run(&mut Bowl).unwrap();
    assert!(p.best_fitness.is_finite());
    assert!(target.positions().iter().flatten().all(|x| x.abs() <= 5.0));
}

#[test]
fn pso_counters_saturate_and_the_run_stops() {
    let good = saved(&swarm());
    let bad = patched(&good, PSO_ITERATION, &u32::MAX.to_le_bytes());
    let bad = patched(&bad, PSO_EVALUATIONS, &u64::MAX.to_le_bytes());
    let mut target = swarm();
    target.restore(&mut bad.as_slice()).unwrap();
    assert_eq!(target.progress().iteration, u32::MAX);
    let p = target.run(&mut Bowl).unwrap();
    assert_eq!(p.stopped, Some(PsoStop::MaxIterations));
    assert_eq!(p.iteration, u32::MAX);
    assert_eq!(p.evaluations, u64::MAX);
}

#[test]
fn bpnn_restore_checks_the_weights() {
    let xs: Vec<[f64; 2]> = (0..20)
        .map(|k| [k as f64 * 0.1, 1.0 - k as f64 * 0.05])
        .collect();
    let ys: Vec<[f64; 1]> = xs.iter().map(|x| [x[0] * x[1]]).collect();
    let mut net = Bpnn::<f64, 2, 4, 1>::new(BpnnConfig::default(), 3).unwrap();
    net.fit_ranges(&xs, &ys).unwrap();
    net.train_epoch(&xs, &ys).unwrap();
    let good = saved(&net);
    let w1 = 12 + 8 + 8 + 4 + 1; // after I, H, O, rate, momentum, batch, activation
    let momentum = w1 + (4 * 2 + 4 + 4 + 1) * 8;
    for bad in [
        patched(&good, w1, &f64::NAN.to_le_bytes()),
        patched(&good, momentum, &f64::INFINITY.to_le_bytes()),
        patched(&good, 12, &f64::MAX.to_le_bytes()), // learning rate
    ] {
        let mut target = net.clone();
        assert_eq!(
            target.restore(&mut bad.as_slice()),
            Err(SnapshotError::Invalid)
        );
        assert_eq!(saved(&target), good);
        assert!(target.train_epoch(&xs, &ys).unwrap().is_finite());
    }
}
