//! The calibration file: what the calibrator writes and the controller loads.
//!
//! One definition for both sides, so that the host's `--out CAL` bytes and the
//! firmware's loader cannot drift apart. The layout (all integers little-endian):
//!
//! ```text
//! offset  size  field
//!  0       8    magic  89 'A' 'R' 'M' 'C' 'A' 'L' 0A   (high bit and newline catch
//!                                                        7-bit and text-mode transfers)
//!  8       2    format version (FORMAT_VERSION)
//! 10       1    joint count M of the nominal model
//! 11       1    reserved, 0
//! 12       8    model hash: CRC-64/XZ of the nominal model's postcard bytes
//! 20       4    payload length n
//! 24       n    payload: postcard bytes of the Calibration (nominal model, identified
//!               errors, whether orientation was calibrated, the model file's units,
//!               the effects, from version 3 the frame of the targets, from
//!               version 4 the ranges it was identified on, from version 5
//!               its expected held-out error and the geometric fallback, from
//!               version 6 the flange frame)
//! 24+n     4    CRC-32/ISO-HDLC of bytes 0 .. 24+n
//! ```
//!
//! The payload's fields, in order (postcard: each field's bytes after the
//! previous one's; `Option` a tag byte 0/1 and the value):
//!
//! ```text
//! version  field                                   Calibration::
//!  2       nominal model                           nominal
//!  2       identified errors (parameter, error)    errors
//!  2       calibrated from full poses (a bool)     task (Pose: true)
//!  2       the model file's units                  units
//!  2       the non-geometric effects               effects
//!  3       the frame of the targets                targets
//!  4       Option: the ranges identified on        ranges
//!  5       Option: expected held-out error, m      held_out
//!  5       Option: the geometric fallback          geometric
//!            (errors, Option: its held-out error)
//!  6       the flange in the last link's frame     flange
//! ```
//!
//! Version 2 files (without the frame of the targets) are read as targets in the
//! world frame, what they meant. Version 2 and 3 files (without the ranges) are
//! read with the ranges unknown ([`Calibration::ranges`] `None`): nothing can be
//! said of where they extrapolate. Files before version 5 are read with the
//! held-out error unknown and without a geometric fallback
//! ([`Calibration::held_out`], [`Calibration::geometric`] `None`): an export
//! that cannot carry their effects has only the geometry fitted with them.
//! Files before version 6 are read with the flange at the last link's frame
//! (what a model file's `[tool]` is given in, and what they meant).
//!
//! Lengths and angles are SI (m, rad) in `f64`; the controller converts to `f32`
//! after validation. A file is accepted only whole: right magic, a version this
//! build understands, the declared length, the CRC, a payload that decodes with
//! nothing left over, a joint count and model hash that match the decoded model,
//! finite values everywhere and identified parameters that exist in the model.
//! Any other file is refused with a [`CalibrationError`] that says why.

use core::fmt;

use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::compensation::Task;
use crate::effects::{Effect, EffectModel, MAX_EFFECTS};
use crate::ranges::Ranges;
use crate::units::Units;
use crate::{Frame, MAX_JOINTS, Param, Robot};

#[cfg(test)]
pub(crate) mod fixtures;
mod magnitudes;

pub use magnitudes::{
    MAX_COMPLIANCE, MAX_EFFECT_ANGLE, MAX_ERROR_ANGLE, MAX_ERROR_LENGTH, MAX_EXPANSION,
    MAX_REFERENCE_TEMPERATURE, MAX_SCALE_ERROR, MagnitudeError,
};

/// The first eight bytes of every calibration file.
pub const MAGIC: [u8; 8] = *b"\x89ARMCAL\n";

/// The format version this build writes and the newest it reads.
pub const FORMAT_VERSION: u16 = 6;

/// The oldest format version this build reads.
pub const OLDEST_VERSION: u16 = 2;

/// Bytes before the payload.
pub const HEADER_LEN: usize = 24;

/// Bytes of the trailing CRC.
const CRC_LEN: usize = 4;

/// The most identified parameters a calibration holds: the four D-H parameters
/// and Hayati's tilt per joint, six of the base and six of the tool.
pub const MAX_PARAMS: usize = 5 * MAX_JOINTS + 12;

/// The largest calibration file, bytes: the receive buffer a loader needs.
/// The largest possible file (every parameter identified twice, in the
/// calibration and in its geometric fallback, the most effects, every range)
/// is asserted to fit by the `calibration_file` tests.
pub const MAX_FILE_LEN: usize = 5120;

