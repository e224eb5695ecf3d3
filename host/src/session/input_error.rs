//! Why an input was refused, and where: [`InputError`], the refusal every
//! layer gives for a file or argument it cannot take.
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
//! Reading the files, within the limit of each kind, is [`crate::io::input_error`]'s.

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

/// A number as a refusal quotes it: as Rust writes it between 10⁻⁴ and 10¹⁵,
/// in scientific notation beyond (`1e300`, not three hundred digits).
pub fn number(v: f64) -> String {
    if v == 0.0 || !v.is_finite() || (1e-4..1e15).contains(&v.abs()) {
        format!("{v}")
    } else {
        format!("{v:e}")
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
}
