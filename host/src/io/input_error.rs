//! Why a model or data file was refused, and where.
//!
//! Every refusal of an input file (a robot model of `docs/file-formats.md` §1, a measurement
//! CSV of §2) is an [`InputError`] that names the file, the line and the column
//! of the offending text, so that an editor or a terminal can jump to it:
//!
//! ```text
//! data.csv:14:23: column 'x': "abc" is not a finite number
//! ```
//!
//! Conventions:
//! - lines and columns are 1-based;
//! - a line ends at `\n`, or at a `\r` that no `\n` follows (an old Mac line
//!   end: the CSV reader ends a record there too, and editors show a new line);
//!   the `\r` of `\r\n` is the last character of its line ([`ends_line`]);
//! - the column counts *characters* (Unicode scalar values), not bytes, from the
//!   start of the line, so that it matches what an editor shows for non-ASCII text;
//! - line 0, column 0 means "no place in the text" (the file could not be read at
//!   all); the position is then left out of the message.
//!
//! [`line_col`] turns a byte offset, as the TOML and CSV parsers report them, into
//! such a (line, column) pair. It never panics, whatever the offset.
//!
//! Every input file is read through [`read_bounded`] with the limit of its kind
//! ([`MODEL_FILE`]: 1 MiB, [`DATA_FILE`]: 1 GiB; a calibration's 5 KiB in
//! [`predict`](crate::apply::predict::CALIBRATION_FILE)): at most the limit and one
//! byte is read, and a larger file is refused naming the limit.

use thiserror::Error;

/// A refused input file: the file, the place in it and what is wrong there.
///
/// Displayed as `file:line:column: message` (`file: message` when `line` is 0,
/// i.e. when the file could not be read at all).
#[derive(Clone, Debug, PartialEq, Eq, Error)]
#[error("{}", self.render())]
pub struct InputError {
    /// The file as the user named it (a path, or the label of a built-in file).
    pub file: String,
    /// 1-based line; 0 when the error has no place in the text.
    pub line: usize,
    /// 1-based character column in that line; 0 when the error has no place in the text.
    pub column: usize,
    /// What is wrong and, where it helps, what would be accepted.
    pub message: String,
}

impl InputError {
    /// An error at a known line and column (both 1-based).
    pub fn new(
        file: impl Into<String>,
        line: usize,
        column: usize,
        message: impl Into<String>,
    ) -> Self {
        Self {
            file: file.into(),
            line,
            column,
            message: message.into(),
        }
    }

    /// An error at byte `offset` of `text` (the offset is turned into line and
    /// column by [`line_col`]).
    pub fn at_offset(
        file: impl Into<String>,
        text: &str,
        offset: usize,
        message: impl Into<String>,
    ) -> Self {
        let (line, column) = line_col(text, offset);
        Self::new(file, line, column, message)
    }

    /// A file that could not be read at all (line and column 0), with the reason
    /// the operating system gave.
    pub fn unreadable(file: impl Into<String>, reason: impl core::fmt::Display) -> Self {
        Self::new(file, 0, 0, format!("cannot read the file: {reason}"))
    }

    /// A refused command-line argument: `flag` names it in place of a file.
    pub fn argument(flag: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(flag, 0, 0, message)
    }

    fn render(&self) -> String {
        if self.line == 0 {
            format!("{}: {}", self.file, self.message)
        } else {
            format!(
                "{}:{}:{}: {}",
                self.file, self.line, self.column, self.message
            )
        }
    }
}

/// Whether byte `i` of `bytes` ends a line: a `\n`, or a `\r` that no `\n`
/// follows (see [the module](self)).
pub fn ends_line(bytes: &[u8], i: usize) -> bool {
    match bytes.get(i) {
        Some(b'\n') => true,
        Some(b'\r') => bytes.get(i + 1) != Some(&b'\n'),
        _ => false,
    }
}

/// The 1-based (line, character column) of byte `offset` in `text`.
///
/// Lines end as [`ends_line`] says (a `\r` before a `\n` counts as the last
/// character of its line). An offset past the end is taken as the end of the
/// text, and an offset inside a multi-byte character as the start of that
/// character.
pub fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut offset = offset.min(text.len());
    while offset > 0 && !text.is_char_boundary(offset) {
        offset -= 1;
    }
    let bytes = text.as_bytes();
    let line = (0..offset).filter(|&i| ends_line(bytes, i)).count() + 1;
    let line_start = (0..offset)
        .rev()
        .find(|&i| ends_line(bytes, i))
        .map_or(0, |i| i + 1);
    let column = text.get(line_start..offset).unwrap_or("").chars().count() + 1;
    (line, column)
}

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

    /// Line and column are 1-based, the column counts characters not bytes, and
    /// out-of-range or mid-character offsets do not panic.
    #[test]
    fn line_col_counts_lines_and_characters() {
        let text = "ab\nçd,e\n\nz";
        assert_eq!(line_col(text, 0), (1, 1));
        assert_eq!(line_col(text, 2), (1, 3)); // the '\n' itself
        assert_eq!(line_col(text, 3), (2, 1)); // 'ç'
        assert_eq!(line_col(text, 4), (2, 1)); // inside 'ç': its start
        assert_eq!(line_col(text, 5), (2, 2)); // 'd': 'ç' is one character
        assert_eq!(line_col(text, 7), (2, 4)); // 'e'
        assert_eq!(line_col(text, 9), (3, 1)); // the empty line
        assert_eq!(line_col(text, 10), (4, 1));
        assert_eq!(line_col(text, 1000), (4, 2)); // past the end: the end
        assert_eq!(line_col("", 5), (1, 1));
    }

    /// A `\r` that no `\n` follows ends a line, as the CSV reader ends a record
    /// there; the `\r` of `\r\n` is the last character of its line.
    #[test]
    fn a_lone_carriage_return_ends_a_line() {
        let text = "ab\rcd\r\nef\r\r\ng\r";
        assert_eq!(line_col(text, 2), (1, 3)); // the lone '\r'
        assert_eq!(line_col(text, 3), (2, 1)); // 'c'
        assert_eq!(line_col(text, 5), (2, 3)); // the '\r' of "\r\n"
        assert_eq!(line_col(text, 6), (2, 4)); // its '\n'
        assert_eq!(line_col(text, 7), (3, 1)); // 'e'
        assert_eq!(line_col(text, 10), (4, 1)); // the '\r' of "\r\r\n"
        assert_eq!(line_col(text, 12), (5, 1)); // 'g'
        assert_eq!(line_col(text, 1000), (6, 1)); // after the last lone '\r'
    }

    /// The display is `file:line:column: message`, without the place for line 0.
    #[test]
    fn display_names_file_line_column() {
        let e = InputError::new("data.csv", 14, 23, "column 'x': bad");
        assert_eq!(e.to_string(), "data.csv:14:23: column 'x': bad");
        let e = InputError::unreadable("nope.toml", "No such file");
        assert_eq!(
            e.to_string(),
            "nope.toml: cannot read the file: No such file"
        );
        let e = InputError::at_offset("m.toml", "a\nbc", 3, "here");
        assert_eq!((e.line, e.column), (2, 2));
    }

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