// Bit by bit, without lookup tables: a file is checked once per load, and the
// tables would take 3 KB of the controller's 64 KB of flash.
const CRC32: crc::Crc<u32, crc::NoTable> =
    crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISO_HDLC);
const CRC64: crc::Crc<u64, crc::NoTable> = crc::Crc::<u64, crc::NoTable>::new(&crc::CRC_64_XZ);

/// One identified parameter: its error, identified value minus nominal, SI units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParamError {
    /// Which parameter.
    pub param: Param,
    /// Identified minus nominal, m or rad.
    pub error: f64,
}

/// A calibration: the nominal model it was made for and the identified errors.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Calibration {
    /// The nominal model, in SI units.
    pub nominal: Robot<f64>,
    /// The identified errors; parameters not listed keep their nominal value.
    pub errors: Vec<ParamError, MAX_PARAMS>,
    /// What its corrections reach: [`Task::Pose`] when identified from full
    /// poses (the orientation is calibrated too), [`Task::Position`] from
    /// positions. On the wire the bool "from full poses", `true` for a pose.
    #[serde(with = "task_as_bool")]
    pub task: Task,
    /// The units of the model file, in which results are reported.
    pub units: Units,
    /// The non-geometric effects identified with the geometry (`armcal diagnose`).
    pub effects: Vec<Effect<f64>, MAX_EFFECTS>,
    /// The frame the targets of the compensation are given in.
    pub targets: TargetFrame,
    /// The joint, temperature and payload ranges of the session it was
    /// identified on, SI; `None` when unknown (a file before version 4, or a
    /// calibration not identified from data).
    pub ranges: Option<Ranges<f64>>,
    /// The tool-point error this calibration is expected to make on poses it
    /// was not fitted to, m, from the cross-validation of its session: the RMS
    /// of the 3-D position error, or for a session without a tracker of the
    /// tool point's distance from its fixed point or plane. `None` when
    /// unknown (a file before version 5, or a calibration not identified from
    /// data).
    pub held_out: Option<f64>,
    /// Present only when the calibration has effects: the geometry refitted
    /// without any effect, for a format that cannot carry effects (a URDF, UR
    /// deltas), and its expected held-out error. `None` in a file before
    /// version 5.
    pub geometric: Option<GeometricCalibration>,
    /// The robot's flange (the frame a working tool is given in) in the last
    /// link's frame `M`, nominal: identity for a model file (its `[tool]` is
    /// in frame `M`), the tip link's frame for a URDF, UR's flange for a UR
    /// with its factory calibration. Identity in a file before version 6.
    pub flange: Frame<f64>,
}

/// The best geometry-only calibration of a calibration with effects: the
/// geometric model of its session fitted without any effect (the errors of
/// the effects' geometry fitted together with them would leave what the
/// effects explain to the geometry, and predict worse without them).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GeometricCalibration {
    /// The identified errors, of the same nominal model; parameters not listed
    /// keep their nominal value.
    pub errors: Vec<ParamError, MAX_PARAMS>,
    /// Its expected tool-point error on poses it was not fitted to, m, as
    /// [`Calibration::held_out`]; `None` when unknown.
    pub held_out: Option<f64>,
}

/// The frame the targets (the nominal model's poses) of the compensation are
/// given in ([`crate::compensation`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum TargetFrame {
    /// The world (measurement) frame the calibration was identified in: the
    /// identified base is compensated with the arm.
    #[default]
    World,
    /// The robot's own base frame: the identified base errors (the registration
    /// of the measuring instrument) are not compensated.
    Base,
}

/// The fields every version's payload starts with: a version 2 payload, a
/// [`Calibration`] without [`Calibration::targets`] and the later fields.
/// A calibration's [`Task`] as the payload holds it since version 2: the bool
/// "identified from full poses", `true` for [`Task::Pose`].
mod task_as_bool {
    use serde::{Deserialize, Deserializer, Serializer};

    use crate::compensation::Task;

    /// `true` for [`Task::Pose`].
    pub fn serialize<S: Serializer>(task: &Task, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_bool(*task == Task::Pose)
    }

    /// [`Task::Pose`] for `true`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Task, D::Error> {
        Ok(if bool::deserialize(d)? {
            Task::Pose
        } else {
            Task::Position
        })
    }
}

