//! Plans for a session without a tracker: a ball on the flange seated in the
//! sockets of a plate (`armcal plan --sockets S.csv`, `docs/file-formats.md` §3
//! and §7).
//!
//! ## What is chosen
//! For each socket, which configurations to seat the ball in it at: the
//! candidates are configurations of the nominal model that put its tool point
//! (the ball's centre) at the socket's nominal centre (inverse kinematics from
//! random starts within the joint limits less the margin), with the stem from
//! the ball to the flange within [`APPROACH_CONE_DEG`] of the direction the
//! socket is entered from. The poses are shared among the sockets evenly (the
//! first sockets one more where they do not divide): each socket's rows fix
//! its own three unknown coordinates and the rest calibrate the robot, the
//! known distances between sockets its scale.
//!
//! ## The frame the prediction is in
//! A session of contacts measures no coordinate: `identify` estimates the
//! sockets in the robot's base frame and holds the base, and every joint
//! parameter that moves the arm as the base would (`θ1` about a first axis
//! along the base z), at nominal ([`crate::calibration::fit`]). The
//! plan predicts the calibrated robot's tool point in that frame, so those
//! parameters ([`gauge`]: their columns over the candidates within the span of
//! the base's and the sockets') are not among its unknowns; every other
//! parameter is, with the prior where the contacts do not determine it (the
//! scale, without a known distance). SI inside.

use armcal_shared::{FrameAxis, Param, Robot};
use nalgebra::DMatrix;

use super::{Column, PlanError, jacobian, within_limits};
use crate::calibration::parallel;
use crate::calibration::simulate::{Stream, reach_point};
use crate::io::sockets::{APPROACH_CONE_DEG, Sockets};
use crate::session::constraints::{Constraints, Named};
use crate::session::observation::Contact;
use crate::session::observation::Observation;

/// The candidates of a socket plan: about `count` configurations in all,
/// shared among `plate`'s sockets, each reaching its socket (see the module
/// header), with the socket each reaches. Refused when a socket is reached
/// by fewer than `least` of them.
pub fn candidates(
    robot: &Robot<f64>,
    plate: &Sockets,
    count: usize,
    least: usize,
    margin: f64,
    seed: u64,
) -> Result<(Vec<Vec<f64>>, Vec<usize>), PlanError> {
    let per_socket = count.div_ceil(plate.sockets.len()).max(least);
    let limits: Vec<[f64; 2]> = robot
        .links
        .iter()
        .map(|l| super::margin_range(l, margin))
        .collect();
    let kinematics = robot.prepare();
    let cone = APPROACH_CONE_DEG.to_radians().cos();
    let mut q = Vec::new();
    let mut socket_of = Vec::new();
    for (k, socket) in plate.sockets.iter().enumerate() {
        let starts = within_limits(robot, per_socket, margin, Stream::Socket(k).seed(seed));
        let pieces: Vec<&[Vec<f64>]> = starts
            .chunks(parallel::piece_len(starts.len(), 1))
            .collect();
        let reached = parallel::map(&pieces, |chunk| {
            chunk
                .iter()
                .filter_map(|start| {
                    let q = reach_point(robot, start.clone(), &socket.centre)?;
                    let within = q
                        .iter()
                        .zip(&limits)
                        .all(|(v, [lo, hi])| lo <= v && v <= hi);
                    let chain = kinematics.chain(&q).ok()?;
                    let stem = chain.flange.translation.vector - socket.centre.coords;
                    let entered =
                        stem.norm() < 1e-3 || stem.normalize().dot(&socket.approach) >= cone;
                    (within && entered).then_some(q)
                })
                .collect::<Vec<_>>()
        })
        .concat();
        if reached.len() < least {
            return Err(PlanError::SocketUnreached {
                socket: socket.name.clone(),
                reached: reached.len(),
                tried: per_socket,
                least,
            });
        }
        socket_of.extend(std::iter::repeat_n(k, reached.len()));
        q.extend(reached);
    }
    Ok((q, socket_of))
}

/// The socket of each of `n` poses: the sockets in turn, so that they share
/// the poses evenly (the first ones one more where they do not divide).
pub fn slots(n: usize, sockets: usize) -> Vec<usize> {
    (0..n).map(|i| i % sockets.max(1)).collect()
}

/// How many of the rows `socket_of` (the socket of each) are at `socket`.
pub fn rows_at(socket_of: &[usize], socket: usize) -> usize {
    socket_of.iter().filter(|&&k| k == socket).count()
}

/// Exact contacts of `robot` at `q`, each at its socket `socket_of`: what the
/// identifiability checks read.
pub fn exact(q: &[Vec<f64>], socket_of: &[usize]) -> Vec<Observation> {
    q.iter()
        .zip(socket_of)
        .map(|(q, &k)| Observation::at_contact(q.clone(), Contact::Point(k)))
        .collect()
}

/// The constraints of a session seating the ball in `plate`'s sockets as
/// `socket_of` says: the sockets as named points, and the known distances.
pub fn constraints(plate: &Sockets, socket_of: &[usize]) -> Constraints {
    Constraints {
        points: plate
            .sockets
            .iter()
            .enumerate()
            .map(|(k, s)| Named {
                name: s.name.clone(),
                first: (0, 0),
                rows: rows_at(socket_of, k),
            })
            .collect(),
        planes: Vec::new(),
        distances: plate.distances.clone(),
    }
}

/// Of the parameters `held`, those that move every candidate's tool point as
/// a rigid motion of the base frame would, the sockets moving with it: their
/// columns over the candidates `q` (at their sockets `socket_of`) are within
/// the span of the base's and the sockets' to 10⁻⁶ of their norm. The
/// calibration holds them as it holds the base (see the module header).
pub fn gauge(
    robot: &Robot<f64>,
    q: &[Vec<f64>],
    socket_of: &[usize],
    sockets: usize,
    held: &[Param],
) -> Vec<Param> {
    let frame: Vec<Column> = FrameAxis::ALL
        .into_iter()
        .map(|a| Column::Param(Param::Base(a)))
        .chain(
            (0..sockets).flat_map(|socket| (0..3).map(move |axis| Column::Socket { socket, axis })),
        )
        .collect();
    let a = jacobian(robot, q, Some(socket_of), &frame, None);
    let held_columns: Vec<Column> = held.iter().map(|&p| Column::Param(p)).collect();
    let b = jacobian(robot, q, Some(socket_of), &held_columns, None);
    let svd = a.clone().svd(true, true);
    let Ok(x) = svd.solve(&b, 1e-12 * svd.singular_values.max()) else {
        return Vec::new();
    };
    let residual: DMatrix<f64> = &a * x - &b;
    held.iter()
        .enumerate()
        .filter(|&(k, _)| residual.column(k).norm() <= 1e-6 * b.column(k).norm())
        .map(|(_, &p)| p)
        .collect()
}
