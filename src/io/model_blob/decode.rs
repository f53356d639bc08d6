//! Reading a binary model into a robot: every check passes before the robot is replaced.

use super::{
    effect_kind, tag, BlobError, BASE_LEN, CRC_LEN, EFFECT_HEAD_LEN, HEADER_LEN, MAGIC, MAX_JOINTS,
    ROW_LEN, TOOL_LEN, VERSION,
};
use crate::io::snapshot::crc32;
use crate::model::effects::{EffectError, EffectKind};
use crate::model::tool::MAX_TOOL_POINTS;
use crate::ValueStorage;
use crate::{Frame, Joint, Real, Robot};
use nalgebra::Vector3;

/// Little-endian reader over a checked blob; reading past the end is [`BlobError::Malformed`]
/// (the header's length was checked, so only a record's own length can lead there).
struct Reader<'a> {
    buf: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn bytes(&mut self, n: usize) -> Result<&'a [u8], BlobError> {
        let end = self.at.checked_add(n).ok_or(BlobError::Malformed)?;
        let b = self.buf.get(self.at..end).ok_or(BlobError::Malformed)?;
        self.at = end;
        Ok(b)
    }
    fn array<const K: usize>(&mut self) -> Result<[u8; K], BlobError> {
        let mut a = [0u8; K];
        a.copy_from_slice(self.bytes(K)?);
        Ok(a)
    }
    fn u8(&mut self) -> Result<u8, BlobError> {
        Ok(self.array::<1>()?[0])
    }
    fn u16(&mut self) -> Result<u16, BlobError> {
        Ok(u16::from_le_bytes(self.array()?))
    }
    fn u32(&mut self) -> Result<u32, BlobError> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    /// An `f64` that must be finite, in the robot's scalar type.
    fn real<T: Real>(&mut self) -> Result<T, BlobError> {
        let v = f64::from_le_bytes(self.array()?);
        if v.is_finite() {
            Ok(T::of(v))
        } else {
            Err(BlobError::NotFinite)
        }
    }
    fn vec3<T: Real>(&mut self) -> Result<Vector3<T>, BlobError> {
        Ok(Vector3::new(self.real()?, self.real()?, self.real()?))
    }
    fn zero(&mut self) -> Result<(), BlobError> {
        if self.u8()? == 0 {
            Ok(())
        } else {
            Err(BlobError::Malformed)
        }
    }
    fn done(&self) -> bool {
        self.at >= self.buf.len()
    }
}

/// The header's checks: magic, version, length, checksum, joint count. Returns the joint
/// count and the bytes covered by the checksum.
fn checked(blob: &[u8]) -> Result<(usize, &[u8]), BlobError> {
    let head = blob.get(..HEADER_LEN).ok_or(BlobError::Truncated)?;
    if head[..4] != MAGIC {
        return Err(BlobError::NotAModel);
    }
    let version = u16::from_le_bytes([head[4], head[5]]);
    if version != VERSION {
        return Err(BlobError::Version(version));
    }
    let joints = head[6];
    let len = u32::from_le_bytes([head[8], head[9], head[10], head[11]]) as usize;
    if blob.len() < len {
        return Err(BlobError::Truncated);
    }
    if blob.len() > len || len < HEADER_LEN + CRC_LEN {
        return Err(BlobError::NotAModel);
    }
    let (body, crc) = blob.split_at(len - CRC_LEN);
    if crc32(body) != u32::from_le_bytes([crc[0], crc[1], crc[2], crc[3]]) {
        return Err(BlobError::Checksum);
    }
    if head[7] != 0 {
        return Err(BlobError::Malformed);
    }
    let n = joints as usize;
    if n == 0 || n > MAX_JOINTS {
        return Err(BlobError::Joints(joints));
    }
    if body.len() < HEADER_LEN + BASE_LEN + ROW_LEN * n + TOOL_LEN {
        return Err(BlobError::Malformed);
    }
    Ok((n, body))
}

/// The joint count of a binary model, after the checks of its header and checksum (so a
/// firmware can choose the robot type before [`decode`]).
pub fn joint_count(blob: &[u8]) -> Result<usize, BlobError> {
    checked(blob).map(|(n, _)| n)
}

