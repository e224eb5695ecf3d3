//! Reading an input file within the limit of its kind, and the refusal it
//! gives ([`InputError`], defined in [`crate::session::input_error`] with
//! [`line_col`](crate::session::input_error::line_col) and
//! [`ends_line`](crate::session::input_error::ends_line)).
//!
//! Every input file is read through [`read_bounded`] with the limit of its kind
//! ([`MODEL_FILE`]: 1 MiB, [`DATA_FILE`]: 1 GiB; a calibration's 5 KiB in
//! [`calibration_file`](crate::io::calibration_file::CALIBRATION_FILE)): at most the limit and one
//! byte is read, and a larger file is refused naming the limit.

use crate::session::input_error::InputError;

/// How much of one kind of input file armcal reads: files larger than `bytes`
/// are refused (status 2) without being read whole.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SizeLimit {
    /// The largest file accepted, in bytes.
    pub bytes: u64,
    /// What the file is, for the message (`"a robot model file"`).
    pub what: &'static str,
}

/// A robot model (TOML, `docs/file-formats.md` §1) has at most 1 MiB; the models of
/// `models/` have about 2 KiB.
pub const MODEL_FILE: SizeLimit = SizeLimit {
    bytes: 1 << 20,
    what: "a robot model file",
};

/// A data file (measurements or joint readings, CSV, `docs/file-formats.md` §2) has at most
/// 1 GiB: some ten million rows, an hour of 1 kHz servo commands three times
/// over. The whole file is held in memory while it is parsed.
pub const DATA_FILE: SizeLimit = SizeLimit {
    bytes: 1 << 30,
    what: "a data file",
};

impl SizeLimit {
    /// The refusal of `file`, larger than this limit.
    pub fn refusal(&self, file: &str) -> InputError {
        InputError::new(
            file,
            0,
            0,
            format!(
                "the file is larger than {}, the most {} may have",
                human_size(self.bytes),
                self.what
            ),
        )
    }
}

/// `n` bytes in the largest binary unit that divides it (`4096 bytes`, `1 MiB`).
pub fn human_size(n: u64) -> String {
    for (shift, unit) in [(30, "GiB"), (20, "MiB"), (10, "KiB")] {
        if n >= 1 << shift && n.is_multiple_of(1 << shift) {
            return format!("{} {unit}", n >> shift);
        }
    }
    format!("{n} bytes")
}

/// Reads at most `limit.bytes` of the file at `path`, refusing a larger one.
///
/// A regular file whose size already says it is too large is refused before a
/// byte is read; anything else (a device, a FIFO, a file that grows) is read
/// through [`Read::take`](std::io::Read::take) of one byte more than the limit,
/// so that `/dev/zero` ends at the limit too.
pub fn read_bounded(path: &str, limit: SizeLimit) -> Result<Vec<u8>, InputError> {
    use std::io::Read as _;
    let file = open_bounded(path, limit)?;
    let mut bytes = Vec::new();
    if let Ok(meta) = file.metadata()
        && meta.is_file()
    {
        bytes.reserve(usize::try_from(meta.len()).unwrap_or(0));
    }
    file.take(limit.bytes.saturating_add(1))
        .read_to_end(&mut bytes)
        .map_err(|e| InputError::unreadable(path, e))?;
    if bytes.len() as u64 > limit.bytes {
        return Err(limit.refusal(path));
    }
    Ok(bytes)
}

/// Opens the file at `path` to be read up to `limit`: a regular file whose
/// size already says it is larger is refused before a byte is read (a reader
/// of anything else stops at the limit itself, as [`read_bounded`] does).
pub fn open_bounded(path: &str, limit: SizeLimit) -> Result<std::fs::File, InputError> {
    let file = std::fs::File::open(path).map_err(|e| InputError::unreadable(path, e))?;
    if let Ok(meta) = file.metadata()
        && meta.is_file()
        && meta.len() > limit.bytes
    {
        return Err(limit.refusal(path));
    }
    Ok(file)
}

/// Reads a whole input file as UTF-8 text, at most `limit` of it
/// ([`MODEL_FILE`], [`DATA_FILE`]; a larger file is refused, see [`read_bounded`]).
///
/// A file that cannot be read is an error at line 0 naming the OS reason; a file
/// that is not UTF-8 is an error at the first invalid byte. A leading UTF-8
/// byte-order mark (as spreadsheet programs write) is dropped.
pub fn read_text(path: &str, limit: SizeLimit) -> Result<String, InputError> {
    let bytes = read_bounded(path, limit)?;
    match String::from_utf8(bytes) {
        Ok(mut text) => {
            if text.starts_with('\u{feff}') {
                text.drain(..'\u{feff}'.len_utf8());
            }
            Ok(text)
        }
        Err(e) => {
            let valid = e.utf8_error().valid_up_to();
            let bytes = e.into_bytes();
            let prefix = String::from_utf8_lossy(bytes.get(..valid).unwrap_or(&[]));
            Err(InputError::at_offset(
                path,
                &prefix,
                valid,
                "the file is not UTF-8 text (invalid byte here)",
            ))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A missing file names the file; a non-UTF-8 file names the line and column
    /// of the first bad byte; a byte-order mark is dropped.
    #[test]
    fn read_text_refuses_unreadable_and_non_utf8() {
        let e = read_text("/nonexistent/armcal/x.toml", MODEL_FILE).unwrap_err();
        assert_eq!(e.file, "/nonexistent/armcal/x.toml");
        assert_eq!((e.line, e.column), (0, 0));
        assert!(
            e.to_string()
                .starts_with("/nonexistent/armcal/x.toml: cannot read")
        );

        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("bad.csv");
        std::fs::write(&path, b"q1,x\n1,\xff\n").unwrap();
        let p = path.to_str().unwrap();
        let e = read_text(p, DATA_FILE).unwrap_err();
        assert_eq!((e.line, e.column), (2, 3), "{e}");
        assert!(e.message.contains("UTF-8"));

        std::fs::write(&path, "\u{feff}q1,x\n").unwrap();
        assert_eq!(read_text(p, DATA_FILE).unwrap(), "q1,x\n");
    }

    /// A file larger than its limit is refused naming the limit, whether its
    /// size is known (a regular file) or not (`/dev/zero`, read only up to the
    /// limit and one byte); a file of exactly the limit is read.
    #[test]
    fn read_bounded_refuses_past_the_limit() {
        let limit = SizeLimit {
            bytes: 4096,
            what: "a test file",
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.csv");
        let p = path.to_str().unwrap();
        std::fs::write(&path, vec![b'a'; 4096]).unwrap();
        assert_eq!(read_bounded(p, limit).unwrap().len(), 4096);
        std::fs::write(&path, vec![b'a'; 4097]).unwrap();
        let e = read_bounded(p, limit).unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("{p}: the file is larger than 4 KiB, the most a test file may have")
        );
        let e = read_text("/dev/zero", MODEL_FILE).unwrap_err();
        assert!(e.to_string().contains("larger than 1 MiB"), "{e}");
        assert_eq!(human_size(1 << 30), "1 GiB");
        assert_eq!(human_size(4097), "4097 bytes");
    }
}
