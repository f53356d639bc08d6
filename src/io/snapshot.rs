//! Snapshot and restore of stepper state over `embedded_io`: a small versioned, checksummed
//! container plus little-endian field helpers.
//!
//! A controller runs identification in idle slices and may lose power between them; a snapshot
//! lets the run continue where it stopped and end bit-identical to an uninterrupted one.
//!
//! ## Container (format version 1)
//!
//! | bytes | field                                                                      |
//! |-------|----------------------------------------------------------------------------|
//! | 4     | magic `b"KCSN"`                                                            |
//! | 2     | format version, u16 LE ([`FORMAT_VERSION`])                                |
//! | 2     | kind tag, u16 LE (which stepper: [`Kind`])                                 |
//! | 1     | scalar width in bytes (4 = `f32`, 8 = `f64`)                               |
//! | 3     | reserved, zero                                                             |
//! | 4     | payload length in bytes, u32 LE                                            |
//! | 4     | CRC-32 (IEEE 802.3, as zlib) of the payload, u32 LE                        |
//! | n     | payload: the stepper's fields, written with [`Encoder`]                   |
//!
//! Every header field is checked on restore; the payload must decode to exactly `length`
//! bytes and match the CRC. A payload starts with the shape (const generics) of the stepper,
//! so a snapshot cannot be restored into a stepper of another size.
//!
//! ## Writing and reading a stepper
//!
//! [`save_with`] calls the payload closure twice: once to measure length and CRC (nothing is
//! written), once to write. The closure must therefore write the same bytes both times (it
//! only reads `self`). [`restore_with`] reads the header, lets the closure decode into a
//! *temporary* value, then checks length and CRC; only a fully valid snapshot is handed back,
//! so `restore` can replace `self` in one assignment and never half-loads.
//!
//! Scalars: a real is written as IEEE `f32` bits when `T` is 4 bytes wide and as `f64` bits
//! otherwise, so `f32` state round-trips bit-exactly. Integers are little-endian; `usize` is
//! written as u32 (checked).

use crate::Real;
use embedded_io::{Read, ReadExactError, Write};

/// Magic bytes that open every snapshot.
pub const MAGIC: [u8; 4] = *b"KCSN";
/// Version of the container and of every payload layout in this crate.
pub const FORMAT_VERSION: u16 = 1;
/// Header length in bytes.
pub const HEADER_LEN: usize = 20;

/// Which stepper a snapshot holds (the kind tag).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[repr(u16)]
pub enum Kind {
    /// [`crate::identify::pso::Pso`].
    Pso = 1,
    /// [`crate::identify::bpnn::Bpnn`].
    Bpnn = 2,
    /// [`crate::identify::lm::Levenberg`].
    Levenberg = 3,
}

/// Why a snapshot could not be written or was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum SnapshotError {
    /// The writer or reader failed.
    Io,
    /// The stream ended before the snapshot did.
    UnexpectedEof,
    /// The stream does not start with [`MAGIC`].
    BadMagic,
    /// Written by another format version.
    Version(u16),
    /// Holds another kind of stepper.
    Kind(u16),
    /// Written with another scalar type (`f32` vs `f64`).
    Scalar(u8),
    /// Holds a stepper of another size (const generics differ).
    Shape,
    /// The payload is shorter or longer than the header says, or too long to write.
    Length,
    /// The payload does not match its CRC.
    Checksum,
    /// The payload decodes to a state no stepper can be in.
    Invalid,
}

impl<E> From<ReadExactError<E>> for SnapshotError {
    fn from(e: ReadExactError<E>) -> Self {
        match e {
            ReadExactError::UnexpectedEof => SnapshotError::UnexpectedEof,
            ReadExactError::Other(_) => SnapshotError::Io,
        }
    }
}

/// Saving and restoring a stepper's complete state (including its random generator).
pub trait Snapshot {
    /// Writes a snapshot of the current state.
    fn save<W: Write>(&self, w: &mut W) -> Result<(), SnapshotError>;
    /// Replaces the state with a snapshot. On error `self` is unchanged.
    fn restore<R: Read>(&mut self, r: &mut R) -> Result<(), SnapshotError>;
}

/// Scalar width tag of `T` for the header.
pub fn scalar_width<T: Real>() -> u8 {
    if core::mem::size_of::<T>() == 4 {
        4
    } else {
        8
    }
}

/// Streaming CRC-32 (IEEE 802.3 polynomial, reflected, as zlib and PNG), nibble-table based
/// so it costs 64 bytes of flash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crc32(u32);

