//! The streaming reader of a data file ([`CsvReader`]): one record ([`Row`])
//! at a time from a [`Source`], with its text and line, the header read into a
//! [`Table`] and every data line handed on in file order.
//!
//! Two threads share the work: this one splits the records (the `csv`
//! crate), counts the lines, converts the joint readings
//! ([`Table::convert`]) and lets the text read go; the other reads the rest
//! of each record ([`Table::record`], [`Table::distance_line`]) and gives it
//! to the sink. The split balances the two on a tracker's file (10⁶ rows:
//! 0.44 s, 0.72 s on one thread). Records go over in batches of [`BATCH`],
//! at most [`IN_FLIGHT`] batches ahead, so memory stays independent of the
//! file's length. The refusal given is the first in file order: a row's,
//! else the reader's where it stopped.

use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

use super::row::{Batch, Row, place_after};
use super::schema::{Columns, Item, Role, Schema, ignored_warning};
use super::source::{Source, Stop};
use super::table::Table;
use crate::io::input_error::{DATA_FILE, SizeLimit};
use crate::session::input_error::InputError;

/// Records a batch holds.
const BATCH: usize = 512;
/// Batches read ahead of the one being parsed.
const IN_FLIGHT: usize = 2;

/// Reads the records of a data file one at a time and says where each is.
pub(super) struct CsvReader<'f, R> {
    reader: csv::Reader<Source<R>>,
    file: &'f str,
    /// Line counting cursor: `line` is the 1-based line of byte `byte`.
    byte: usize,
    line: usize,
}

impl<'f, R: std::io::Read> CsvReader<'f, R> {
    pub(super) fn new(source: Source<R>, file: &'f str) -> Self {
        Self {
            reader: csv::ReaderBuilder::new()
                .has_headers(false)
                .comment(Some(b'#'))
                .flexible(true)
                .from_reader(source),
            file,
            byte: 0,
            line: 1,
        }
    }

    fn source(&self) -> &Source<R> {
        self.reader.get_ref()
    }

    /// The refusal `message` at byte `offset` of the text.
    fn err_at(&self, offset: usize, message: impl Into<String>) -> InputError {
        let source = self.source();
        let mut offset = offset.clamp(self.byte, source.end());
        // Not inside a character.
        while offset > self.byte && source.byte(offset).is_some_and(|b| b & 0xC0 == 0x80) {
            offset -= 1;
        }
        let (line, column) = place_after(source.text(self.byte, offset), self.line);
        InputError::new(self.file, line, column, message)
    }

    /// The 1-based line of byte `offset`; offsets come in increasing order, so
    /// the file is scanned once. Every line ends in `\n` by now: a lone CR
    /// became one ([`Source`]), the CR of a CR LF is the line's last character.
    fn line_of(&mut self, offset: usize) -> usize {
        let offset = offset.min(self.source().end());
        if offset > self.byte {
            self.line += memchr::memchr_iter(b'\n', self.source().text(self.byte, offset)).count();
            self.byte = offset;
        }
        self.line
    }

    /// Where a record really starts: the `csv` crate reports the place it began
    /// reading, before the comment and blank lines it skipped.
    fn record_start(&self, mut i: usize) -> usize {
        let source = self.source();
        loop {
            match source.byte(i) {
                Some(b'#') => {
                    while let Some(b) = source.byte(i) {
                        i += 1;
                        if b == b'\n' {
                            break;
                        }
                    }
                }
                Some(b'\n' | b'\r') => i += 1,
                _ => return i,
            }
        }
    }

