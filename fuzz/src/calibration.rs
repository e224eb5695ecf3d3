//! `calibration_decode`: the calibration file reader, `Calibration::decode`.
//!
//! The input's first byte chooses the mode: bit 0 clear, the rest of the input
//! is the file as it is (the header checks: magic, version, lengths, CRC);
//! bit 0 set, the harness first writes the payload length (bytes 20..24) and
//! the CRC-32 (the last 4 bytes) that fit the rest, so that the fuzzer reaches
//! the payload, the joint count and model hash checks and the validation
//! behind the CRC.
//!
//! Asserts, for every input: no panic; and for a file that decodes:
//! - it encodes again (`Calibration::encode` into `MAX_FILE_LEN` bytes) and
//!   the encoding decodes to an equal calibration (a version 2 file comes back
//!   as version 3, the targets in the world frame);
//! - the encoding is canonical: encoding the decoded encoding gives the same
//!   bytes;
//! - if the controller's check (`check_magnitudes`) accepts it, the f32
//!   compensator builds and corrects a command at the zero pose and at a
//!   non-trivial pose without panicking, with finite commands unless it
//!   reports `NonFinite`.

use armcal_shared::calibration::{HEADER_LEN, MAX_FILE_LEN};
use armcal_shared::compensation::{Compensator, Conditions, Fault, Limits};
use armcal_shared::link::check_magnitudes;
use armcal_shared::{Calibration, MAX_JOINTS};

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// The harness; see [the module](self). Returns whether the file decoded
/// and passed the controller's check (for the tests of the seeds).
pub fn run(data: &[u8]) -> bool {
    let Some((&mode, file)) = data.split_first() else {
        return false;
    };
    let mut file = file.to_vec();
    if mode & 1 == 1 && file.len() >= HEADER_LEN + 4 {
        let body_end = file.len() - 4;
        let payload_len = (body_end - HEADER_LEN) as u32;
        file[20..24].copy_from_slice(&payload_len.to_le_bytes());
        let crc = CRC32.checksum(&file[..body_end]);
        file[body_end..].copy_from_slice(&crc.to_le_bytes());
    }
    let Ok(cal) = Calibration::decode(&file) else {
        return false;
    };
    let mut buf = vec![0u8; MAX_FILE_LEN];
    let encoded = match cal.encode(&mut buf) {
        Ok(bytes) => bytes.to_vec(),
        Err(e) => panic!("a decoded calibration does not encode: {e}"),
    };
    let again = Calibration::decode(&encoded).expect("its encoding decodes");
    assert_eq!(again, cal, "encode -> decode changed the calibration");
    let mut buf2 = vec![0u8; MAX_FILE_LEN];
    assert_eq!(
        again.encode(&mut buf2).expect("encodes"),
        &encoded[..],
        "the encoding is not canonical"
    );
    if check_magnitudes(&cal).is_err() {
        return false;
    }
    let compensator = Compensator::<f32>::from_calibration(&cal, Limits::default());
    let n = cal.nominal.dof();
    assert!(n <= MAX_JOINTS);
    assert_eq!(compensator.dof(), n);
    let conditions = Conditions {
        temperature: Some(35.0),
        payload: Some(2.0),
    };
    let zero = vec![0.0f32; n];
    let pose: Vec<f32> = (0..n).map(|j| 0.3 - 0.17 * j as f32).collect();
    for q in [&zero, &pose] {
        let c = compensator.correct(q, &conditions);
        assert_eq!(c.q.len(), n);
        if c.fault != Some(Fault::NonFinite) {
            assert!(
                c.q.iter().all(|x| x.is_finite()),
                "non-finite commands without a NonFinite fault: {c:?}"
            );
        }
    }
    true
}
