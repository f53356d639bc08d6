//! Records of the binary model (docs/formats.md "Binary model (.kcm)") the decoder reads,
//! skips or refuses: unknown and informational tags, malformed records, and effect payloads a
//! robot file refuses (the same effect twice, an order, start or step on a kind without one).

use super::model_blob::{blob_of, model, refused, resealed};
use kinecal::io::model_blob::{self, tag, BlobError};
use kinecal::model::effects::EffectError;
use kinecal::{Robot, RobotError};
use kinecal_cli::formats::robot_file::RobotFile;

/// `blob` with one record appended before the checksum (length and CRC updated).
fn with_record(blob: &[u8], tag: u16, payload: &[u8]) -> Vec<u8> {
    let mut b = blob[..blob.len() - 4].to_vec();
    b.extend_from_slice(&tag.to_le_bytes());
    b.extend_from_slice(&(payload.len() as u32).to_le_bytes());
    b.extend_from_slice(payload);
    b.extend_from_slice(&[0; 4]);
    let len = b.len() as u32;
    b[8..12].copy_from_slice(&len.to_le_bytes());
    resealed(b)
}

#[test]
fn records_unknown_informational_and_malformed() {
    let r = model::<6>(crate::common::ER20_TILTED_PLACED);
    let blob = blob_of(&r);
    let target = RobotFile::parse(crate::common::ER20_PLACED, "test")
        .unwrap()
        .to_robot::<6>()
        .unwrap();
    // An informational record is skipped: the model is the same.
    let info = with_record(&blob, tag::INFORMATIONAL | 1, b"ER20 cell 3, 2026-11-26");
    let mut t = target.clone();
    model_blob::decode(&info, &mut t).unwrap();
    assert_eq!(t, r);
    // A correction this library does not know (the next tag after base-drift's) is refused.
    let next = tag::BASE_DRIFT + 1;
    refused(
        &with_record(&blob, next, &[0; 32]),
        &target,
        BlobError::UnknownRecord(next),
    );
    // An effect whose count disagrees with its length.
    let mut scale = vec![0u8; 24 + 8];
    scale[4] = 2; // count 2, one value
    refused(
        &with_record(&blob, tag::JOINT_SCALE, &scale),
        &target,
        BlobError::Malformed,
    );
    // An effect on a joint the robot lacks, a second coupling chain.
    let mut scale = vec![0u8; 24 + 8];
    scale[0] = 6;
    scale[4] = 1;
    let e = model_blob::decode(
        &with_record(&blob, tag::JOINT_SCALE, &scale),
        &mut target.clone(),
    );
    assert!(matches!(e, Err(BlobError::Refused(_))), "{e:?}");
    let mut chain = vec![0u8; 12];
    chain[0] = 1; // joint 2 from joint 1, while joint 3 is coupled from joint 2
    chain[4..12].copy_from_slice(&1.0f64.to_le_bytes());
    let e = model_blob::decode(
        &with_record(&blob, tag::COUPLING, &chain),
        &mut target.clone(),
    );
    assert!(matches!(e, Err(BlobError::Refused(_))), "{e:?}");
    // A record running past the end.
    let mut b = with_record(&blob, tag::JOINT_SCALE, &scale);
    let at = b.len() - 4 - 32 - 4;
    b[at..at + 4].copy_from_slice(&1000u32.to_le_bytes());
    refused(&resealed(b), &target, BlobError::Malformed);
}

/// An effect payload: joint (0-based), order, start, step, values.
fn effect(joint: u8, order: u16, start: f64, step: f64, values: &[f64]) -> Vec<u8> {
    let mut p = vec![joint, 0];
    p.extend_from_slice(&order.to_le_bytes());
    p.extend_from_slice(&(values.len() as u32).to_le_bytes());
    p.extend_from_slice(&start.to_le_bytes());
    p.extend_from_slice(&step.to_le_bytes());
    for v in values {
        p.extend_from_slice(&v.to_le_bytes());
    }
    p
}

