//! ABB EGM (Externally Guided Motion) over UDP: the controller's
//! `EgmRobot` message read, the sensor's `EgmSensor` answer written, as
//! protocol buffers (proto2).
//!
//! Source of the format: `egm.proto`, "ABB sensor interface V1.1", package
//! `abb.egm`, as ROS-Industrial's `abb_libegm` ships it (`proto/egm.proto`).
//! The messages below are written by hand from it with `prost`'s derive:
//! every field of `EgmRobot` and `EgmSensor` with its tag, scalar type and
//! label, so that a field of the wrong wire type anywhere in the message
//! refuses it (`prost` skips only unknown tags). Repeated scalars are
//! proto2's unpacked encoding (`prost` reads the packed one too).
//!
//! Every cycle (4 ms by default) the controller sends an `EgmRobot`
//! (`header`: `seqno`, `tm` in ms, `mtype` `MSGTYPE_DATA`; `feedBack` and
//! `planned` joints in degrees; motor, EGM and RAPID states); armcal answers
//! with an `EgmSensor` whose `header` has its own `seqno` (from 0), `tm`
//! (ms since it started) and `mtype` `MSGTYPE_CORRECTION`, and whose
//! `planned.joints` is the joint reference: the joint file's next row,
//! corrected, degrees (robot axes, in order; every joint revolute).
//!
//! Safety of the reader: a datagram is at most [`MAX_DATAGRAM`] bytes;
//! `prost` decodes within it, nested at most 100 deep.

use prost::Message;

/// The largest datagram read: 4 KiB (an `EgmRobot` with every field is
/// under 400 bytes).
pub const MAX_DATAGRAM: usize = 4096;

/// `EgmHeader.MessageType`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, prost::Enumeration)]
#[repr(i32)]
pub enum MessageType {
    /// `MSGTYPE_UNDEFINED`.
    Undefined = 0,
    /// `MSGTYPE_COMMAND` (for future use).
    Command = 1,
    /// `MSGTYPE_DATA`: sent by the robot controller.
    Data = 2,
    /// `MSGTYPE_CORRECTION`: sent by the sensor for position guidance.
    Correction = 3,
    /// `MSGTYPE_PATH_CORRECTION`: sent by the sensor for path correction.
    PathCorrection = 4,
}

/// `EgmHeader`.
#[derive(Clone, PartialEq, Message)]
pub struct EgmHeader {
    /// Sequence number (to find lost messages).
    #[prost(uint32, optional, tag = "1")]
    pub seqno: Option<u32>,
    /// Send time stamp, ms.
    #[prost(uint32, optional, tag = "2")]
    pub tm: Option<u32>,
    /// The message's type.
    #[prost(enumeration = "MessageType", optional, tag = "3")]
    pub mtype: Option<i32>,
}

/// `EgmCartesian` (a position, mm) and `EgmEuler` (an orientation,
/// degrees): the same layout.
#[derive(Clone, PartialEq, Message)]
pub struct EgmXyz {
    /// x.
    #[prost(double, required, tag = "1")]
    pub x: f64,
    /// y.
    #[prost(double, required, tag = "2")]
    pub y: f64,
    /// z.
    #[prost(double, required, tag = "3")]
    pub z: f64,
}

/// `EgmQuaternion`.
#[derive(Clone, PartialEq, Message)]
pub struct EgmQuaternion {
    /// u0.
    #[prost(double, required, tag = "1")]
    pub u0: f64,
    /// u1.
    #[prost(double, required, tag = "2")]
    pub u1: f64,
    /// u2.
    #[prost(double, required, tag = "3")]
    pub u2: f64,
    /// u3.
    #[prost(double, required, tag = "4")]
    pub u3: f64,
}

/// `EgmClock`: since 1 Jan 1970.
#[derive(Clone, PartialEq, Message)]
pub struct EgmClock {
    /// Seconds.
    #[prost(uint64, required, tag = "1")]
    pub sec: u64,
    /// Microseconds.
    #[prost(uint64, required, tag = "2")]
    pub usec: u64,
}

/// `EgmPose`.
#[derive(Clone, PartialEq, Message)]
pub struct EgmPose {
    /// Position.
    #[prost(message, optional, tag = "1")]
    pub pos: Option<EgmXyz>,
    /// Orientation as a quaternion.
    #[prost(message, optional, tag = "2")]
    pub orient: Option<EgmQuaternion>,
    /// Orientation as Euler angles.
    #[prost(message, optional, tag = "3")]
    pub euler: Option<EgmXyz>,
}

/// `EgmJoints` (also `EgmExternalJoints`, the same layout): degrees.
#[derive(Clone, PartialEq, Message)]
pub struct EgmJoints {
    /// The joint values.
    #[prost(double, repeated, packed = "false", tag = "1")]
    pub joints: Vec<f64>,
}

