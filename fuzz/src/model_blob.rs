//! The binary model decoder (`io::model_blob`, docs/formats.md "Binary model (.kcm)").
//!
//! Input: a flag byte (bit 0: rewrite the header's length and the CRC-32 to match the bytes,
//! so the fuzzer reaches the records; bit 1: decode as 7 joints instead of 6), then the blob.
//!
//! Invariants:
//! - `no-panic`;
//! - `error-leaves-unchanged`: a refused blob leaves the robot as it was;
//! - `decoded-finite`: an accepted blob gives a robot whose numbers are finite;
//! - `re-encode-equal`: what decodes re-encodes, and that decodes to an equal robot whose
//!   encoding is the same bytes (one canonical form);
//! - `joint-count-agrees`: `joint_count` accepts exactly what passes the header checks.

use super::{invariant, robot_finite};
use kinecal::io::model_blob::{self, BlobError};
use kinecal::io::snapshot::crc32;
use kinecal::{Frame, Joint, Robot};
use nalgebra::Vector3;

type V = kinecal::Inline<64>;

fn start<const N: usize>() -> Robot<f64, N, V> {
    Robot::new(
        Frame::identity(),
        [Joint::mdh(0.0, 100.0, 0.0, 50.0); N],
        Vector3::new(0.0, 0.0, 10.0),
    )
    .expect("start robot")
}

fn check<const N: usize>(blob: &[u8]) {
    let mut robot = start::<N>();
    let before = robot.clone();
    match model_blob::decode(blob, &mut robot) {
        Err(e) => {
            invariant!("error-leaves-unchanged", robot == before, "{e:?}");
            if let Ok(n) = model_blob::joint_count(blob) {
                invariant!(
                    "joint-count-agrees",
                    !matches!(e, BlobError::Truncated | BlobError::Checksum),
                    "joint_count {n} but decode {e:?}"
                );
            }
        }
        Ok(()) => {
            invariant!("decoded-finite", robot_finite(&robot));
            invariant!("joint-count-agrees", model_blob::joint_count(blob) == Ok(N));
            let mut out = vec![0u8; model_blob::encoded_len(&robot)];
            let n = model_blob::encode(&robot, &mut out);
            invariant!("re-encode-equal", n == Ok(out.len()), "{n:?}");
            let mut again = start::<N>();
            let d = model_blob::decode(&out, &mut again);
            invariant!("re-encode-equal", d.is_ok() && again == robot, "{d:?}");
            let mut out2 = vec![0u8; out.len()];
            let _ = model_blob::encode(&again, &mut out2);
            invariant!("re-encode-equal", out2 == out);
        }
    }
}

/// One input: the target's invariants asserted on `data` (panics name the invariant).
pub fn run(data: &[u8]) {
    let Some((&flags, rest)) = data.split_first() else {
        return;
    };
    let mut blob = rest.to_vec();
    if flags & 1 != 0 && blob.len() >= 16 {
        let len = blob.len() as u32;
        blob[8..12].copy_from_slice(&len.to_le_bytes());
        let n = blob.len() - 4;
        let crc = crc32(&blob[..n]);
        blob[n..].copy_from_slice(&crc.to_le_bytes());
    }
    if flags & 2 != 0 {
        check::<7>(&blob);
    } else {
        check::<6>(&blob);
    }
}