const CRC_NIBBLE: [u32; 16] = {
    let mut t = [0u32; 16];
    let mut i = 0;
    while i < 16 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 4 {
            c = if c & 1 != 0 {
                0xEDB8_8320 ^ (c >> 1)
            } else {
                c >> 1
            };
            k += 1;
        }
        t[i] = c;
        i += 1;
    }
    t
};

impl Default for Crc32 {
    fn default() -> Self {
        Self::new()
    }
}

impl Crc32 {
    /// A checksum over no bytes yet.
    pub const fn new() -> Self {
        Crc32(0xFFFF_FFFF)
    }
    /// Feeds bytes.
    pub fn update(&mut self, bytes: &[u8]) {
        let mut c = self.0;
        for &b in bytes {
            c ^= b as u32;
            c = CRC_NIBBLE[(c & 0xF) as usize] ^ (c >> 4);
            c = CRC_NIBBLE[(c & 0xF) as usize] ^ (c >> 4);
        }
        self.0 = c;
    }
    /// The checksum of everything fed so far.
    pub fn value(&self) -> u32 {
        !self.0
    }
}

/// CRC-32 of a byte slice (`crc32(b"123456789") == 0xCBF4_3926`).
pub fn crc32(bytes: &[u8]) -> u32 {
    let mut c = Crc32::new();
    c.update(bytes);
    c.value()
}

/// Writes payload fields little-endian; during the measuring pass of [`save_with`] it only
/// counts bytes and updates the CRC.
#[derive(Debug)]
pub struct Encoder<'a, W: Write> {
    sink: Option<&'a mut W>,
    crc: Crc32,
    len: u64,
}

impl<W: Write> Encoder<'_, W> {
    /// Raw bytes.
    pub fn bytes(&mut self, b: &[u8]) -> Result<(), SnapshotError> {
        self.crc.update(b);
        self.len += b.len() as u64;
        if let Some(w) = self.sink.as_mut() {
            w.write_all(b).map_err(|_| SnapshotError::Io)?;
        }
        Ok(())
    }
    /// One byte.
    pub fn u8(&mut self, v: u8) -> Result<(), SnapshotError> {
        self.bytes(&[v])
    }
    /// A bool as one byte, 0 or 1.
    pub fn bool(&mut self, v: bool) -> Result<(), SnapshotError> {
        self.u8(v as u8)
    }
    /// A u16, little-endian.
    pub fn u16(&mut self, v: u16) -> Result<(), SnapshotError> {
        self.bytes(&v.to_le_bytes())
    }
    /// A u32, little-endian.
    pub fn u32(&mut self, v: u32) -> Result<(), SnapshotError> {
        self.bytes(&v.to_le_bytes())
    }
    /// A u64, little-endian.
    pub fn u64(&mut self, v: u64) -> Result<(), SnapshotError> {
        self.bytes(&v.to_le_bytes())
    }
    /// A `usize` as u32 (fails with [`SnapshotError::Length`] above `u32::MAX`).
    pub fn usize(&mut self, v: usize) -> Result<(), SnapshotError> {
        self.u32(u32::try_from(v).map_err(|_| SnapshotError::Length)?)
    }
    /// A real: `f32` bits when `T` is 4 bytes wide, `f64` bits otherwise.
    pub fn real<T: Real>(&mut self, v: T) -> Result<(), SnapshotError> {
        if scalar_width::<T>() == 4 {
            self.bytes(&(v.to_f64() as f32).to_bits().to_le_bytes())
        } else {
            self.bytes(&v.to_f64().to_bits().to_le_bytes())
        }
    }
    /// A slice of reals (no length prefix: the shape is part of the payload's layout).
    pub fn reals<T: Real>(&mut self, v: &[T]) -> Result<(), SnapshotError> {
        v.iter().try_for_each(|x| self.real(*x))
    }
    /// Rows of reals (`[[T; D]]`, e.g. a swarm or a matrix), row after row.
    pub fn real_rows<T: Real, const D: usize>(
        &mut self,
        v: &[[T; D]],
    ) -> Result<(), SnapshotError> {
        v.iter().try_for_each(|row| self.reals(row))
    }
    /// A `Xoshiro256PlusPlus` generator's state (32 bytes).
    pub fn rng(&mut self, rng: &rand_xoshiro::Xoshiro256PlusPlus) -> Result<(), SnapshotError> {
        self.bytes(&rng.state())
    }
}