/// Postcard writes a struct as its fields in order, so a version 3 payload is
/// these and the targets, a version 4 payload these, the targets and the
/// ranges, a version 5 payload these, the targets, the ranges and
/// [`AddedV5`]: one deserialiser of the common fields, and one of each later
/// addition, read every version (and take a third of the flash whole-payload
/// deserialisers would).
#[derive(Deserialize)]
struct PayloadV2 {
    nominal: Robot<f64>,
    errors: Vec<ParamError, MAX_PARAMS>,
    #[serde(with = "task_as_bool")]
    task: Task,
    units: Units,
    effects: Vec<Effect<f64>, MAX_EFFECTS>,
}

/// The fields version 5 added, after the ranges: one deserialiser for both.
#[derive(Deserialize)]
struct AddedV5 {
    held_out: Option<f64>,
    geometric: Option<GeometricCalibration>,
}

/// The payload of `version`, decoded, and the bytes after it; before version
/// 3 with targets in the world frame, before version 4 with the ranges
/// unknown, before version 5 with neither held-out error nor fallback,
/// before version 6 with the flange at the last link's frame.
fn decode_payload(version: u16, payload: &[u8]) -> Result<(Calibration, &[u8]), CalibrationError> {
    let bad = |_| CalibrationError::Payload;
    let (v2, rest) = postcard::take_from_bytes::<PayloadV2>(payload).map_err(bad)?;
    let (targets, rest) = if version >= 3 {
        postcard::take_from_bytes::<TargetFrame>(rest).map_err(bad)?
    } else {
        (TargetFrame::World, rest)
    };
    let (ranges, rest) = if version >= 4 {
        postcard::take_from_bytes::<Option<Ranges<f64>>>(rest).map_err(bad)?
    } else {
        (None, rest)
    };
    let (added5, rest) = if version >= 5 {
        postcard::take_from_bytes::<AddedV5>(rest).map_err(bad)?
    } else {
        (
            AddedV5 {
                held_out: None,
                geometric: None,
            },
            rest,
        )
    };
    let (flange, rest) = if version >= 6 {
        postcard::take_from_bytes::<Frame<f64>>(rest).map_err(bad)?
    } else {
        (Frame::identity(), rest)
    };
    let cal = Calibration {
        nominal: v2.nominal,
        errors: v2.errors,
        task: v2.task,
        units: v2.units,
        effects: v2.effects,
        targets,
        ranges,
        held_out: added5.held_out,
        geometric: added5.geometric,
        flange,
    };
    Ok((cal, rest))
}

/// Why a calibration file was refused, or could not be written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum CalibrationError {
    /// Fewer bytes than the header and CRC, or than the header declares.
    Truncated {
        /// Bytes present.
        len: usize,
        /// Bytes needed.
        needed: usize,
    },
    /// More bytes than the header declares, or than [`MAX_FILE_LEN`].
    TooLong {
        /// Bytes present.
        len: usize,
        /// Bytes expected at most.
        max: usize,
    },
    /// The first bytes are not [`MAGIC`]: not an armcal calibration file.
    BadMagic,
    /// Written by a newer armcal, in a format this build does not know.
    NewerVersion {
        /// The file's version.
        found: u16,
    },
    /// A version this build does not read (0, or an older one).
    BadVersion {
        /// The file's version.
        found: u16,
    },
    /// The CRC does not match: the bytes were damaged.
    Crc {
        /// CRC stored in the file.
        stored: u32,
        /// CRC of the bytes read.
        computed: u32,
    },
    /// The payload does not decode as a calibration.
    Payload,
    /// The header's joint count is not the model's.
    JointCount {
        /// In the header.
        header: u8,
        /// In the model.
        model: usize,
    },
    /// The header's model hash is not the hash of the model in the payload.
    ModelHash {
        /// In the header.
        header: u64,
        /// Of the decoded model.
        computed: u64,
    },
    /// A value of the model or of an identified error is NaN or infinite.
    NonFinite,
    /// An identified parameter names a joint the model does not have.
    UnknownParam {
        /// The parameter.
        param: Param,
    },
    /// An effect acts on a joint the model does not have.
    EffectJoint,
    /// The identified ranges are not one finite interval per joint with
    /// `min ≤ max` (and finite temperature and payload intervals).
    Ranges,
    /// The same parameter is identified twice.
    DuplicateParam {
        /// The parameter.
        param: Param,
    },
    /// An expected held-out error is negative.
    HeldOut,
    /// A link of the model has a negative mass.
    NegativeMass {
        /// The link, from 0.
        link: usize,
    },
    /// The output buffer is too small (writing).
    BufferTooSmall,
}

