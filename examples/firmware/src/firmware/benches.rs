//! Stage 6: instruction counts of the building blocks, printed as `BENCH` lines.

use super::kernels::{bpnn_forward_f32, compensate_f32, fk_f32, fk_f64, jacobian_f32, new_fk};
use super::{fail, Stateful, MODEL};
use crate::bench::Counter;
use crate::scenario::{self, Net, N, P};
use core::hint::black_box;
use cortex_m::interrupt as irq;
use cortex_m_semihosting::hprintln;
use kinecal::compensate::Target;
use kinecal::Measurement;
use nalgebra::Vector3;

/// Stage 6: instruction counts of the building blocks (see `bench.rs` for the method).
#[inline(never)]
pub(super) fn benches(
    counter: &mut Counter,
    id: &[Measurement<f32, N>],
    stateful: &Stateful,
    net: &Net<f32>,
) {
    let robot = scenario::nominal::<f32>();
    let robot64 = scenario::nominal::<f64>();
    let q = id[0].q;
    let q64 = q.map(|v| v as f64);
    let mut fk = new_fk::<f32>();
    let mut fk64 = new_fk::<f64>();
    let set = scenario::params();

    let n = counter.per_call(|| {
        black_box(fk_f32(black_box(&mut fk), black_box(&robot), black_box(&q)));
    });
    report("fk_f32", n);
    let n = counter.per_call(|| {
        black_box(fk_f64(
            black_box(&mut fk64),
            black_box(&robot64),
            black_box(&q64),
        ));
    });
    report("fk_f64", n);
    fk_f32(&mut fk, &robot, &q);
    let mut cols = [Vector3::zeros(); P];
    let n = counter.per_call(|| {
        jacobian_f32(
            black_box(&fk),
            black_box(&robot),
            black_box(set.as_slice()),
            black_box(&mut cols),
        );
    });
    report("jacobian_f32", n);

    // One 6-D target from the nominal seed (a cold start), with the identified model.
    let model =
        irq::free(|cs| MODEL.borrow(cs).borrow().clone()).unwrap_or_else(|| fail("no model"));
    let qn = scenario::nominal_joints::<f32>(0);
    fk_f32(&mut fk, &robot, &qn);
    let target = Target::Pose(fk.flange_pose());
    let cfg = scenario::compensation();
    if let Ok(s) = compensate_f32(&model, &target, &qn, &cfg) {
        hprintln!(
            "compensate: cold start from the nominal seed, {} Newton steps",
            s.iterations
        );
    }
    let n = counter.per_call(|| {
        let _ = black_box(compensate_f32(
            black_box(&model),
            black_box(&target),
            black_box(&qn),
            &cfg,
        ));
    });
    report("compensate_f32", n);

    report("lm_pose_f32", stateful.lm_pose);
    report("lm_pose6d_f32", stateful.lm_pose6d);
    report("lm_point_multi_f32", stateful.lm_point_multi);
    report("lm_remaster_f32", stateful.lm_remaster);
    report("lm_socket_f32", stateful.lm_socket);
    report("pso_particle_f32", stateful.pso_particle);

    let x = scenario::net_input::<f32>();
    let n = counter.per_call(|| {
        black_box(bpnn_forward_f32(black_box(net), black_box(&x)));
    });
    report("bpnn_forward_f32", n);
}

pub(super) fn report(name: &str, insns: f32) {
    hprintln!("BENCH {} {}", name, libm::roundf(insns) as u32);
}
