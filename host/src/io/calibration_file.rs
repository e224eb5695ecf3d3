//! Calibration files in: the bytes of a calibration file, read within its
//! limit ([`CALIBRATION_FILE`], [`MAX_FILE_LEN`] = 5 KiB), and the
//! [`Calibration`] they decode to (the binary format of
//! `docs/file-formats.md` §5, decoded and checked by `armcal_shared`). A file
//! that cannot be read, is too large or is refused by the decoder is an
//! [`InputError`] at line 0 naming the file. Writing one is
//! [`Calibration::to_bytes`]'s, through [`crate::io::output`].

use armcal_shared::Calibration;
use armcal_shared::calibration::MAX_FILE_LEN;

use crate::io::input_error::{SizeLimit, read_bounded};
use crate::session::input_error::InputError;

/// The bytes of the calibration file at `path`, not decoded.
///
/// A calibration has at most [`MAX_FILE_LEN`] (5 KiB) bytes: at most that and
/// one byte more is read, and a larger file is refused naming the limit (so a
/// large CSV or `/dev/zero` given by mistake is refused at once). A file that
/// cannot be read is an [`InputError`] at line 0 naming the file.
pub fn read_calibration(path: &str) -> Result<Vec<u8>, InputError> {
    read_bounded(path, CALIBRATION_FILE)
}

/// The size limit of a calibration file: [`MAX_FILE_LEN`] bytes.
pub const CALIBRATION_FILE: SizeLimit = SizeLimit {
    bytes: MAX_FILE_LEN as u64,
    what: "a calibration file",
};

/// Reads ([`read_calibration`]) and fully validates the calibration file at `path`.
///
/// A file that cannot be read, that is larger than a calibration can be, or that
/// [`Calibration::decode`] refuses, is an [`InputError`] at line 0 naming the
/// file and the reason (`cal.bin: calibration damaged: CRC ...`).
pub fn load_calibration(path: &str) -> Result<Calibration, InputError> {
    let bytes = read_calibration(path)?;
    Calibration::decode(&bytes).map_err(|e| InputError::new(path, 0, 0, e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::model_file::load_model;
    use armcal_shared::compensation::Task;

    /// A calibration file that cannot be used is refused at line 0, with the
    /// reason of the decoder; a good one reads back.
    #[test]
    fn load_calibration_names_the_file_and_the_reason() {
        let model = load_model("puma560").unwrap();
        let cal = Calibration::nominal(model.robot, Task::Pose, model.units);
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("cal.bin");
        let p = path.to_str().unwrap();
        let bytes = cal.to_bytes().unwrap();
        std::fs::write(&path, &bytes).unwrap();
        assert_eq!(load_calibration(p).unwrap(), cal);
        std::fs::write(&path, &bytes[..bytes.len() - 1]).unwrap();
        let e = load_calibration(p).unwrap_err();
        assert_eq!((e.file.as_str(), e.line), (p, 0));
        assert!(e.to_string().starts_with(&format!("{p}: truncated")), "{e}");
        let e = load_calibration("/nonexistent/cal.bin").unwrap_err();
        assert!(e.message.contains("cannot read"), "{e}");
    }
}