/// `EgmPlanned` (and `EgmFeedBack`, the same layout).
#[derive(Clone, PartialEq, Message)]
pub struct EgmPlanned {
    /// Robot joints, degrees.
    #[prost(message, optional, tag = "1")]
    pub joints: Option<EgmJoints>,
    /// Cartesian pose.
    #[prost(message, optional, tag = "2")]
    pub cartesian: Option<EgmPose>,
    /// External axes.
    #[prost(message, optional, tag = "3")]
    pub external_joints: Option<EgmJoints>,
    /// Time.
    #[prost(message, optional, tag = "4")]
    pub time: Option<EgmClock>,
}

/// `EgmSpeedRef`.
#[derive(Clone, PartialEq, Message)]
pub struct EgmSpeedRef {
    /// Joint speeds.
    #[prost(message, optional, tag = "1")]
    pub joints: Option<EgmJoints>,
    /// Cartesian speeds.
    #[prost(message, optional, tag = "2")]
    pub cartesians: Option<EgmValues>,
    /// External axes' speeds.
    #[prost(message, optional, tag = "3")]
    pub external_joints: Option<EgmJoints>,
}

/// `EgmMotorState`, `EgmMCIState`, `EgmRapidCtrlExecState`: one enumerated
/// `state` (read as its number).
#[derive(Clone, PartialEq, Message)]
pub struct EgmState {
    /// The state's number.
    #[prost(int32, required, tag = "1")]
    pub state: i32,
}

/// `EgmTestSignals`, `EgmMeasuredForce` and `EgmCartesianSpeed` (mm/s or
/// degrees/s): repeated doubles.
#[derive(Clone, PartialEq, Message)]
pub struct EgmValues {
    /// The values.
    #[prost(double, repeated, packed = "false", tag = "1")]
    pub values: Vec<f64>,
}

/// `EgmRobot`: the controller's message.
#[derive(Clone, PartialEq, Message)]
pub struct EgmRobot {
    /// Header.
    #[prost(message, optional, tag = "1")]
    pub header: Option<EgmHeader>,
    /// Measured position (`feedBack`).
    #[prost(message, optional, tag = "2")]
    pub feed_back: Option<EgmPlanned>,
    /// Planned position.
    #[prost(message, optional, tag = "3")]
    pub planned: Option<EgmPlanned>,
    /// Motor state.
    #[prost(message, optional, tag = "4")]
    pub motor_state: Option<EgmState>,
    /// EGM state.
    #[prost(message, optional, tag = "5")]
    pub mci_state: Option<EgmState>,
    /// Whether the EGM's convergence criteria are met.
    #[prost(bool, optional, tag = "6")]
    pub mci_convergence_met: Option<bool>,
    /// Test signals.
    #[prost(message, optional, tag = "7")]
    pub test_signals: Option<EgmValues>,
    /// RAPID execution state.
    #[prost(message, optional, tag = "8")]
    pub rapid_exec_state: Option<EgmState>,
    /// Measured force.
    #[prost(message, optional, tag = "9")]
    pub measured_force: Option<EgmValues>,
    /// Utilization rate.
    #[prost(double, optional, tag = "10")]
    pub utilization_rate: Option<f64>,
}

/// `EgmSensor`: the sensor's answer.
#[derive(Clone, PartialEq, Message)]
pub struct EgmSensor {
    /// Header.
    #[prost(message, optional, tag = "1")]
    pub header: Option<EgmHeader>,
    /// The reference.
    #[prost(message, optional, tag = "2")]
    pub planned: Option<EgmPlanned>,
    /// Speed reference.
    #[prost(message, optional, tag = "3")]
    pub speed_ref: Option<EgmSpeedRef>,
}

/// What armcal reads of one `EgmRobot`.
#[derive(Clone, Debug, PartialEq)]
pub struct Robot {
    /// The header's sequence number, when sent.
    pub seqno: Option<u32>,
    /// The robot joints of the feedback (else the planned), when sent.
    pub joints: Option<usize>,
}

/// Why a datagram is not an `EgmRobot` armcal reads.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RobotError {
    /// Larger than [`MAX_DATAGRAM`].
    #[error("a datagram of more than {MAX_DATAGRAM} bytes")]
    Oversized,
    /// Not an `EgmRobot` (a field of the wrong type, a truncated message).
    #[error("not an EgmRobot: {0}")]
    Decode(String),
}

/// Reads an `EgmRobot` datagram.
pub fn parse(datagram: &[u8]) -> Result<Robot, RobotError> {
    if datagram.len() > MAX_DATAGRAM {
        return Err(RobotError::Oversized);
    }
    let robot = EgmRobot::decode(datagram).map_err(|e| RobotError::Decode(e.to_string()))?;
    let joints = |p: &Option<EgmPlanned>| {
        p.as_ref()
            .and_then(|p| p.joints.as_ref())
            .map(|j| j.joints.len())
    };
    Ok(Robot {
        seqno: robot.header.as_ref().and_then(|h| h.seqno),
        joints: joints(&robot.feed_back).or(joints(&robot.planned)),
    })
}

