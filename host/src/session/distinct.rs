//! One session given once: the same file, the same rows, or rows copied from
//! another session (reordered, re-rounded, a few left out) are refused where
//! several sessions make one calibration or one holdout. A session given twice
//! counts its rows twice, and a session held out and trained on gives
//! in-sample figures as held-out ones. Positions in m, joints in rad or m.

use crate::session::input_error::InputError;
use crate::session::measurements::Measurements;
use crate::session::observation::Contact;

/// Why a holdout's session is given once ([`require_distinct`]).
pub const HOLDOUT_TWICE: &str =
    "a session held out and trained on gives in-sample figures as held-out ones";

/// Why one of several sessions of a calibration is given once
/// ([`require_distinct`]).
pub const SESSION_TWICE: &str = "a session given twice counts its rows twice, and its figure \
     left out is an in-sample one";

/// Two measured points closer than this, m, at one configuration are one
/// reading copied: a laser tracker repeats a point to several µm, and a
/// copy rounded to nine significant digits keeps a metre to 1e-9 m.
pub const COPY_POSITION: f64 = 1e-6;

/// Two joint readings closer than this, rad or m, are one configuration (an
/// encoder's count, [`crate::session::configurations::REVOLUTE_RESOLUTION`]).
const COPY_JOINT: f64 = crate::session::configurations::REVOLUTE_RESOLUTION;

/// How many measured rows of `b` repeat a measured row of `a`: every joint
/// within [`COPY_JOINT`] and the measured point within [`COPY_POSITION`],
/// whatever the rows' order. A session measured again at the same
/// configurations differs by the instrument's noise, far above that; a
/// session copied, reversed or re-rounded does not.
fn copied_rows(a: &Measurements, b: &Measurements) -> usize {
    let measured = |m: &Measurements| -> Vec<usize> {
        (0..m.poses.len())
            .filter(|&i| m.poses[i].contact == Contact::Measured && !m.poses[i].q.is_empty())
            .collect()
    };
    let mut sorted = measured(a);
    sorted.sort_by(|&i, &j| a.poses[i].q[0].total_cmp(&a.poses[j].q[0]));
    let firsts: Vec<f64> = sorted.iter().map(|&i| a.poses[i].q[0]).collect();
    measured(b)
        .into_iter()
        .filter(|&i| {
            let p = &b.poses[i];
            let from = firsts.partition_point(|&x| x < p.q[0] - COPY_JOINT);
            sorted[from..]
                .iter()
                .take_while(|&&j| a.poses[j].q[0] <= p.q[0] + COPY_JOINT)
                .any(|&j| {
                    let o = &a.poses[j];
                    o.q.len() == p.q.len()
                        && o.q
                            .iter()
                            .zip(&p.q)
                            .all(|(x, y)| (x - y).abs() <= COPY_JOINT)
                        && (o.position - p.position).norm() <= COPY_POSITION
                })
        })
        .count()
}

/// Refuses a session given twice among `sessions`: the same file (paths
/// compared once canonicalised), the same rows (the joint readings and
/// measured points of every row, the names of the points and planes they
/// are held to, and the known distances), or nine in ten of the measured
/// rows of the shorter one copied from the other (`copied_rows`: reordered,
/// re-rounded, a few rows less), naming both and saying `why` a
/// session must be given once (the sessions of a holdout: left out and
/// trained on at once, its held-out figures would be in-sample ones,
/// [`HOLDOUT_TWICE`]).
pub fn require_distinct(sessions: &[&Measurements], why: &str) -> Result<(), InputError> {
    // Only a file on disk has a path (numpy arrays and built-in sets are
    // labels, compared by their rows).
    let path = |m: &Measurements| {
        let p = std::path::Path::new(&m.file);
        p.is_file().then(|| std::fs::canonicalize(p).ok()).flatten()
    };
    /// Every row as held (readings and measured point, point, plane) and
    /// every distance.
    #[allow(clippy::type_complexity)]
    fn rows(
        m: &Measurements,
    ) -> (
        Vec<(Vec<u64>, Option<&str>, Option<&str>)>,
        Vec<(&str, &str, u64)>,
    ) {
        let c = &m.constraints;
        let held: Vec<(Vec<u64>, Option<&str>, Option<&str>)> = m
            .poses
            .iter()
            .map(|p| {
                let (point, plane) = match p.contact {
                    Contact::Point(k) => (c.points.get(k).map(|n| n.name.as_str()), None),
                    Contact::Plane(k) => (None, c.planes.get(k).map(|n| n.name.as_str())),
                    Contact::Measured => (None, None),
                };
                let reading = p.q.iter().chain(p.position.coords.iter());
                (reading.map(|v| v.to_bits()).collect(), point, plane)
            })
            .collect();
        let distances: Vec<(&str, &str, u64)> = c
            .distances
            .iter()
            .map(|d| {
                let [a, b] = d
                    .points
                    .map(|k| c.points.get(k).map_or("", |p| p.name.as_str()));
                (a, b, d.length.to_bits())
            })
            .collect();
        (held, distances)
    }
    for (j, b) in sessions.iter().enumerate() {
        for a in &sessions[..j] {
            let copied = copied_rows(a, b);
            let how = if path(a).is_some_and(|p| Some(p) == path(b)) {
                "the same file".to_owned()
            } else if rows(a) == rows(b) {
                "the same rows (every joint reading, measured point, point, plane and distance)"
                    .to_owned()
            } else if copied * 10 >= 9 * a.poses.len().min(b.poses.len()) && copied > 0 {
                format!(
                    "{copied} of its {} rows repeat a configuration of {} with the same measured \
                     point to {COPY_POSITION:e} m, closer than an instrument reads a point twice: \
                     rows copied, reordered or rounded",
                    b.poses.len(),
                    a.file
                )
            } else {
                continue;
            };
            return Err(InputError::new(
                &b.file,
                0,
                0,
                format!(
                    "the same session as {} ({how}): {why}; give each session once",
                    a.file
                ),
            ));
        }
    }
    Ok(())
}
