//! Rows of joint readings alone, in SI: what `armcal predict`, `compensate`
//! and `stream` read (`docs/file-formats.md` §4), and what Python hands them.

/// One row of joint readings, for `armcal predict` and `compensate`.
#[derive(Clone, Debug, PartialEq)]
pub struct JointRow {
    /// 1-based line of this row in the file.
    pub line: usize,
    /// Joint readings, SI: rad for a revolute joint, m for a prismatic one.
    pub q: Vec<f64>,
    /// Time of the reading, s.
    pub t: Option<f64>,
    /// Temperature, °C.
    pub temp: Option<f64>,
    /// Payload mass, kg.
    pub load: Option<f64>,
}

/// A file of joint readings read against a robot (see [the module](self)).
#[derive(Clone, Debug, PartialEq)]
pub struct JointRows {
    /// The file as named by the user.
    pub file: String,
    /// The rows, in file order.
    pub rows: Vec<JointRow>,
    /// The header names of the columns used (`q1..qM`, `t`, `temp`, `load`), in
    /// file order.
    pub columns_used: Vec<String>,
    /// The header names of the columns not read (`x`, `y`, `z`, the quaternion and
    /// any other), in file order.
    pub columns_ignored: Vec<String>,
    /// Things the user should know that do not stop the computation.
    pub warnings: Vec<String>,
}

impl JointRows {
    /// Rows of joint values given in memory (SI), all in the same conditions,
    /// named `file` and numbered from line 2 as under a header.
    pub fn commands(
        file: &str,
        rows: &[Vec<f64>],
        temperature: Option<f64>,
        payload: Option<f64>,
    ) -> Self {
        Self {
            file: file.into(),
            rows: rows
                .iter()
                .enumerate()
                .map(|(i, q)| JointRow {
                    line: i + 2,
                    q: q.clone(),
                    t: None,
                    temp: temperature,
                    load: payload,
                })
                .collect(),
            columns_used: Vec::new(),
            columns_ignored: Vec::new(),
            warnings: Vec::new(),
        }
    }

    /// The number of rows.
    pub fn len(&self) -> usize {
        self.rows.len()
    }

    /// Whether there are no rows (never the case for a parsed file).
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty()
    }
}