/// The `EgmSensor` answer with sequence number `seqno`, time `tm` (ms) and
/// the joint reference `joints` (degrees), encoded into `out` (cleared).
pub fn write_sensor(out: &mut Vec<u8>, seqno: u32, tm: u32, joints: &[f64]) {
    out.clear();
    let sensor = EgmSensor {
        header: Some(EgmHeader {
            seqno: Some(seqno),
            tm: Some(tm),
            mtype: Some(MessageType::Correction as i32),
        }),
        planned: Some(EgmPlanned {
            joints: Some(EgmJoints {
                joints: joints.to_vec(),
            }),
            ..EgmPlanned::default()
        }),
        speed_ref: None,
    };
    // Encoding into a Vec cannot run out of room.
    let _ = sensor.encode(out);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A message as the controller sends it, encoded from the same
    /// definitions.
    fn robot(seqno: u32) -> EgmRobot {
        let joints = |v: &[f64]| EgmJoints { joints: v.to_vec() };
        EgmRobot {
            header: Some(EgmHeader {
                seqno: Some(seqno),
                tm: Some(4 * seqno),
                mtype: Some(MessageType::Data as i32),
            }),
            feed_back: Some(EgmPlanned {
                joints: Some(joints(&[0.0, -30.0, 30.0, 0.0, 90.0, 0.0])),
                ..EgmPlanned::default()
            }),
            planned: Some(EgmPlanned {
                joints: Some(joints(&[0.0, -30.0, 30.0, 0.0, 90.0, 0.0])),
                ..EgmPlanned::default()
            }),
            motor_state: Some(EgmState { state: 1 }),
            mci_state: Some(EgmState { state: 3 }),
            mci_convergence_met: Some(true),
            rapid_exec_state: Some(EgmState { state: 2 }),
            utilization_rate: Some(12.5),
            ..EgmRobot::default()
        }
    }

    /// The controller's message is read; the answer decodes as an
    /// EgmSensor with the header and reference written.
    #[test]
    fn reads_the_robot_and_writes_the_sensor() {
        let bytes = robot(7).encode_to_vec();
        assert_eq!(
            parse(&bytes).unwrap(),
            Robot {
                seqno: Some(7),
                joints: Some(6)
            }
        );
        let mut out = Vec::new();
        write_sensor(&mut out, 3, 12, &[1.0, 2.0, 3.0, 4.0, 5.0, 6.5]);
        let back = EgmSensor::decode(&out[..]).unwrap();
        let header = back.header.unwrap();
        assert_eq!((header.seqno, header.tm), (Some(3), Some(12)));
        assert_eq!(header.mtype, Some(MessageType::Correction as i32));
        assert_eq!(
            back.planned.unwrap().joints.unwrap().joints,
            vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.5]
        );
        // proto2's unpacked repeated doubles: tag 1, wire type 1 (64-bit),
        // once per value.
        let joints = EgmJoints {
            joints: vec![1.0, 2.0],
        }
        .encode_to_vec();
        assert_eq!(joints.len(), 18);
        assert_eq!((joints[0], joints[9]), (0x09, 0x09));
    }

    /// A field of the wrong wire type (the header as a number, a joint as a
    /// string, the motor state as a double) and a truncated message are
    /// refused; unknown fields are skipped, as proto2 asks.
    #[test]
    fn refuses_wrong_field_types() {
        let good = robot(1).encode_to_vec();
        // Field 1 (header) as a varint: tag byte (1 << 3) | 0.
        let mut header_as_number = vec![0x08, 0x05];
        header_as_number.extend(&good);
        // Field 2 (feedBack) holding field 1 (joints) holding field 1 as
        // length-delimited text.
        let joint_as_text = vec![0x12, 0x07, 0x0a, 0x05, 0x0a, 0x03, b'a', b'b', b'c'];
        // Field 4 (motorState) as a 64-bit double: (4 << 3) | 1.
        let mut motor_as_double = vec![0x21];
        motor_as_double.extend(1.0f64.to_le_bytes());
        for bad in [
            header_as_number,
            joint_as_text,
            motor_as_double,
            good[..good.len() - 3].to_vec(),
        ] {
            assert!(matches!(parse(&bad), Err(RobotError::Decode(_))), "{bad:?}");
        }
        // Field 99, a varint: unknown, skipped.
        let mut unknown = good.clone();
        unknown.extend([0x98, 0x06, 0x01]);
        assert_eq!(parse(&unknown).unwrap().seqno, Some(1));
        assert_eq!(
            parse(&vec![0; MAX_DATAGRAM + 1]),
            Err(RobotError::Oversized)
        );
    }
}
