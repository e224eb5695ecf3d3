//! `egm_robot`: the reader of ABB EGM's `EgmRobot` message
//! (`armcal::apply::serve::egm::parse`) and the writer of the answer
//! (`write_sensor`).
//!
//! The input is one datagram as the socket delivers it. Asserts: no panic;
//! and for a message that is read: at most `MAX_DATAGRAM` bytes; the decoded
//! `EgmRobot` encodes and decodes again to the same message (`prost`'s
//! encoding is canonical after one round); the answer written with as many
//! joints as its feedback decodes as an `EgmSensor` with that reference, the
//! sequence number and `MSGTYPE_CORRECTION`.

use armcal::apply::serve::egm::{self, EgmRobot, EgmSensor, MAX_DATAGRAM, MessageType};
use prost::Message;

/// The harness; see [the module](self). Returns whether the message was read.
pub fn run(data: &[u8]) -> bool {
    let Ok(robot) = egm::parse(data) else {
        return false;
    };
    assert!(data.len() <= MAX_DATAGRAM);
    let message = EgmRobot::decode(data).expect("parse read it");
    let again = EgmRobot::decode(&message.encode_to_vec()[..]).expect("its own encoding");
    // NaN payloads compare unequal: compare the encodings.
    assert_eq!(again.encode_to_vec(), message.encode_to_vec());
    let joints: Vec<f64> = (0..robot.joints.unwrap_or(0)).map(|m| m as f64).collect();
    let mut out = Vec::new();
    egm::write_sensor(&mut out, robot.seqno.unwrap_or(0), 4, &joints);
    let sensor = EgmSensor::decode(&out[..]).expect("the answer decodes");
    let header = sensor.header.expect("a header");
    assert_eq!(header.seqno, Some(robot.seqno.unwrap_or(0)));
    assert_eq!(header.mtype, Some(MessageType::Correction as i32));
    let sent = sensor.planned.and_then(|p| p.joints).map(|j| j.joints);
    assert_eq!(sent.unwrap_or_default(), joints);
    true
}
