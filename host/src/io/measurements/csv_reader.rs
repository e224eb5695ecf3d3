//! The streaming reader of a data file ([`CsvReader`]): one record ([`Row`])
//! at a time from a [`Source`], the line and character column of each field,
//! the header checked against the [`Schema`] and every data line handed on as
//! it is read (rows by [`record`](super::record), distance lines here).

use super::schema::{
    Columns, Item, Kind, LimitTally, Place, QUAT, Role, Schema, case_hint, ignored_warning,
    joint_index, role_of, torque_index,
};
use super::source::{Source, Stop};
use crate::io::input_error::{DATA_FILE, InputError, SizeLimit};
use crate::session::constraints::{DEFAULT_DISTANCE_STD, DistanceLine};
use crate::session::measurements::POSITION;

/// Reads the records of a data file one at a time and says where each is.
pub(super) struct CsvReader<'f, R> {
    reader: csv::Reader<Source<R>>,
    file: &'f str,
    /// Line counting cursor: `line` is the 1-based line of byte `byte`.
    byte: usize,
    line: usize,
}

/// One record: its fields (untrimmed: [`Row::field`] trims), where it starts
/// and its line.
#[derive(Default)]
pub(super) struct Row {
    pub(super) fields: csv::StringRecord,
    pub(super) start: usize,
    pub(super) line: usize,
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
}

