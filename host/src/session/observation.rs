//! One measured row of a session, in SI ([`Observation`]): the pose's joint
//! readings, what its tool point is held to ([`Contact`]: a measured
//! position, an unknown fixed point or plane), its orientation and context
//! (temperature, payload, approach, torques), with the limits a row's values
//! are read within. Positions in m, joints in rad or m, torques in N·m.

use armcal_shared::compensation::Task;
use armcal_shared::effects::{Approach, Context};
use armcal_shared::ranges::Ranges;
use nalgebra::{Point3, UnitQuaternion};

use crate::session::channel::Channel;

/// The temperatures (°C) a working robot may be measured at: below it a `temp`
/// is refused as a unit or a typo (−273.15 °C, a value in K or °F).
pub const TEMPERATURE_RANGE: [f64; 2] = [-50.0, 150.0];

/// The payloads (kg) a robot may carry: none is negative, and the heaviest
/// industrial arms carry about 2.3 t.
pub const PAYLOAD_RANGE: [f64; 2] = [0.0, 5000.0];

/// The largest joint torque a `tau` cell may hold, N·m (N for a prismatic
/// joint): the shoulders of the heaviest industrial arms carry under 10⁵ N·m.
pub const MAX_TORQUE: f64 = 1e5;

/// How far from 1 the norm of a measured quaternion may be; within it the
/// quaternion is normalised, beyond it the file is refused.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

/// One measured pose, SI: the joint readings, what the instrument saw, and
/// what non-geometric effects depend on at it.
#[derive(Clone, Debug, PartialEq)]
pub struct Observation {
    /// Joint readings: rad for a revolute joint, m for a prismatic one.
    pub q: Vec<f64>,
    /// Measured position of the tool point in the measurement frame, m.
    pub position: Point3<f64>,
    /// Measured orientation of the tool frame, if the row has one (normalised).
    pub orientation: Option<UnitQuaternion<f64>>,
    /// The row's temperature (`temp`, °C) and payload (`load`, kg), and the
    /// direction each joint approached the pose from (the sign of its last
    /// change in row order, held while the joint holds:
    /// [`Approach`]).
    pub context: Context<f64>,
    /// The joints' torques the robot reported at the pose (`tau1..tauM`: the
    /// torque each joint's drive exerts on its link, N·m, N for a prismatic
    /// joint), when the session has them.
    pub torque: Option<Vec<f64>>,
    /// What the row's tool point is held to: its measured `position`, or
    /// (a row of a constraint file, `position` not measured and 0) an unknown
    /// fixed point or plane.
    pub contact: Contact,
    /// The session the row was measured in: an index into
    /// [`Measurements::sessions`](crate::session::measurements::Measurements::sessions) (0 for a single session). Each session has
    /// its own registration unless told it shares one
    /// ([`crate::session::registration`]).
    pub session: usize,
}

/// The ranges of `poses` (SI: each joint, the temperature and the payload
/// where the rows give them), recorded in a calibration identified from them.
pub fn ranges<'a>(poses: impl IntoIterator<Item = &'a Observation>) -> Ranges<f64> {
    Ranges::of(
        poses
            .into_iter()
            .map(|o| (&o.q[..], o.context.temperature, o.context.payload)),
    )
}

/// What a calibration from `poses` compensates: [`Task::Pose`] when every
/// pose (of one at least) has a measured orientation, else
/// [`Task::Position`].
pub fn task<'a>(poses: impl IntoIterator<Item = &'a Observation>) -> Task {
    let mut poses = poses.into_iter().peekable();
    if poses.peek().is_some() && poses.all(|p| p.orientation.is_some()) {
        Task::Pose
    } else {
        Task::Position
    }
}

/// The number of sessions `poses` were measured in (1 for none or one).
pub fn session_count<'a>(poses: impl IntoIterator<Item = &'a Observation>) -> usize {
    poses.into_iter().map(|o| o.session + 1).max().unwrap_or(1)
}

/// What a pose's tool point is held to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Contact {
    /// The position measured on the row.
    #[default]
    Measured,
    /// The unknown fixed point it sits at: an index into
    /// [`Measurements::constraints`](crate::session::measurements::Measurements::constraints)' points.
    Point(usize),
    /// The unknown plane it touches: an index into
    /// [`Measurements::constraints`](crate::session::measurements::Measurements::constraints)' planes.
    Plane(usize),
}

impl Observation {
    /// A row of a session without a tracker: joints `q` (SI), the tool point
    /// at the unknown point or on the unknown plane `contact` names; no
    /// coordinate measured.
    pub fn at_contact(q: Vec<f64>, contact: Contact) -> Self {
        Self {
            q,
            position: Point3::origin(),
            orientation: None,
            context: Context::default(),
            torque: None,
            contact,
            session: 0,
        }
    }

    /// The pose of one row, in the order of the rows: joints `q` (SI), the
    /// measured point (m) and orientation, the row's temperature (°C) and
    /// payload (kg); `approach` carries the joints' approach directions from
    /// row to row.
    pub fn of_row(
        q: Vec<f64>,
        position: Point3<f64>,
        orientation: Option<UnitQuaternion<f64>>,
        (temperature, payload): (Option<f64>, Option<f64>),
        torque: Option<Vec<f64>>,
        approach: &mut Approach,
    ) -> Self {
        let context = Context {
            temperature,
            payload,
            approach: approach.next(&q),
        };
        Self {
            q,
            position,
            orientation,
            context,
            torque,
            contact: Contact::Measured,
            session: 0,
        }
    }

    /// The unknown fixed point the tool point sits at, if it does.
    pub fn fixed_point(&self) -> Option<usize> {
        match self.contact {
            Contact::Point(k) => Some(k),
            _ => None,
        }
    }

    /// The unknown plane the tool point touches, if it does.
    pub fn on_plane(&self) -> Option<usize> {
        match self.contact {
            Contact::Plane(k) => Some(k),
            _ => None,
        }
    }

    /// The noise channel of the rows that locate its tool point: a measured
    /// position, or the kind of its contact.
    pub fn channel(&self) -> Channel {
        match self.contact {
            Contact::Measured => Channel::Position,
            Contact::Point(_) => Channel::Point,
            Contact::Plane(_) => Channel::Plane,
        }
    }

    /// The scalar equations this pose gives an identification: its position
    /// rows and its orientation rows.
    pub fn equations(&self) -> usize {
        self.position_rows() + self.orientation_rows()
    }

    /// The rows that locate its tool point: 3, or 1 for a touch of a plane
    /// (its distance along the normal).
    pub fn position_rows(&self) -> usize {
        if self.on_plane().is_some() { 1 } else { 3 }
    }

    /// Its orientation rows: 3 when measured (a touch of a plane has none).
    pub fn orientation_rows(&self) -> usize {
        if self.orientation.is_some() && self.on_plane().is_none() {
            3
        } else {
            0
        }
    }
}