/// Reads payload fields little-endian, bounded by the payload length and feeding the CRC.
#[derive(Debug)]
pub struct Decoder<'a, R: Read> {
    src: &'a mut R,
    crc: Crc32,
    left: u32,
}

impl<R: Read> Decoder<'_, R> {
    /// Fills `b` from the payload.
    pub fn bytes(&mut self, b: &mut [u8]) -> Result<(), SnapshotError> {
        let n = u32::try_from(b.len()).map_err(|_| SnapshotError::Length)?;
        if n > self.left {
            return Err(SnapshotError::Length);
        }
        self.src.read_exact(b)?;
        self.left -= n;
        self.crc.update(b);
        Ok(())
    }
    fn array<const K: usize>(&mut self) -> Result<[u8; K], SnapshotError> {
        let mut b = [0u8; K];
        self.bytes(&mut b)?;
        Ok(b)
    }
    /// One byte.
    pub fn u8(&mut self) -> Result<u8, SnapshotError> {
        Ok(self.array::<1>()?[0])
    }
    /// A bool; bytes other than 0 and 1 are [`SnapshotError::Invalid`].
    pub fn bool(&mut self) -> Result<bool, SnapshotError> {
        match self.u8()? {
            0 => Ok(false),
            1 => Ok(true),
            _ => Err(SnapshotError::Invalid),
        }
    }
    /// A little-endian u16.
    pub fn u16(&mut self) -> Result<u16, SnapshotError> {
        Ok(u16::from_le_bytes(self.array()?))
    }
    /// A little-endian u32.
    pub fn u32(&mut self) -> Result<u32, SnapshotError> {
        Ok(u32::from_le_bytes(self.array()?))
    }
    /// A little-endian u64.
    pub fn u64(&mut self) -> Result<u64, SnapshotError> {
        Ok(u64::from_le_bytes(self.array()?))
    }
    /// A `usize` written by [`Encoder::usize`].
    pub fn usize(&mut self) -> Result<usize, SnapshotError> {
        usize::try_from(self.u32()?).map_err(|_| SnapshotError::Invalid)
    }
    /// Reads a u32 and checks it equals `expected` (shape fields); otherwise [`SnapshotError::Shape`].
    pub fn expect_shape(&mut self, expected: usize) -> Result<(), SnapshotError> {
        let v = self.u32()?;
        if usize::try_from(v).ok() == Some(expected) {
            Ok(())
        } else {
            Err(SnapshotError::Shape)
        }
    }
    /// A real written by [`Encoder::real`] (NaN and infinities pass; validate afterwards).
    pub fn real<T: Real>(&mut self) -> Result<T, SnapshotError> {
        if scalar_width::<T>() == 4 {
            Ok(T::of(
                f32::from_bits(u32::from_le_bytes(self.array()?)) as f64
            ))
        } else {
            Ok(T::of(f64::from_bits(u64::from_le_bytes(self.array()?))))
        }
    }
    /// A finite real; anything else is [`SnapshotError::Invalid`].
    pub fn finite<T: Real>(&mut self) -> Result<T, SnapshotError> {
        let v: T = self.real()?;
        if v.finite() {
            Ok(v)
        } else {
            Err(SnapshotError::Invalid)
        }
    }
    /// Fills `out` with reals written by [`Encoder::reals`] (not checked for finiteness).
    pub fn reals<T: Real>(&mut self, out: &mut [T]) -> Result<(), SnapshotError> {
        out.iter_mut().try_for_each(|x| {
            *x = self.real()?;
            Ok(())
        })
    }
    /// Fills `out` row after row, as [`Encoder::real_rows`] wrote them.
    pub fn real_rows<T: Real, const D: usize>(
        &mut self,
        out: &mut [[T; D]],
    ) -> Result<(), SnapshotError> {
        out.iter_mut().try_for_each(|row| self.reals(row))
    }
    /// A generator state written by [`Encoder::rng`]; the all-zero state (unreachable from
    /// any seed, and remapped by `from_seed`) is [`SnapshotError::Invalid`].
    pub fn rng(&mut self) -> Result<rand_xoshiro::Xoshiro256PlusPlus, SnapshotError> {
        use rand_core::SeedableRng;
        let s: [u8; 32] = self.array()?;
        if s.iter().all(|b| *b == 0) {
            return Err(SnapshotError::Invalid);
        }
        Ok(rand_xoshiro::Xoshiro256PlusPlus::from_seed(s))
    }
    /// Payload bytes not yet read.
    pub fn remaining(&self) -> u32 {
        self.left
    }
}

