//! Writing a robot as a binary model into the caller's buffer.

use super::{
    effect_tag, tag, BlobError, BASE_LEN, CRC_LEN, EFFECT_HEAD_LEN, HEADER_LEN, MAGIC, MAX_JOINTS,
    RECORD_HEAD_LEN, ROW_LEN, TOOL_LEN, VERSION,
};
use crate::io::snapshot::crc32;
use crate::ValueStorage;
use crate::{Real, Robot};
use nalgebra::Vector3;

/// Payload bytes of a further tool point (index, x, y, z).
const TOOL_POINT_LEN: usize = 1 + 24;
/// Payload bytes of the tool orientation (three axes).
const TOOL_AXES_LEN: usize = 72;
/// Payload bytes of a coupling.
const COUPLING_LEN: usize = 12;

/// Bytes [`encode`] writes for `robot`.
pub fn encoded_len<T: Real, const N: usize, V: ValueStorage>(robot: &Robot<T, N, V>) -> usize {
    let mut n = HEADER_LEN + BASE_LEN + ROW_LEN * N + TOOL_LEN + CRC_LEN;
    n += (RECORD_HEAD_LEN + TOOL_POINT_LEN) * robot.tool_point_count().saturating_sub(1);
    if !robot.tool_axes_identity() {
        n += RECORD_HEAD_LEN + TOOL_AXES_LEN;
    }
    n += (RECORD_HEAD_LEN + COUPLING_LEN) * robot.couplings().len();
    for e in robot.effects().iter() {
        n += RECORD_HEAD_LEN + EFFECT_HEAD_LEN + 8 * e.len as usize;
    }
    n
}

/// Little-endian writer over the caller's buffer (sized beforehand: a write past its end is
/// dropped and shows as a short count).
struct Writer<'a> {
    buf: &'a mut [u8],
    at: usize,
}

impl Writer<'_> {
    fn bytes(&mut self, b: &[u8]) {
        if let Some(dst) = self.buf.get_mut(self.at..self.at + b.len()) {
            dst.copy_from_slice(b);
        }
        self.at += b.len();
    }
    fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }
    fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }
    fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    fn real<T: Real>(&mut self, v: T) {
        self.bytes(&v.to_f64().to_le_bytes());
    }
    fn vec3<T: Real>(&mut self, v: &Vector3<T>) {
        for c in v.iter() {
            self.real(*c);
        }
    }
    fn record(&mut self, tag: u16, len: usize) {
        self.u16(tag);
        self.u32(len as u32);
    }
}

/// Writes `robot` as a binary model into `out` and returns the bytes written
/// ([`encoded_len`]). [`BlobError::BufferTooSmall`] when `out` is shorter (nothing useful is
/// written), [`BlobError::Joints`] for more than [`super::MAX_JOINTS`] joints,
/// [`BlobError::Capacity`] when the model does not fit the format's 32-bit length, and an
/// effect of the wrong shape (`EffectError::Shape`) for what the decoder would refuse: an
/// effect given twice, or with an order, start or step its kind does not have.
pub fn encode<T: Real, const N: usize, V: ValueStorage>(
    robot: &Robot<T, N, V>,
    out: &mut [u8],
) -> Result<usize, BlobError> {
    if N == 0 || N > MAX_JOINTS {
        return Err(BlobError::Joints(N.min(255) as u8));
    }
    // What the decoder refuses is not written (a blob that would not load): an effect with an
    // order, start or step its kind does not have, or the same effect twice.
    let effects = robot.effects();
    for (i, e) in effects.iter().enumerate() {
        let fits = super::decode::fields_fit(e.kind, e.order, e.start.to_f64(), e.step.to_f64());
        if !fits || effects.find(e.kind, e.joint as usize, e.order) != Some(i) {
            return Err(crate::model::effects::EffectError::Shape.into());
        }
    }
    let len = encoded_len(robot);
    if len > u32::MAX as usize {
        return Err(BlobError::Capacity);
    }
    if out.len() < len {
        return Err(BlobError::BufferTooSmall { needed: len });
    }
    let mut w = Writer { buf: out, at: 0 };
    w.bytes(&MAGIC);
    w.u16(VERSION);
    w.u8(N as u8);
    w.u8(0);
    w.u32(len as u32);
    let b = robot.base();
    for v in [&b.x, &b.y, &b.z, &b.o] {
        w.vec3(v);
    }
    for j in robot.joints() {
        for v in [j.alpha, j.a, j.theta, j.d, j.beta, j.lower, j.upper] {
            w.real(v);
        }
    }
    w.vec3(robot.tool());
    for k in 1..robot.tool_point_count() {
        if let Some(p) = robot.tool_point(k) {
            w.record(tag::TOOL_POINT, TOOL_POINT_LEN);
            w.u8(k as u8);
            w.vec3(p);
        }
    }
    if !robot.tool_axes_identity() {
        let a = robot.tool_axes();
        w.record(tag::TOOL_AXES, TOOL_AXES_LEN);
        for v in [&a.x, &a.y, &a.z] {
            w.vec3(v);
        }
    }
    for (joint, from, ratio) in robot.couplings().iter() {
        w.record(tag::COUPLING, COUPLING_LEN);
        w.u8(joint as u8);
        w.u8(from as u8);
        w.u16(0);
        w.real(ratio);
    }
    for (i, e) in robot.effects().iter().enumerate() {
        let values = robot.effects().values_of(i);
        w.record(effect_tag(e.kind), EFFECT_HEAD_LEN + 8 * values.len());
        w.u8(e.joint);
        w.u8(0);
        w.u16(e.order);
        w.u32(values.len() as u32);
        w.real(e.start);
        w.real(e.step);
        for v in values {
            w.real(*v);
        }
    }
    let body = w.at;
    let crc = crc32(w.buf.get(..body).unwrap_or(&[]));
    w.u32(crc);
    if w.at == len {
        Ok(len)
    } else {
        // Only if `encoded_len` and the writer disagreed: a bug, reported rather than hidden.
        Err(BlobError::Malformed)
    }
}