/// `field` without leading and trailing white space ([`str::trim`], which a
/// field that starts and ends in a printable ASCII character does not need).
pub(super) fn trim(field: &str) -> &str {
    match (field.as_bytes().first(), field.as_bytes().last()) {
        (Some(a), Some(b)) if a.is_ascii_graphic() && b.is_ascii_graphic() => field,
        _ => field.trim(),
    }
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

    /// The place of field `index` of the record at `start`.
    pub(super) fn place(&self, start: usize, index: usize) -> Place {
        self.place_at(self.field_offset(start, index))
    }

    /// The refusal `message` at byte `offset` ([`Self::place_at`]).
    pub(super) fn err_at(&self, offset: usize, message: impl Into<String>) -> InputError {
        let (line, column) = self.place_at(offset);
        InputError::new(self.file, line, column, message)
    }

    /// The line and character column of byte `offset`.
    fn place_at(&self, offset: usize) -> Place {
        let source = self.source();
        let mut offset = offset.clamp(self.byte, source.end());
        // Not inside a character.
        while offset > self.byte && source.byte(offset).is_some_and(|b| b & 0xC0 == 0x80) {
            offset -= 1;
        }
        let before = source.text(self.byte, offset);
        let line_start = memchr::memrchr(b'\n', before).map_or(0, |i| i + 1);
        let column = before[line_start..]
            .iter()
            .filter(|&&b| b & 0xC0 != 0x80)
            .count()
            + 1;
        let line = self.line + memchr::memchr_iter(b'\n', before).count();
        (line, column)
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

    /// The byte offsets where the fields of the record at `start` begin (after
    /// leading blanks, as the fields are trimmed), and where the record ends.
    fn field_offsets(&self, start: usize) -> (Vec<usize>, usize) {
        let source = self.source();
        let skip_blanks = |mut i: usize| {
            while matches!(source.byte(i), Some(b' ' | b'\t')) {
                i += 1;
            }
            i
        };
        let mut starts = Vec::new();
        let mut i = start;
        loop {
            starts.push(skip_blanks(i));
            // As in csv-core, a quote opens a quoted field only as its first byte.
            let mut in_quotes = source.byte(i) == Some(b'"');
            if in_quotes {
                i += 1;
            }
            loop {
                match source.byte(i) {
                    None => return (starts, i),
                    Some(b'"') if in_quotes => {
                        if source.byte(i + 1) == Some(b'"') {
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

    /// The byte offset of field `index` of the record at `start` (the end of the
    /// record if it has fewer fields).
    pub(super) fn field_offset(&self, start: usize, index: usize) -> usize {
        let (starts, end) = self.field_offsets(start);
        starts.get(index).copied().unwrap_or(end)
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
                    row.start = self.record_start(begun);
                    row.line = self.line_of(row.start);
                    self.reader.get_mut().forget_before(row.start);
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

    /// Reads the header and every data row, giving each row to `sink`.
    pub(super) fn read(
        mut self,
        schema: &Schema<'_>,
        mut sink: impl FnMut(Item),
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
        let columns = self.header(&header, schema)?;

        let mut tally = LimitTally::new(schema);
        let mut row = Row::default();
        let mut rows = 0;
        // Only a file with a `point` column has distance lines (an old file's
        // rows read as before).
        let constraint_file = header.fields().any(|n| n == "point" || n == "plane");
        while self.next_row(&mut row)? {
            if constraint_file && row.field(0) == Some("distance") {
                sink(Item::Distance(self.distance_line(&row, schema)?));
                continue;
            }
            let record = self.record(&row, &header, &columns, schema)?;
            tally.add(&record);
            sink(Item::Row(record));
            rows += 1;
        }
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
        for (name, role) in header.fields().zip(&columns) {
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

    /// Checks the header against the schema; the role of each column.
    fn header(&self, header: &Row, schema: &Schema<'_>) -> Result<Vec<Role>, InputError> {
        let m = schema.dof();
        let at = |index: usize, message: String| {
            self.err_at(self.field_offset(header.start, index), message)
        };
        let names: Vec<&str> = header.fields().collect();

        for (i, name) in names.iter().enumerate() {
            if name.is_empty() {
                continue;
            }
            if let Some(first) = names.iter().take(i).position(|n| n == name) {
                return Err(at(
                    i,
                    format!(
                        "column '{name}': duplicate column name (field {} of the header is '{name}' too)",
                        first + 1
                    ),
                ));
            }
        }

        let roles: Vec<Role> = names.iter().map(|n| role_of(n, schema.kind)).collect();
        let joint_numbers: Vec<(usize, usize)> = names
            .iter()
            .enumerate()
            .filter_map(|(i, n)| joint_index(n).map(|k| (i, k)))
            .collect();
        let data_joints = joint_numbers.iter().map(|(_, k)| *k).max().unwrap_or(0);
        for &(i, k) in &joint_numbers {
            if k == 0 {
                return Err(at(
                    i,
                    "column 'q0': joints are numbered from 1 (q1..qM)".to_owned(),
                ));
            }
            if k > m {
                return Err(at(
                    i,
                    format!(
                        "column '{}': joint-count mismatch: the model has {m} joints, the data has {data_joints} (q1..q{m} expected)",
                        names.get(i).unwrap_or(&"")
                    ),
                ));
            }
        }
        let header_err = |message: String| InputError::new(self.file, header.line, 1, message);
        if let [only] = names.as_slice()
            && let Some((delimiter, called)) = [(';', "semicolons"), ('\t', "tabs")]
                .into_iter()
                .find(|(c, _)| only.contains(*c))
        {
            return Err(header_err(format!(
                "the header is one field with {called} in it ({:?}): armcal reads comma-separated values; save the file with commas",
                only.split(delimiter)
                    .take(3)
                    .collect::<Vec<_>>()
                    .join(&delimiter.to_string())
            )));
        }
        for j in 0..m {
            if !roles.contains(&Role::Joint(j)) {
                return Err(header_err(format!(
                    "missing column 'q{}': joint-count mismatch: the model has {m} joints, the data has {}{}",
                    j + 1,
                    joint_numbers.len(),
                    case_hint(&names, &format!("q{}", j + 1))
                )));
            }
        }
        // A constraint file (a `point` column) may leave out x, y, z altogether.
        let constraint_file = roles.contains(&Role::Point) || roles.contains(&Role::Plane);
        let any_position = (0..3).any(|c| roles.contains(&Role::Position(c)));
        for (c, name) in POSITION.iter().enumerate() {
            if schema.kind == Kind::Measurements
                && (!constraint_file || any_position)
                && !roles.contains(&Role::Position(c))
            {
                return Err(header_err(format!(
                    "missing required column '{name}' (required: {}){}",
                    schema.kind.required(m),
                    case_hint(&names, name)
                )));
            }
        }
        if schema.kind == Kind::Measurements {
            for (i, name) in names.iter().enumerate() {
                if let Some(k) = torque_index(name).filter(|&k| k == 0 || k > m) {
                    return Err(at(
                        i,
                        format!(
                            "column '{name}': {} (tau1..tau{m}: one torque per joint of the model)",
                            if k == 0 {
                                "joints are numbered from 1".to_owned()
                            } else {
                                format!("the model has {m} joints")
                            }
                        ),
                    ));
                }
            }
            let missing: Vec<String> = (0..m)
                .filter(|j| !roles.contains(&Role::Torque(*j)))
                .map(|j| format!("tau{}", j + 1))
                .collect();
            if !missing.is_empty() && missing.len() < m {
                return Err(header_err(format!(
                    "missing column '{}': a measured torque for every joint (tau1..tau{m}) or none",
                    missing[0]
                )));
            }
        }
        let present: Vec<usize> = (0..4).filter(|c| roles.contains(&Role::Quat(*c))).collect();
        if !present.is_empty() && present.len() < 4 {
            let first = roles
                .iter()
                .position(|r| matches!(r, Role::Quat(_)))
                .unwrap_or(0);
            let have: Vec<&str> = present
                .iter()
                .filter_map(|c| QUAT.get(*c).copied())
                .collect();
            let missing: Vec<&str> = (0..4)
                .filter(|c| !present.contains(c))
                .filter_map(|c| QUAT.get(c).copied())
                .collect();
            return Err(at(
                first,
                format!(
                    "column '{}': partial quaternion: {} given, {} missing; give all four of qw, qx, qy, qz or none",
                    names.get(first).unwrap_or(&""),
                    have.join(", "),
                    missing.join(", ")
                ),
            ));
        }
        Ok(roles)
    }

    /// A distance line of a constraint file: `distance,<point>,<point>,<length>[,<std>]`.
    fn distance_line(&self, row: &Row, schema: &Schema<'_>) -> Result<DistanceLine, InputError> {
        let at = |index: usize, message: String| {
            self.err_at(self.field_offset(row.start, index), message)
        };
        const FORM: &str = "distance,<point>,<point>,<length>[,<std>]";
        if !(4..=5).contains(&row.len()) {
            return Err(at(
                row.len().min(5),
                format!(
                    "a distance line has 4 or 5 fields ({FORM}), this one has {}",
                    row.len()
                ),
            ));
        }
        let name = |i: usize| -> Result<(String, Place), InputError> {
            let value = row.field(i).unwrap_or("");
            if value.is_empty() {
                return Err(at(
                    i,
                    format!(
                        "distance: field {} is empty, expected a point name ({FORM})",
                        i + 1
                    ),
                ));
            }
            Ok((value.to_owned(), self.place(row.start, i)))
        };
        let points = [name(1)?, name(2)?];
        if points[0].0 == points[1].0 {
            return Err(at(
                2,
                format!("distance: from the point '{}' to itself", points[0].0),
            ));
        }
        let unit = schema.units.length.name();
        let positive = |i: usize, what: &str| -> Result<f64, InputError> {
            let value = row.field(i).unwrap_or("");
            match value.parse::<f64>() {
                Ok(x) if x.is_finite() && x > 0.0 => Ok(schema.units.length_to_si(x)),
                _ => Err(at(
                    i,
                    format!(
                        "distance: {what} {value:?} is not a positive number of {unit} ({FORM})"
                    ),
                )),
            }
        };
        let length = positive(3, "the length")?;
        let std = if row.len() == 5 {
            positive(4, "the standard uncertainty")?
        } else {
            DEFAULT_DISTANCE_STD
        };
        Ok(DistanceLine {
            line: row.line,
            points,
            length,
            std,
            length_at: self.place(row.start, 3),
        })
    }
}

/// Reads the file `source` (`file` in messages) as a file of `schema.kind`,
/// giving each data row to `sink` as it is read.
pub(super) fn read_table<R: std::io::Read>(
    source: Source<R>,
    file: &str,
    schema: &Schema<'_>,
    sink: impl FnMut(Item),
) -> Result<Columns, InputError> {
    CsvReader::new(source, file).read(schema, sink)
}