impl fmt::Display for CalibrationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Truncated { len, needed } => {
                write!(
                    f,
                    "truncated calibration: {len} bytes, {needed} needed; copy the whole file again"
                )
            }
            Self::TooLong { len, max } => {
                write!(
                    f,
                    "calibration of {len} bytes, at most {max} expected: extra bytes after the end"
                )
            }
            Self::BadMagic => f.write_str("not an armcal calibration file (wrong magic bytes)"),
            Self::NewerVersion { found } => write!(
                f,
                "calibration format version {found} is newer than this build reads ({FORMAT_VERSION}): update the reader"
            ),
            Self::BadVersion { found } => write!(
                f,
                "calibration format version {found} is older than this build reads ({OLDEST_VERSION} to {FORMAT_VERSION}): identify again"
            ),
            Self::Crc { stored, computed } => write!(
                f,
                "calibration damaged: CRC {computed:#010x} of the bytes read, {stored:#010x} stored"
            ),
            Self::Payload => f.write_str("calibration damaged: the payload does not decode"),
            Self::JointCount { header, model } => {
                write!(
                    f,
                    "calibration header says {header} joints, its model has {model}"
                )
            }
            Self::ModelHash { header, computed } => write!(
                f,
                "calibration model hash {header:#018x} in the header, {computed:#018x} computed from its model"
            ),
            Self::NonFinite => f.write_str("calibration holds a value that is not a finite number"),
            Self::UnknownParam { param } => {
                write!(
                    f,
                    "calibration identifies {param}, which its model does not have"
                )
            }
            Self::DuplicateParam { param } => write!(f, "calibration identifies {param} twice"),
            Self::HeldOut => f.write_str("calibration's expected held-out error is negative"),
            Self::NegativeMass { link } => write!(
                f,
                "calibration's model gives link {} a negative mass",
                link + 1
            ),
            Self::EffectJoint => {
                f.write_str("calibration has an effect on a joint its model does not have")
            }
            Self::Ranges => {
                f.write_str("calibration's identified ranges are not one finite interval per joint")
            }
            Self::BufferTooSmall => write!(
                f,
                "output buffer too small (at most {MAX_FILE_LEN} bytes needed)"
            ),
        }
    }
}

impl core::error::Error for CalibrationError {}