/// The decoder refuses what a robot file refuses ("the same effect is given twice", "`order`
/// applies to joint-cyclic only", "step_deg/start_deg apply to joint-table only"), as an effect
/// of the wrong shape, the target unchanged: the same effect again (it would be applied twice:
/// kind and joint, and order for joint-cyclic), an order above 1 on another kind, a start or
/// step on a kind that has none. What a robot file or a library model writes still decodes: a
/// second harmonic order on one joint, order 0 or 1 on the others, a thermal term's T0. The
/// checks are on the blob's f64, so a start too small for f32 is refused in f32 too.
#[test]
fn effects_a_robot_file_refuses_are_refused() {
    let r = model::<6>(crate::common::ER20_TILTED_PLACED);
    let blob = blob_of(&r);
    let target = RobotFile::parse(crate::common::ER20_PLACED, "test")
        .unwrap()
        .to_robot::<6>()
        .unwrap();
    let shape = BlobError::Refused(RobotError::BadEffect(EffectError::Shape));
    // The model: scale on joint 1, cyclic of order 2 and 1 on joint 2, compliance on joint 3,
    // a table on joint 4, thermal expansion (0-based joints below).
    let table = effect(3, 1, -1.0, 0.2, &[1e-4; 10]);
    for (tag, payload, why) in [
        (
            tag::JOINT_SCALE,
            effect(0, 1, 0.0, 0.0, &[1e-4]),
            "scale twice",
        ),
        (
            tag::JOINT_SCALE,
            effect(0, 0, 0.0, 0.0, &[1e-4]),
            "scale twice, order 0",
        ),
        (
            tag::JOINT_CYCLIC,
            effect(1, 2, 0.0, 0.0, &[1e-4, 0.0]),
            "cyclic order 2 twice",
        ),
        (
            tag::JOINT_CYCLIC,
            effect(1, 1, 0.0, 0.0, &[1e-4, 0.0]),
            "cyclic order 1 twice",
        ),
        (
            tag::JOINT_COMPLIANCE,
            effect(2, 1, 0.0, 0.0, &[1e-4]),
            "compliance twice",
        ),
        (tag::JOINT_TABLE, table.clone(), "table twice"),
        (
            tag::THERMAL_EXPANSION,
            effect(0, 1, 20.0, 0.0, &[1e-5]),
            "thermal twice",
        ),
        (
            tag::JOINT_SCALE,
            effect(4, 5, 0.0, 0.0, &[1e-4]),
            "order on a scale",
        ),
        (
            tag::JOINT_COMPLIANCE,
            effect(4, 2, 0.0, 0.0, &[1e-4]),
            "order on a compliance",
        ),
        (
            tag::JOINT_TABLE,
            effect(4, 2, -1.0, 0.2, &[1e-4; 3]),
            "order on a table",
        ),
        (
            tag::JOINT_CYCLIC,
            effect(4, 1, 0.5, 0.0, &[1e-4, 0.0]),
            "start on a cyclic",
        ),
        (
            tag::JOINT_CYCLIC,
            effect(4, 1, 0.0, 0.1, &[1e-4, 0.0]),
            "step on a cyclic",
        ),
        (
            tag::JOINT_SCALE,
            effect(4, 1, 0.1, 0.0, &[1e-4]),
            "start on a scale",
        ),
        (
            tag::JOINT_COMPLIANCE,
            effect(4, 1, 0.0, 0.1, &[1e-4]),
            "step on a compliance",
        ),
    ] {
        let b = with_record(&blob, tag, &payload);
        let mut t = target.clone();
        assert_eq!(model_blob::decode(&b, &mut t), Err(shape), "{why}");
        assert_eq!(t, target, "{why}");
    }
    // A step on a thermal term or a drift (no second one of either: a model without them).
    let plain = blob_of(&target);
    for (tag, payload) in [
        (tag::THERMAL_EXPANSION, effect(0, 1, 20.0, 0.5, &[1e-5])),
        (tag::BASE_DRIFT, effect(0, 1, 1.7e9, 0.5, &[1e-5, 0.0, 0.0])),
    ] {
        refused(&with_record(&plain, tag, &payload), &target, shape);
    }
    // Accepted: another harmonic order on a joint that has one, order 0 or 1 on the others
    // (1 from a robot file, 0 from a model built in the library), a thermal term's and a
    // drift's reference.
    for (tag, payload) in [
        (tag::JOINT_CYCLIC, effect(1, 3, 0.0, 0.0, &[1e-4, 0.0])),
        (tag::JOINT_SCALE, effect(4, 0, 0.0, 0.0, &[1e-4])),
        (tag::JOINT_TABLE, effect(4, 0, -1.0, 0.2, &[1e-4; 3])),
        (tag::BASE_DRIFT, effect(0, 1, 1.7e9, 0.0, &[1e-5, 0.0, 0.0])),
    ] {
        let mut t = target.clone();
        model_blob::decode(&with_record(&blob, tag, &payload), &mut t).unwrap();
        assert_eq!(t.effects().len(), r.effects().len() + 1);
    }
    // A start that rounds to 0 in f32 is refused there as in f64.
    let tiny = with_record(
        &blob,
        tag::JOINT_CYCLIC,
        &effect(4, 1, 1e-300, 0.0, &[1e-4, 0.0]),
    );
    let small: Robot<f32, 6, kinecal::Inline<256>> =
        target.cast::<f32>().unwrap().with_capacity().unwrap();
    refused(&tiny, &target, shape);
    let mut t = small.clone();
    assert_eq!(model_blob::decode(&tiny, &mut t), Err(shape));
    assert_eq!(t, small);
}

/// What the decoder refuses the encoder does not write (the review: a library model with the
/// same scale twice on a joint, or a cyclic term with a start, was written and then refused on
/// loading): refused with the same error; one of each is written and read back.
#[test]
fn the_encoder_refuses_what_the_decoder_would() {
    use kinecal::model::effects::EffectKind;
    let base = RobotFile::parse(crate::common::ER20_TILTED_PLACED, "test")
        .unwrap()
        .to_robot::<6>()
        .unwrap();
    let shape = BlobError::Refused(RobotError::BadEffect(EffectError::Shape));
    let mut buf = vec![0u8; 1 << 16];
    let with = |kind: EffectKind, order: u16, start: f64, twice: bool| {
        let mut r = base.clone();
        for _ in 0..1 + usize::from(twice) {
            r.effects_mut()
                .push(
                    kind,
                    4,
                    6,
                    order,
                    start,
                    0.0,
                    &[1e-4, 0.0][..if kind == EffectKind::Cyclic { 2 } else { 1 }],
                )
                .unwrap();
        }
        r
    };
    for (r, why) in [
        (with(EffectKind::Scale, 1, 0.0, true), "scale twice"),
        (with(EffectKind::Cyclic, 1, 0.3, false), "start on a cyclic"),
        (
            with(EffectKind::Compliance, 2, 0.0, false),
            "order on a compliance",
        ),
    ] {
        assert_eq!(model_blob::encode(&r, &mut buf), Err(shape), "{why}");
    }
    let r = with(EffectKind::Scale, 1, 0.0, false);
    let n = model_blob::encode(&r, &mut buf).unwrap();
    let mut back = base.clone();
    model_blob::decode(&buf[..n], &mut back).unwrap();
    assert_eq!(back, r);
}
