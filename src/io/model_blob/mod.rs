//! The binary model (`.kcm`, `docs/formats.md#binary-model-kcm`): a whole calibrated robot
//! (rows with tilt and limits, base, tool points and orientation, every joint correction,
//! couplings) in a compact, versioned, checksummed form that firmware loads without a parser.
//!
//! Everything is little-endian; every real is an IEEE `f64` in library units (mm, rad), so a
//! model written from `f64` decodes to the same `f64` bit for bit. The layout:
//!
//! ```text
//! header   magic "KCM1"(4) version u16 joints u8 reserved u8 length u32      12 bytes
//! base     x axis, y axis, z axis, origin (12 f64)                            96 bytes
//! rows     per joint: alpha a theta d beta lower upper (7 f64)             56 bytes each
//! tool     the first measured point (3 f64)                                   24 bytes
//! records  tag u16, payload length u32, payload (until the checksum)
//! crc      CRC-32 (zlib's) of every byte before it                             4 bytes
//! ```
//!
//! Records are tagged so that new kinds of correction can be added without a new version:
//! a decoder refuses a record it does not know ([`BlobError::UnknownRecord`]: applying a model
//! without one of its corrections would be silently wrong), except tags with bit 15 set, which
//! carry information only and are skipped. [`encode`] writes into the caller's buffer,
//! [`decode`] reads into a robot and leaves it unchanged on any error; neither allocates or
//! panics.

mod decode;
mod encode;

pub use decode::{decode, joint_count};
pub use encode::{encode, encoded_len};

use crate::model::coupling::CouplingError;
use crate::model::effects::{EffectError, EffectKind};
use crate::RobotError;

/// The first four bytes of every binary model.
pub const MAGIC: [u8; 4] = *b"KCM1";
/// The layout version this library writes and reads.
pub const VERSION: u16 = 1;
/// Most joints a binary model holds.
pub const MAX_JOINTS: usize = 7;

/// Bytes of the header (magic, version, joints, reserved, length).
pub(crate) const HEADER_LEN: usize = 12;
/// Bytes of the base pose.
pub(crate) const BASE_LEN: usize = 96;
/// Bytes of one joint row.
pub(crate) const ROW_LEN: usize = 56;
/// Bytes of the first tool point.
pub(crate) const TOOL_LEN: usize = 24;
/// Bytes of a record's tag and length.
pub(crate) const RECORD_HEAD_LEN: usize = 6;
/// Bytes of the checksum.
pub(crate) const CRC_LEN: usize = 4;

/// Record tags (`docs/formats.md#binary-model-kcm`).
pub mod tag {
    /// A further tool point: index u8 (1, 2, … in order), x y z (3 f64).
    pub const TOOL_POINT: u16 = 0x0001;
    /// The measured frame's orientation in the flange frame: x, y, z axes (9 f64).
    pub const TOOL_AXES: u16 = 0x0002;
    /// A coupling: joint u8, from u8 (0-based), reserved u16 (0), ratio f64.
    pub const COUPLING: u16 = 0x0003;
    /// `joint-scale` (effect payload).
    pub const JOINT_SCALE: u16 = 0x0010;
    /// `joint-cyclic` (effect payload).
    pub const JOINT_CYCLIC: u16 = 0x0011;
    /// `joint-compliance` (effect payload).
    pub const JOINT_COMPLIANCE: u16 = 0x0012;
    /// `joint-table` (effect payload).
    pub const JOINT_TABLE: u16 = 0x0013;
    /// `thermal-expansion` (effect payload: joint 0, start the reference temperature T0, °C).
    pub const THERMAL_EXPANSION: u16 = 0x0014;
    /// `base-drift` (effect payload: joint 0, start the reference time t0, s; vx, vy, vz mm/s).
    pub const BASE_DRIFT: u16 = 0x0015;
    /// Tags with this bit set carry information only: decoders skip those they do not know.
    pub const INFORMATIONAL: u16 = 0x8000;
}

/// Bytes of an effect payload before its values: joint u8, reserved u8, order u16, count u32,
/// start f64, step f64.
pub(crate) const EFFECT_HEAD_LEN: usize = 24;

/// The record tag of a correction kind.
pub(crate) const fn effect_tag(kind: EffectKind) -> u16 {
    match kind {
        EffectKind::Scale => tag::JOINT_SCALE,
        EffectKind::Cyclic => tag::JOINT_CYCLIC,
        EffectKind::Compliance => tag::JOINT_COMPLIANCE,
        EffectKind::Table => tag::JOINT_TABLE,
        EffectKind::Thermal => tag::THERMAL_EXPANSION,
        EffectKind::Drift => tag::BASE_DRIFT,
    }
}

/// The correction kind of a record tag, `None` for other records.
pub(crate) const fn effect_kind(tag: u16) -> Option<EffectKind> {
    match tag {
        tag::JOINT_SCALE => Some(EffectKind::Scale),
        tag::JOINT_CYCLIC => Some(EffectKind::Cyclic),
        tag::JOINT_COMPLIANCE => Some(EffectKind::Compliance),
        tag::JOINT_TABLE => Some(EffectKind::Table),
        tag::THERMAL_EXPANSION => Some(EffectKind::Thermal),
        tag::BASE_DRIFT => Some(EffectKind::Drift),
        _ => None,
    }
}

/// Why a binary model was not written or not read.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum BlobError {
    /// Encoding: the output buffer holds fewer bytes than the model needs (`needed`).
    BufferTooSmall {
        /// Bytes the model needs.
        needed: usize,
    },
    /// Shorter than a header, or than the length its header gives.
    Truncated,
    /// Not a binary model (the magic is wrong), or longer than its header says.
    NotAModel,
    /// A layout version this library does not read.
    Version(u16),
    /// The CRC-32 does not match the bytes: the blob was corrupted.
    Checksum,
    /// The joint count is 0, above [`MAX_JOINTS`], or not the robot's.
    Joints(u8),
    /// A record's length does not match its content, or a reserved byte is not zero.
    Malformed,
    /// A record this library does not know (and that is not informational).
    UnknownRecord(u16),
    /// A number is NaN or infinite.
    NotFinite,
    /// More effects, effect values, couplings or tool points than the robot has room for.
    Capacity,
    /// The model was refused as [`crate::Robot::new`] and its setters refuse (a base that is
    /// not a rotation, a length beyond 1 km, a coupling chain, an effect of the wrong shape),
    /// or as a robot file refuses its effects: the same effect twice (kind and joint, and
    /// order for `joint-cyclic`), an order on another kind than `joint-cyclic` (0 and 1 are
    /// no order), a start or step on a kind that has none (`EffectError::Shape`, as the
    /// effect list refuses a second `thermal-expansion`).
    Refused(RobotError),
}

impl From<RobotError> for BlobError {
    fn from(e: RobotError) -> Self {
        match e {
            RobotError::BadEffect(EffectError::Capacity)
            | RobotError::BadCoupling(CouplingError::Capacity) => BlobError::Capacity,
            e => BlobError::Refused(e),
        }
    }
}

impl From<EffectError> for BlobError {
    fn from(e: EffectError) -> Self {
        BlobError::from(RobotError::BadEffect(e))
    }
}