/// Writes a complete snapshot: header, then the payload produced by `payload`.
///
/// `payload` is called twice (measure, then write) and must produce the same bytes both times.
pub fn save_with<T: Real, W: Write, F>(
    w: &mut W,
    kind: Kind,
    mut payload: F,
) -> Result<(), SnapshotError>
where
    F: FnMut(&mut Encoder<'_, W>) -> Result<(), SnapshotError>,
{
    let mut measure: Encoder<'_, W> = Encoder {
        sink: None,
        crc: Crc32::new(),
        len: 0,
    };
    payload(&mut measure)?;
    let len = u32::try_from(measure.len).map_err(|_| SnapshotError::Length)?;
    let crc = measure.crc.value();
    let mut header = [0u8; HEADER_LEN];
    header[0..4].copy_from_slice(&MAGIC);
    header[4..6].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
    header[6..8].copy_from_slice(&(kind as u16).to_le_bytes());
    header[8] = scalar_width::<T>();
    header[12..16].copy_from_slice(&len.to_le_bytes());
    header[16..20].copy_from_slice(&crc.to_le_bytes());
    w.write_all(&header).map_err(|_| SnapshotError::Io)?;
    let mut enc = Encoder {
        sink: Some(w),
        crc: Crc32::new(),
        len: 0,
    };
    payload(&mut enc)?;
    if enc.len != len as u64 || enc.crc.value() != crc {
        // The closure is not deterministic: the snapshot just written is unusable.
        return Err(SnapshotError::Invalid);
    }
    enc.sink
        .map_or(Ok(()), |w| w.flush().map_err(|_| SnapshotError::Io))
}

/// Reads and checks a snapshot of `kind` for scalar `T`, decoding the payload with `payload`
/// into a value of the caller's choice (a temporary copy of the stepper). The value is returned
/// only when the payload was consumed exactly and its CRC matched. When `payload` refuses the
/// state ([`SnapshotError::Invalid`]) the rest of the payload is read: a CRC mismatch then
/// reports [`SnapshotError::Checksum`] (corruption), a match [`SnapshotError::Invalid`].
pub fn restore_with<T: Real, R: Read, X, F>(
    r: &mut R,
    kind: Kind,
    payload: F,
) -> Result<X, SnapshotError>
where
    F: FnOnce(&mut Decoder<'_, R>) -> Result<X, SnapshotError>,
{
    let mut header = [0u8; HEADER_LEN];
    r.read_exact(&mut header)?;
    if header[0..4] != MAGIC {
        return Err(SnapshotError::BadMagic);
    }
    let version = u16::from_le_bytes([header[4], header[5]]);
    if version != FORMAT_VERSION {
        return Err(SnapshotError::Version(version));
    }
    let k = u16::from_le_bytes([header[6], header[7]]);
    if k != kind as u16 {
        return Err(SnapshotError::Kind(k));
    }
    if header[8] != scalar_width::<T>() {
        return Err(SnapshotError::Scalar(header[8]));
    }
    if header[9..12] != [0, 0, 0] {
        return Err(SnapshotError::Invalid);
    }
    let len = u32::from_le_bytes([header[12], header[13], header[14], header[15]]);
    let crc = u32::from_le_bytes([header[16], header[17], header[18], header[19]]);
    let mut dec = Decoder {
        src: r,
        crc: Crc32::new(),
        left: len,
    };
    let value = match payload(&mut dec) {
        Err(SnapshotError::Invalid) => return Err(refused(&mut dec, crc)),
        v => v?,
    };
    if dec.left != 0 {
        return Err(SnapshotError::Length);
    }
    if dec.crc.value() != crc {
        return Err(SnapshotError::Checksum);
    }
    Ok(value)
}

/// The error of a payload the closure refused ([`SnapshotError::Invalid`]): a state no stepper
/// can be in. The rest of the payload is read: from a corrupted payload (a checksum error) when
/// it does not match the CRC `crc`, else a CRC-valid but invalid snapshot.
fn refused<R: Read>(dec: &mut Decoder<'_, R>, crc: u32) -> SnapshotError {
    let mut b = [0u8; 16];
    while dec.left > 0 {
        let n = (dec.left as usize).min(b.len());
        if let Err(e) = dec.bytes(&mut b[..n]) {
            return e;
        }
    }
    if dec.crc.value() != crc {
        SnapshotError::Checksum
    } else {
        SnapshotError::Invalid
    }
}