/// A postcard output that only feeds a CRC-64, to hash a model without a buffer.
struct HashFlavor(crc::Digest<'static, u64, crc::NoTable>);

impl postcard::ser_flavors::Flavor for HashFlavor {
    type Output = u64;

    fn try_push(&mut self, data: u8) -> postcard::Result<()> {
        self.update(&[data]);
        Ok(())
    }

    fn try_extend(&mut self, data: &[u8]) -> postcard::Result<()> {
        self.update(data);
        Ok(())
    }

    fn finalize(self) -> postcard::Result<u64> {
        Ok(self.0.finalize())
    }
}

impl HashFlavor {
    /// One out-of-line update for every call site of the serialiser (the
    /// bit-by-bit CRC inlined at each would take 12 KB of flash).
    #[inline(never)]
    fn update(&mut self, data: &[u8]) {
        self.0.update(data);
    }
}

/// The model hash: CRC-64/XZ of the model's postcard bytes. Two models hash
/// alike only if every parameter, limit and mass is bit-for-bit the same.
pub fn model_hash(model: &Robot<f64>) -> u64 {
    // Serialising into a hash never fails: the flavor accepts every byte.
    postcard::serialize_with_flavor(model, HashFlavor(CRC64.digest())).unwrap_or(0)
}

impl Calibration {
    /// A calibration that identifies nothing: the nominal model itself,
    /// compensating `task`.
    pub fn nominal(nominal: Robot<f64>, task: Task, units: Units) -> Self {
        Self {
            nominal,
            errors: Vec::new(),
            task,
            units,
            effects: Vec::new(),
            targets: TargetFrame::World,
            ranges: None,
            held_out: None,
            geometric: None,
            flange: Frame::identity(),
        }
    }

    /// The geometric fallback as a calibration of its own, without effects:
    /// what a format that cannot carry the effects should hold (its
    /// [`Calibration::held_out`] the fallback's). `None` without a fallback
    /// (no effects, or a file before version 5).
    pub fn geometric_only(&self) -> Option<Calibration> {
        let g = self.geometric.as_ref()?;
        Some(Calibration {
            nominal: self.nominal.clone(),
            errors: g.errors.clone(),
            task: self.task,
            units: self.units,
            effects: Vec::new(),
            targets: self.targets,
            ranges: self.ranges.clone(),
            held_out: g.held_out,
            geometric: None,
            flange: self.flange,
        })
    }

    /// The identified errors the compensation corrects: all of them for
    /// targets in the world frame; without the base's for targets in the
    /// robot's base frame.
    pub fn compensated_errors(&self) -> impl Iterator<Item = &ParamError> {
        let base_frame = self.targets == TargetFrame::Base;
        self.errors
            .iter()
            .filter(move |e| !(base_frame && matches!(e.param, Param::Base(_))))
    }

    /// The calibrated model: the nominal model with every identified error added.
    pub fn calibrated(&self) -> Robot<f64> {
        let mut robot = self.nominal.clone();
        for e in &self.errors {
            if let Some(v) = robot.param_mut(e.param) {
                *v += e.error;
            }
        }
        robot
    }

    /// The calibrated model with its effects, for evaluation in context.
    pub fn model(&self) -> EffectModel<f64> {
        // `validate` (run by `decode` and `encode`) checked every effect's joint;
        // a calibration built in memory and never validated falls back to geometry.
        EffectModel::new(self.calibrated(), &self.effects).unwrap_or_else(|_| EffectModel {
            robot: self.calibrated(),
            effects: Vec::new(),
        })
    }

    /// Writes the calibration file into `buf` and returns the bytes written.
    pub fn encode<'a>(&self, buf: &'a mut [u8]) -> Result<&'a mut [u8], CalibrationError> {
        self.validate()?;
        if buf.len() < HEADER_LEN + CRC_LEN {
            return Err(CalibrationError::BufferTooSmall);
        }
        let (header, rest) = buf.split_at_mut(HEADER_LEN);
        let payload_len = postcard::to_slice(self, rest)
            .map_err(|_| CalibrationError::BufferTooSmall)?
            .len();
        let total = HEADER_LEN + payload_len + CRC_LEN;
        if total > MAX_FILE_LEN {
            return Err(CalibrationError::TooLong {
                len: total,
                max: MAX_FILE_LEN,
            });
        }
        header[0..8].copy_from_slice(&MAGIC);
        header[8..10].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
        header[10] = self.nominal.dof() as u8;
        header[11] = 0;
        header[12..20].copy_from_slice(&model_hash(&self.nominal).to_le_bytes());
        header[20..24].copy_from_slice(&(payload_len as u32).to_le_bytes());
        let body_end = HEADER_LEN + payload_len;
        let crc = CRC32.checksum(&buf[..body_end]);
        let out = buf
            .get_mut(..total)
            .ok_or(CalibrationError::BufferTooSmall)?;
        out[body_end..].copy_from_slice(&crc.to_le_bytes());
        Ok(out)
    }

    /// The calibration file as a byte vector.
    #[cfg(feature = "std")]
    pub fn to_bytes(&self) -> Result<std::vec::Vec<u8>, CalibrationError> {
        let mut buf = std::vec![0u8; MAX_FILE_LEN];
        let len = self.encode(&mut buf)?.len();
        buf.truncate(len);
        Ok(buf)
    }

    /// Reads and fully validates a calibration file.
    pub fn decode(bytes: &[u8]) -> Result<Self, CalibrationError> {
        let min = HEADER_LEN + CRC_LEN;
        if bytes.len() < MAGIC.len() || bytes[..MAGIC.len()] != MAGIC {
            // A short prefix of the magic is a truncated file, anything else is foreign.
            return Err(if bytes.len() < MAGIC.len() && MAGIC.starts_with(bytes) {
                CalibrationError::Truncated {
                    len: bytes.len(),
                    needed: min,
                }
            } else {
                CalibrationError::BadMagic
            });
        }
        if bytes.len() < min {
            return Err(CalibrationError::Truncated {
                len: bytes.len(),
                needed: min,
            });
        }
        let u16_at = |i: usize| u16::from_le_bytes([bytes[i], bytes[i + 1]]);
        let u32_at =
            |i: usize| u32::from_le_bytes([bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]]);
        let version = u16_at(8);
        if version > FORMAT_VERSION {
            return Err(CalibrationError::NewerVersion { found: version });
        }
        if version < OLDEST_VERSION {
            return Err(CalibrationError::BadVersion { found: version });
        }
        let payload_len = u32_at(20) as usize;
        let total = HEADER_LEN
            .saturating_add(payload_len)
            .saturating_add(CRC_LEN);
        if total > MAX_FILE_LEN {
            return Err(CalibrationError::TooLong {
                len: total,
                max: MAX_FILE_LEN,
            });
        }
        if bytes.len() < total {
            return Err(CalibrationError::Truncated {
                len: bytes.len(),
                needed: total,
            });
        }
        if bytes.len() > total {
            return Err(CalibrationError::TooLong {
                len: bytes.len(),
                max: total,
            });
        }
        let body_end = HEADER_LEN + payload_len;
        let stored = u32_at(body_end);
        let computed = CRC32.checksum(&bytes[..body_end]);
        if stored != computed {
            return Err(CalibrationError::Crc { stored, computed });
        }
        let payload = &bytes[HEADER_LEN..body_end];
        let (cal, rest) = decode_payload(version, payload)?;
        if !rest.is_empty() {
            return Err(CalibrationError::Payload);
        }
        let header_joints = bytes[10];
        if usize::from(header_joints) != cal.nominal.dof() {
            return Err(CalibrationError::JointCount {
                header: header_joints,
                model: cal.nominal.dof(),
            });
        }
        let header_hash = u64::from_le_bytes([
            bytes[12], bytes[13], bytes[14], bytes[15], bytes[16], bytes[17], bytes[18], bytes[19],
        ]);
        let computed = model_hash(&cal.nominal);
        if header_hash != computed {
            return Err(CalibrationError::ModelHash {
                header: header_hash,
                computed,
            });
        }
        cal.validate()?;
        Ok(cal)
    }

    /// Finite values everywhere, no negative mass, every identified
    /// parameter exists once (in the errors, and in the geometric
    /// fallback's), the ranges (when known)
    /// have one interval per joint, and the held-out errors are not negative.
    fn validate(&self) -> Result<(), CalibrationError> {
        let model = &self.nominal;
        let finite3 = |v: &nalgebra::Vector3<f64>| v.iter().all(|x| x.is_finite());
        let links_finite = model.links.iter().all(|l| {
            [l.theta, l.s, l.a, l.alpha].iter().all(|x| x.is_finite())
                && l.limits
                    .is_none_or(|[lo, hi]| lo.is_finite() && hi.is_finite())
                && l.mass.is_none_or(|m| m.mass.is_finite() && finite3(&m.com))
        });
        let frames_finite = [&model.base, &model.tool, &self.flange]
            .iter()
            .all(|f| finite3(&f.xyz) && finite3(&f.rpy));
        if !links_finite || !frames_finite || !model.gravity.as_ref().is_none_or(finite3) {
            return Err(CalibrationError::NonFinite);
        }
        if let Some(link) = model
            .links
            .iter()
            .position(|l| l.mass.is_some_and(|m| m.mass < 0.0))
        {
            return Err(CalibrationError::NegativeMass { link });
        }
        for e in &self.effects {
            // The thermal reference temperature is not a parameter: checked apart.
            let finite = (0..e.parameter_count())
                .all(|i| e.parameter(i).is_some_and(f64::is_finite))
                && e.thermal_expansion()
                    .is_none_or(|(_, reference)| reference.is_finite());
            if !finite {
                return Err(CalibrationError::NonFinite);
            }
            if e.joint().is_some_and(|j| j >= model.dof()) {
                return Err(CalibrationError::EffectJoint);
            }
        }
        if self
            .ranges
            .as_ref()
            .is_some_and(|r| !r.is_valid(model.dof()))
        {
            return Err(CalibrationError::Ranges);
        }
        validate_errors(model, &self.errors)?;
        let held_out = [
            self.held_out,
            self.geometric.as_ref().and_then(|g| g.held_out),
        ];
        for h in held_out.into_iter().flatten() {
            if !h.is_finite() {
                return Err(CalibrationError::NonFinite);
            }
            if h < 0.0 {
                return Err(CalibrationError::HeldOut);
            }
        }
        if let Some(g) = &self.geometric {
            validate_errors(model, &g.errors)?;
        }
        Ok(())
    }
}

/// Every error finite, of a parameter `model` has, each parameter once.
fn validate_errors(model: &Robot<f64>, errors: &[ParamError]) -> Result<(), CalibrationError> {
    for (i, e) in errors.iter().enumerate() {
        if !e.error.is_finite() {
            return Err(CalibrationError::NonFinite);
        }
        if model.param(e.param).is_none() {
            return Err(CalibrationError::UnknownParam { param: e.param });
        }
        if errors[..i].iter().any(|o| o.param == e.param) {
            return Err(CalibrationError::DuplicateParam { param: e.param });
        }
    }
    Ok(())
}
