//! Rows of a session, borrowed ([`Rows`]): all of them, or those an index set
//! names, in its order. A view copies no row: a fold, the rows kept after
//! blunders are set aside, or a sample of a large session is its indices into
//! the session's rows, and the fit reads the rows where they lie.

use std::ops::{Index, Range};

use crate::session::observation::Observation;

/// Rows of a session, borrowed: all of `all`, or those `picked` names (in
/// its order, indices into `all`). `Copy`: pass it by value.
#[derive(Clone, Copy, Debug)]
pub struct Rows<'a> {
    all: &'a [Observation],
    picked: Option<&'a [usize]>,
}

impl<'a> Rows<'a> {
    /// The rows of `all` that `indices` name, in the order of `indices`.
    ///
    /// # Panics
    /// On reading a row whose index is not below `all.len()`.
    pub fn picked(all: &'a [Observation], indices: &'a [usize]) -> Self {
        Self {
            all,
            picked: Some(indices),
        }
    }

    /// The session's rows this view borrows: all of them, whichever it names.
    pub fn all(&self) -> &'a [Observation] {
        self.all
    }

    /// Where rows `rows` of these lie in [`Rows::all`]: with it, what
    /// [`Rows::picked`] views them by (a subset of a subset, still borrowed).
    pub fn positions_of(&self, rows: impl IntoIterator<Item = usize>) -> Vec<usize> {
        rows.into_iter().map(|i| self.position(i)).collect()
    }

    /// The number of rows.
    pub fn len(&self) -> usize {
        self.picked.map_or(self.all.len(), <[usize]>::len)
    }

    /// Whether there is no row.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The rows, in order.
    pub fn iter(&self) -> Iter<'a> {
        Iter {
            rows: *self,
            next: 0,
            end: self.len(),
        }
    }

    /// The first row, if any.
    pub fn first(&self) -> Option<&'a Observation> {
        self.get(0)
    }

    /// Row `i`, if there are more than `i`.
    pub fn get(&self, i: usize) -> Option<&'a Observation> {
        match self.picked {
            None => self.all.get(i),
            Some(p) => p.get(i).map(|&k| &self.all[k]),
        }
    }

    /// Where row `i` of these rows lies in the session's rows.
    fn position(&self, i: usize) -> usize {
        match self.picked {
            None => i,
            Some(p) => p[i],
        }
    }

    /// Rows `range` of these rows.
    ///
    /// # Panics
    /// When `range` runs past [`Rows::len`].
    pub fn slice(&self, range: Range<usize>) -> Self {
        match self.picked {
            None => Self {
                all: &self.all[range],
                picked: None,
            },
            Some(p) => Self {
                all: self.all,
                picked: Some(&p[range]),
            },
        }
    }

    /// These rows in consecutive pieces of `size` (the last may be shorter),
    /// as [`slice::chunks`] cuts a slice.
    ///
    /// # Panics
    /// When `size` is 0.
    pub fn chunks(&self, size: usize) -> impl Iterator<Item = Rows<'a>> + 'a {
        assert!(size > 0, "chunk size must be non-zero");
        let rows = *self;
        let n = rows.len();
        (0..n)
            .step_by(size)
            .map(move |start| rows.slice(start..(start + size).min(n)))
    }
}

impl Index<usize> for Rows<'_> {
    type Output = Observation;

    fn index(&self, i: usize) -> &Observation {
        &self.all[self.position(i)]
    }
}

impl<'a> From<&'a [Observation]> for Rows<'a> {
    fn from(all: &'a [Observation]) -> Self {
        Self { all, picked: None }
    }
}

impl<'a> From<&'a Vec<Observation>> for Rows<'a> {
    fn from(all: &'a Vec<Observation>) -> Self {
        Self::from(&all[..])
    }
}

impl<'a, const N: usize> From<&'a [Observation; N]> for Rows<'a> {
    fn from(all: &'a [Observation; N]) -> Self {
        Self::from(&all[..])
    }
}

impl<'a> IntoIterator for Rows<'a> {
    type Item = &'a Observation;
    type IntoIter = Iter<'a>;

    fn into_iter(self) -> Iter<'a> {
        self.iter()
    }
}

/// The rows of a [`Rows`], in order, borrowed.
#[derive(Clone, Debug)]
pub struct Iter<'a> {
    rows: Rows<'a>,
    next: usize,
    end: usize,
}

impl<'a> Iterator for Iter<'a> {
    type Item = &'a Observation;

    fn next(&mut self) -> Option<&'a Observation> {
        (self.next < self.end).then(|| {
            self.next += 1;
            &self.rows.all[self.rows.position(self.next - 1)]
        })
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = self.end - self.next;
        (n, Some(n))
    }

    fn nth(&mut self, n: usize) -> Option<&'a Observation> {
        self.next = self.next.saturating_add(n).min(self.end);
        self.next()
    }
}

impl<'a> DoubleEndedIterator for Iter<'a> {
    fn next_back(&mut self) -> Option<&'a Observation> {
        (self.next < self.end).then(|| {
            self.end -= 1;
            &self.rows.all[self.rows.position(self.end)]
        })
    }
}

impl ExactSizeIterator for Iter<'_> {}

impl std::iter::FusedIterator for Iter<'_> {}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::observation::Contact;

    fn rows(n: usize) -> Vec<Observation> {
        (0..n)
            .map(|i| Observation {
                session: i,
                ..Observation::at_contact(vec![0.0], Contact::Measured)
            })
            .collect()
    }

    fn sessions(r: Rows<'_>) -> Vec<usize> {
        r.iter().map(|o| o.session).collect()
    }

    #[test]
    fn a_view_reads_the_rows_it_names_in_order() {
        let all = rows(5);
        let whole = Rows::from(&all);
        assert_eq!(sessions(whole), [0, 1, 2, 3, 4]);
        let picked = [3, 0, 4];
        let some = Rows::picked(&all, &picked);
        assert_eq!((some.len(), some[1].session), (3, 0));
        assert_eq!(sessions(some), [3, 0, 4]);
        assert_eq!(sessions(some.slice(1..3)), [0, 4]);
        let pieces: Vec<Vec<usize>> = some.chunks(2).map(sessions).collect();
        assert_eq!(pieces, [vec![3, 0], vec![4]]);
        let pieces: Vec<Vec<usize>> = whole.chunks(2).map(sessions).collect();
        assert_eq!(pieces, [vec![0, 1], vec![2, 3], vec![4]]);
        assert!(Rows::picked(&all, &[]).is_empty());
        assert_eq!(some.get(3).map(|o| o.session), None);
        let inner = some.positions_of([2, 0]);
        assert_eq!(sessions(Rows::picked(some.all(), &inner)), [4, 3]);
        assert_eq!(
            some.iter().rev().map(|o| o.session).collect::<Vec<_>>(),
            [4, 0, 3]
        );
        assert_eq!(some.iter().nth(2).map(|o| o.session), Some(4));
    }
}