/// Reads the binary model `blob` into `robot`. On any error (truncated, corrupted, another
/// version, another joint count, a record unknown or malformed, a number not finite, more
/// values than the storage `V` holds (`V::CAPACITY`), a model [`Robot::new`] refuses, an
/// effect a robot file refuses: of the wrong shape, given twice, or with an order, start or
/// step its kind does not have) `robot` is unchanged.
///
/// Decoded into `f64`, a model written from `f64` equals it exactly (rows, base, tool,
/// effects, couplings: the forward kinematics agree bit for bit).
pub fn decode<T: Real, const N: usize, V: ValueStorage>(
    blob: &[u8],
    robot: &mut Robot<T, N, V>,
) -> Result<(), BlobError> {
    let (n, body) = checked(blob)?;
    if n != N {
        return Err(BlobError::Joints(n as u8));
    }
    let mut r = Reader {
        buf: body,
        at: HEADER_LEN,
    };
    let mut axes = [Vector3::zeros(); 4];
    for a in axes.iter_mut() {
        *a = r.vec3()?;
    }
    let base = Frame {
        x: axes[0],
        y: axes[1],
        z: axes[2],
        o: axes[3],
    };
    let mut joints = [Joint::mdh(T::zero(), T::zero(), T::zero(), T::zero()); N];
    for j in joints.iter_mut() {
        *j = Joint {
            alpha: r.real()?,
            a: r.real()?,
            theta: r.real()?,
            d: r.real()?,
            beta: r.real()?,
            lower: r.real()?,
            upper: r.real()?,
        };
    }
    let tool = r.vec3()?;
    let mut out = Robot::<T, N, V>::new(base, joints, tool)?;
    while !r.done() {
        let tag = r.u16()?;
        let len = r.u32()? as usize;
        let mut p = Reader {
            buf: r.bytes(len)?,
            at: 0,
        };
        record(&mut out, tag, &mut p)?;
        if !p.done() {
            return Err(BlobError::Malformed);
        }
    }
    *robot = out;
    Ok(())
}

/// Applies one record to the robot being built.
fn record<T: Real, const N: usize, V: ValueStorage>(
    out: &mut Robot<T, N, V>,
    tag: u16,
    p: &mut Reader<'_>,
) -> Result<(), BlobError> {
    match tag {
        tag::TOOL_POINT => {
            let k = p.u8()? as usize;
            if k >= MAX_TOOL_POINTS {
                return Err(BlobError::Capacity);
            }
            if k != out.tool_point_count() {
                return Err(BlobError::Malformed);
            }
            out.set_tool_point(k, p.vec3()?)?;
        }
        tag::TOOL_AXES => {
            let (x, y, z) = (p.vec3()?, p.vec3()?, p.vec3()?);
            if !out.tool_axes_identity() {
                return Err(BlobError::Malformed);
            }
            out.set_tool_axes(Frame {
                x,
                y,
                z,
                o: Vector3::zeros(),
            })?;
        }
        tag::COUPLING => {
            let (joint, from) = (p.u8()? as usize, p.u8()? as usize);
            p.zero()?;
            p.zero()?;
            out.set_coupling(joint, from, p.real()?)?;
        }
        t => {
            if let Some(kind) = effect_kind(t) {
                let joint = p.u8()? as usize;
                p.zero()?;
                let order = p.u16()?;
                let count = p.u32()? as usize;
                let (start, step) = (p.real::<f64>()?, p.real::<f64>()?);
                let expected = count
                    .checked_mul(8)
                    .and_then(|b| b.checked_add(EFFECT_HEAD_LEN));
                if expected != Some(p.buf.len()) {
                    return Err(BlobError::Malformed);
                }
                // What a robot file refuses and the effect list would take: a field the kind
                // does not have, or the same effect again (it would be applied twice).
                if !fields_fit(kind, order, start, step)
                    || out.effects().find(kind, joint, order).is_some()
                {
                    return Err(EffectError::Shape.into());
                }
                let (start, step) = (T::of(start), T::of(step));
                out.effects_mut()
                    .push_with(kind, joint, N, order, start, step, count, |v| {
                        for x in v.iter_mut() {
                            *x = p.real()?;
                        }
                        Ok::<(), BlobError>(())
                    })?;
            } else if t & tag::INFORMATIONAL != 0 {
                p.at = p.buf.len();
            } else {
                return Err(BlobError::UnknownRecord(t));
            }
        }
    }
    Ok(())
}

/// Whether an effect record's order, start and step (as written, before any rounding to the
/// robot's scalar) are those a robot file can give its kind (docs/formats.md, "Binary model"):
/// an order only on `joint-cyclic` (the others hold 0 or 1: 1 from a robot file, 0 from a
/// model built in the library), a start only on `joint-table` (the lowest knot),
/// `thermal-expansion` (T0) and `base-drift` (t0), a step only on `joint-table`.
/// `joint-cyclic`'s order (at least 1) and a table's step (positive) are the effect list's
/// checks.
pub(super) fn fields_fit(kind: EffectKind, order: u16, start: f64, step: f64) -> bool {
    match kind {
        EffectKind::Cyclic => start == 0.0 && step == 0.0,
        EffectKind::Table => order <= 1,
        EffectKind::Thermal | EffectKind::Drift => order <= 1 && step == 0.0,
        EffectKind::Scale | EffectKind::Compliance => order <= 1 && start == 0.0 && step == 0.0,
    }
}
