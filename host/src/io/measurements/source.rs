//! The bytes of a data file on their way to the `csv` crate ([`Source`]): a
//! leading byte-order mark dropped, lone CRs made LFs, the size bounded and
//! the text checked to be UTF-8; where it ends early and why ([`Stop`]).

use crate::io::input_error::SizeLimit;

/// The bytes of a data file as the `csv` crate reads them, prepared as the
/// module says: a leading byte-order mark dropped, every lone CR made an LF (one
/// byte for one, so offsets stay those of the file), the size bounded and the
/// text checked to be UTF-8 before the reader sees it. What the reader consumed
/// since the record being read began stays in `window`, for the places of
/// errors; the rest is let go, so a file is read in memory independent of its
/// length.
pub(super) struct Source<R> {
    pub(super) inner: R,
    /// The most bytes read from `inner` ([`SizeLimit::bytes`]).
    pub(super) limit: u64,
    /// Bytes read from `inner` so far.
    pub(super) raw: u64,
    /// The text from offset `start` on.
    pub(super) window: Vec<u8>,
    pub(super) start: usize,
    /// The offset of the next byte for the `csv` reader.
    pub(super) given: usize,
    /// The text up to this offset is UTF-8 (and may be given).
    pub(super) checked: usize,
    /// A CR ended the last read: whether it ends a line depends on the next byte.
    pub(super) held_cr: bool,
    /// Whether a read has been made (the mark is looked for in the first).
    pub(super) begun: bool,
    /// Whether `inner` is exhausted (or the text ends early: `stop`).
    pub(super) eof: bool,
    /// Where the text ends early, and why.
    pub(super) stop: Option<(usize, Stop)>,
    /// The buffer `inner` is read into.
    pub(super) chunk: Vec<u8>,
}

/// Why the text of a data file ends before its end.
#[derive(Clone, Debug)]
pub(super) enum Stop {
    /// The file is larger than the limit.
    TooLarge,
    /// A byte that is not UTF-8.
    NotUtf8,
    /// The file could not be read on (an I/O error).
    Unreadable(String),
}

impl<R: std::io::Read> Source<R> {
    pub(super) fn new(inner: R, limit: SizeLimit) -> Self {
        Self {
            inner,
            limit: limit.bytes,
            raw: 0,
            window: Vec::new(),
            start: 0,
            given: 0,
            checked: 0,
            held_cr: false,
            begun: false,
            eof: false,
            stop: None,
            chunk: vec![0; 1 << 16],
        }
    }

    /// The offset one past the last byte in the window.
    pub(super) fn end(&self) -> usize {
        self.start + self.window.len()
    }

    /// The byte at `offset`, if it is in the window.
    pub(super) fn byte(&self, offset: usize) -> Option<u8> {
        offset
            .checked_sub(self.start)
            .and_then(|i| self.window.get(i).copied())
    }

    /// The text from `from` to `to` (what of it is in the window).
    pub(super) fn text(&self, from: usize, to: usize) -> &[u8] {
        let (a, b) = (
            from.saturating_sub(self.start),
            to.saturating_sub(self.start),
        );
        self.window.get(a..b.min(self.window.len())).unwrap_or(&[])
    }

    /// Lets go of the text before `offset` once that is most of the window.
    pub(super) fn forget_before(&mut self, offset: usize) {
        let dead = offset.min(self.given).saturating_sub(self.start);
        if dead >= 1 << 16 && dead >= self.window.len() / 2 {
            self.window.drain(..dead);
            self.start += dead;
        }
    }

    /// Reads the next chunk of `inner` into the window.
    fn fill(&mut self) {
        let n = loop {
            match self.inner.read(&mut self.chunk) {
                Ok(n) => break n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => {
                    self.end_early(self.end(), Stop::Unreadable(e.to_string()));
                    return;
                }
            }
        };
        self.raw += n as u64;
        let mut bytes = self.chunk.get(..n).unwrap_or(&[]);
        if self.raw > self.limit {
            let over = usize::try_from(self.raw - self.limit).unwrap_or(n).min(n);
            bytes = &bytes[..n - over];
        }
        if !self.begun {
            self.begun = true;
            bytes = bytes.strip_prefix("\u{feff}".as_bytes()).unwrap_or(bytes);
        }
        if std::mem::take(&mut self.held_cr) {
            self.window.push(if bytes.first() == Some(&b'\n') {
                b'\r'
            } else {
                b'\n'
            });
        }
        let mut rest = bytes;
        while let Some(i) = memchr::memchr(b'\r', rest) {
            self.window.extend_from_slice(&rest[..i]);
            match rest.get(i + 1) {
                Some(b'\n') => self.window.push(b'\r'),
                Some(_) => self.window.push(b'\n'),
                None => self.held_cr = true,
            }
            rest = &rest[i + 1..];
        }
        self.window.extend_from_slice(rest);
        if n == 0 {
            self.eof = true;
        }
        let checked = self.checked - self.start;
        if let Err(e) = std::str::from_utf8(&self.window[checked..]) {
            self.checked += e.valid_up_to();
            if e.error_len().is_some() || self.eof {
                self.window.truncate(self.checked - self.start);
                self.end_early(self.checked, Stop::NotUtf8);
            }
        } else {
            self.checked = self.end();
        }
        if self.raw > self.limit {
            self.end_early(self.end(), Stop::TooLarge);
        }
    }

    fn end_early(&mut self, offset: usize, why: Stop) {
        self.eof = true;
        self.held_cr = false;
        if self.stop.is_none() {
            self.stop = Some((offset, why));
        }
    }
}

impl<R: std::io::Read> std::io::Read for Source<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        while self.given == self.checked && !self.eof {
            self.fill();
        }
        let ready = self
            .window
            .get(self.given - self.start..self.checked - self.start)
            .unwrap_or(&[]);
        let n = ready.len().min(buf.len());
        buf[..n].copy_from_slice(&ready[..n]);
        self.given += n;
        Ok(n)
    }
}