    /// Reads the next record that is not a blank-looking line into `row`;
    /// `false` at the end of the file.
    fn next_row(&mut self, row: &mut Row) -> Result<bool, InputError> {
        loop {
            let read = self.reader.read_record(&mut row.fields);
            // The text may end early where the reader stopped: the record
            // read is cut there unless its line ended just before the stop
            // (then the record is whole, and the stop is the next line's).
            let at = self.reader.position().byte() as usize;
            let line_ended =
                matches!(read, Ok(true)) && self.source().byte(at.wrapping_sub(1)) == Some(b'\n');
            if let Some((offset, why)) = self.source().stop.clone()
                && (offset < at || (offset == at && !line_ended))
            {
                return Err(match why {
                    Stop::TooLarge => SizeLimit {
                        bytes: self.source().limit,
                        what: DATA_FILE.what,
                    }
                    .refusal(self.file),
                    Stop::NotUtf8 => {
                        self.err_at(offset, "the file is not UTF-8 text (invalid byte here)")
                    }
                    Stop::Unreadable(reason) => InputError::unreadable(self.file, reason),
                });
            }
            match read {
                Ok(false) => return Ok(false),
                Ok(true) => {
                    let begun = row.fields.position().map_or(0, |p| p.byte() as usize);
                    let start = self.record_start(begun);
                    row.line = self.line_of(start);
                    row.text.clear();
                    row.text.extend_from_slice(self.source().text(start, at));
                    self.reader.get_mut().forget_before(start);
                    if row.len() == 1 && row.field(0).is_some_and(str::is_empty) {
                        continue; // a line of blanks only
                    }
                    return Ok(true);
                }
                Err(e) => {
                    let offset = e.position().map_or(0, |p| p.byte() as usize);
                    return Err(self.err_at(offset, format!("CSV: {e}")));
                }
            }
        }
    }

    /// Reads the header and every data row, giving each row to `sink` in
    /// file order (on the parser's thread).
    pub(super) fn read(
        mut self,
        schema: &Schema<'_>,
        sink: impl FnMut(Item) + Send,
    ) -> Result<Columns, InputError> {
        let mut header = Row::default();
        if !self.next_row(&mut header)? {
            return Err(InputError::new(
                self.file,
                1,
                1,
                format!(
                    "no header line: the file is empty or has only comments (expected {}, ...)",
                    schema.kind.required(schema.dof())
                ),
            ));
        }
        let table = Table::new(self.file, header, schema)?;
        let (rows, tally) = std::thread::scope(|scope| {
            let (to_parser, batches) = sync_channel(IN_FLIGHT);
            let (to_reader, parsed) = sync_channel(IN_FLIGHT + 2);
            let parser = scope.spawn(|| table.parse(batches, to_reader, sink));
            let read = self.send_rows(&table, to_parser, parsed);
            let parsed = parser
                .join()
                .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
            // A row's refusal comes before where the reader stopped.
            let parsed = parsed?;
            read.map(|()| parsed)
        })?;
        let header = &table.header;
        if rows == 0 {
            return Err(InputError::new(
                self.file,
                header.line,
                1,
                format!(
                    "no data rows after the header: at least one {} is needed",
                    schema.kind.row_noun()
                ),
            ));
        }

        let mut used = Vec::new();
        let mut ignored = Vec::new();
        for (name, role) in header.fields().zip(&table.roles) {
            if *role == Role::Ignored {
                ignored.push(name.to_owned());
            } else {
                used.push(name.to_owned());
            }
        }
        let mut warnings = Vec::new();
        warnings.extend(ignored_warning(self.file, header.line, &ignored, schema));
        warnings.extend(tally.warnings(self.file, schema));

        Ok(Columns {
            header: (header.line, header.fields().map(str::to_owned).collect()),
            used,
            ignored,
            warnings,
        })
    }

    /// Reads every record after the header, its numbers converted, and sends
    /// them to the parser in batches, reusing the batches it sends back.
    /// Stops at the end of the file, at a refusal (the records before it sent
    /// first) or when the parser stopped at one of its own.
    fn send_rows(
        &mut self,
        table: &Table<'_>,
        to_parser: SyncSender<Batch>,
        parsed: Receiver<Batch>,
    ) -> Result<(), InputError> {
        loop {
            let mut batch = parsed.try_recv().unwrap_or_default();
            batch.len = 0;
            let mut read = Ok(true);
            while batch.len < BATCH {
                if batch.rows.len() == batch.len {
                    batch.rows.push(Row::default());
                }
                let row = &mut batch.rows[batch.len];
                read = self.next_row(row);
                if !matches!(read, Ok(true)) {
                    break;
                }
                table.convert(row);
                batch.len += 1;
            }
            if to_parser.send(batch).is_err() {
                return Ok(()); // the parser refused a row
            }
            if !matches!(read, Ok(true)) {
                return read.map(|_| ());
            }
        }
    }
}

/// Reads the file `source` (`file` in messages) as a file of `schema.kind`,
/// giving each data row to `sink` as it is read.
pub(super) fn read_table<R: std::io::Read>(
    source: Source<R>,
    file: &str,
    schema: &Schema<'_>,
    sink: impl FnMut(Item) + Send,
) -> Result<Columns, InputError> {
    CsvReader::new(source, file).read(schema, sink)
}
