//! One record of a data file as the reader hands it on ([`Row`]): its fields'
//! text, its line, the joint readings converted, and the line and column of
//! each field for a refusal; and the batches ([`Batch`]) records travel in
//! from the reader's thread to the parser's.

use super::schema::Place;
use crate::session::input_error::InputError;

/// One record: its fields (untrimmed: [`Row::field`] trims), its text as the
/// file has it (for the places of its fields), its line, and its joint
/// readings as the reader converted them ([`super::table::Table::convert`]; `None` in the
/// other columns and where a cell is not a number).
#[derive(Default)]
pub(super) struct Row {
    pub(super) fields: csv::StringRecord,
    pub(super) text: Vec<u8>,
    pub(super) line: usize,
    pub(super) numbers: Vec<Option<f64>>,
}

impl Row {
    /// The number of fields.
    pub(super) fn len(&self) -> usize {
        self.fields.len()
    }

    /// The fields, trimmed.
    pub(super) fn fields(&self) -> impl Iterator<Item = &str> {
        self.fields.iter().map(trim)
    }

    /// Field `i`, trimmed.
    pub(super) fn field(&self, i: usize) -> Option<&str> {
        self.fields.get(i).map(trim)
    }

    /// The line and character column of field `index` (of the end of the
    /// record if it has fewer fields).
    pub(super) fn place(&self, index: usize) -> Place {
        let (starts, end) = self.field_offsets();
        let offset = starts.get(index).copied().unwrap_or(end);
        place_after(self.text.get(..offset).unwrap_or(&self.text), self.line)
    }

    /// The refusal `message` at field `index`, in `file`.
    pub(super) fn err(&self, file: &str, index: usize, message: impl Into<String>) -> InputError {
        let (line, column) = self.place(index);
        InputError::new(file, line, column, message)
    }

    /// The byte offsets in the text where the fields begin (after leading
    /// blanks, as the fields are trimmed), and where the record ends.
    fn field_offsets(&self) -> (Vec<usize>, usize) {
        let byte = |i: usize| self.text.get(i).copied();
        let skip_blanks = |mut i: usize| {
            while matches!(byte(i), Some(b' ' | b'\t')) {
                i += 1;
            }
            i
        };
        let mut starts = Vec::new();
        let mut i = 0;
        loop {
            starts.push(skip_blanks(i));
            // As in csv-core, a quote opens a quoted field only as its first byte.
            let mut in_quotes = byte(i) == Some(b'"');
            if in_quotes {
                i += 1;
            }
            loop {
                match byte(i) {
                    None => return (starts, i),
                    Some(b'"') if in_quotes => {
                        if byte(i + 1) == Some(b'"') {
                            i += 2;
                        } else {
                            in_quotes = false;
                            i += 1;
                        }
                    }
                    Some(b',') if !in_quotes => {
                        i += 1;
                        break;
                    }
                    Some(b'\n' | b'\r') if !in_quotes => return (starts, i),
                    Some(_) => i += 1,
                }
            }
        }
    }
}

/// The line and character column just after `text`, which begins a line,
/// line `line`.
pub(super) fn place_after(text: &[u8], line: usize) -> Place {
    let line_start = memchr::memrchr(b'\n', text).map_or(0, |i| i + 1);
    let column = text[line_start..]
        .iter()
        .filter(|&&b| b & 0xC0 != 0x80)
        .count()
        + 1;
    (line + memchr::memchr_iter(b'\n', text).count(), column)
}

/// `field` without leading and trailing white space ([`str::trim`], which a
/// field that starts and ends in a printable ASCII character does not need).
pub(super) fn trim(field: &str) -> &str {
    match (field.as_bytes().first(), field.as_bytes().last()) {
        (Some(a), Some(b)) if a.is_ascii_graphic() && b.is_ascii_graphic() => field,
        _ => field.trim(),
    }
}

/// Records on their way from the reader to the parser: the first `len` of
/// `rows` (the rest are kept for their buffers).
#[derive(Default)]
pub(super) struct Batch {
    pub(super) rows: Vec<Row>,
    pub(super) len: usize,
}

impl Batch {
    pub(super) fn rows(&self) -> &[Row] {
        self.rows.get(..self.len).unwrap_or(&[])
    }
}
