//! A session of measured rows ([`Measurements`], its rows are
//! [`crate::session::observation`]'s), in SI: the rows, their lines and times,
//! the session's constraints and sessions; and the
//! checks that the rows can carry a calibration of a model (`require_*`):
//! enough distinct configurations, points that can be measurements of the
//! model, known distances the nominal model does not contradict, a fit that
//! reaches them. [`crate::io::measurements`] reads the CSV
//! of `docs/file-formats.md` §2 into them, [`crate::io::arrays`] arrays.

use armcal_shared::compensation::Task;
use armcal_shared::units::Units;
use armcal_shared::{JointType, Robot};
use nalgebra::Point3;

use crate::cancel::Cancel;
use crate::session::configurations::{Configurations, distinct_equations_reach};
use crate::session::constraints::{Constraints, DistanceLine, merge_named};
use crate::session::input_error::InputError;
use crate::session::model::RobotModel;
use crate::session::observation::{Contact, Observation};
use crate::session::registration::{FrameSharing, Sharing};

/// A measurement file read against a model.
#[derive(Clone, Debug, PartialEq)]
pub struct Measurements {
    /// The file as named by the user (or the label of a built-in set).
    pub file: String,
    /// The poses, in file order.
    pub poses: Vec<Observation>,
    /// The 1-based line of each pose's row in the file (for messages and
    /// `outlier_rows`).
    pub lines: Vec<usize>,
    /// The time of each measurement (`t`, s), where the row gives it.
    pub times: Vec<Option<f64>>,
    /// The header names of the columns used, in file order.
    pub columns_used: Vec<String>,
    /// The header names of the columns kept out of the computation, in file order.
    pub columns_ignored: Vec<String>,
    /// Things the user should know that do not stop the computation.
    pub warnings: Vec<String>,
    /// The unknown fixed points and known distances of a constraint file
    /// (empty for measured coordinates; see [`crate::session::constraints`]).
    pub constraints: Constraints,
    /// The files of several sessions read as one ([`Measurements::sessions`]),
    /// in order: a pose's `session` indexes them. Empty for one session, the
    /// `file`.
    pub sessions: Vec<String>,
}

impl Measurements {
    /// Whether the rows carry constraints (unknown fixed points) instead of coordinates.
    pub fn is_constrained(&self) -> bool {
        !self.constraints.is_empty()
    }

    /// The number of poses.
    pub fn len(&self) -> usize {
        self.poses.len()
    }

    /// The sessions `parts` as one, in order: their poses, their lines (each
    /// its own file's), and their constraints, a point named in two parts
    /// being one point. The file is named by the parts' files listed (`a.csv,
    /// b.csv`): what a message about all the rows names; one about a row
    /// names its own file ([`Measurements::file_of`]).
    pub fn merged(parts: &[&Measurements]) -> Measurements {
        let mut out = Measurements {
            file: parts
                .iter()
                .map(|p| p.file.as_str())
                .collect::<Vec<_>>()
                .join(", "),
            poses: Vec::new(),
            lines: Vec::new(),
            times: Vec::new(),
            columns_used: parts
                .first()
                .map(|p| p.columns_used.clone())
                .unwrap_or_default(),
            columns_ignored: Vec::new(),
            warnings: Vec::new(),
            constraints: Constraints::default(),
            sessions: Vec::new(),
        };
        for part in parts {
            // Each point and plane of this part: its index in the merged constraints.
            let index = merge_named(&mut out.constraints.points, &part.constraints.points);
            let planes = merge_named(&mut out.constraints.planes, &part.constraints.planes);
            for pose in &part.poses {
                let mut pose = pose.clone();
                pose.contact = match pose.contact {
                    Contact::Point(k) => Contact::Point(index[k]),
                    Contact::Plane(k) => Contact::Plane(planes[k]),
                    Contact::Measured => Contact::Measured,
                };
                out.poses.push(pose);
            }
            out.lines.extend_from_slice(&part.lines);
            out.times.extend_from_slice(&part.times);
            out.warnings.extend(part.warnings.iter().cloned());
            for d in &part.constraints.distances {
                let mut d = d.clone();
                d.points = d.points.map(|k| index[k]);
                out.constraints.distances.push(d);
            }
        }
        out
    }

    /// Several sessions of one robot as one calibration's rows, in order:
    /// their poses, each marked with its session (an index into
    /// `sessions`, the files), their lines (each its own file's) and times.
    /// Sessions of contacts are [`Measurements::merged`] instead (a point named
    /// in two files is one point, and their frames are one). One part is
    /// returned as it is. Refused: sessions of contacts with sessions of
    /// measured coordinates.
    pub fn sessions(parts: Vec<Measurements>) -> Result<Measurements, InputError> {
        if parts.len() == 1 {
            return Ok(parts.into_iter().next().expect("one part"));
        }
        let contacts = parts.first().is_some_and(Measurements::is_constrained);
        if let Some(other) = parts.iter().find(|p| p.is_constrained() != contacts) {
            return Err(InputError::new(
                &other.file,
                other.lines.first().copied().unwrap_or(1),
                1,
                "a session of contacts (rows at unknown points or planes) and a session of \
                 measured coordinates cannot be calibrated together: give sessions of one kind",
            ));
        }
        let refs: Vec<&Measurements> = parts.iter().collect();
        let mut out = Measurements::merged(&refs);
        let mut pose = 0;
        for (session, part) in parts.iter().enumerate() {
            for p in &mut out.poses[pose..pose + part.poses.len()] {
                p.session = session;
            }
            pose += part.poses.len();
        }
        out.sessions = parts.iter().map(|p| p.file.clone()).collect();
        Ok(out)
    }

    /// The number of sessions the rows were measured in (1 for one file).
    pub fn session_count(&self) -> usize {
        self.sessions.len().max(1)
    }

    /// The file pose `pose` (an index into `poses`) was read from: its
    /// session's, or `file`.
    pub fn file_of(&self, pose: usize) -> &str {
        self.poses
            .get(pose)
            .and_then(|p| self.sessions.get(p.session))
            .map_or(&self.file, String::as_str)
    }

    /// Where a message about the rows as a whole points: the last row's file
    /// and line (the file to add rows to), `file` and line 1 without rows.
    pub fn last_place(&self) -> (&str, usize) {
        match self.poses.len().checked_sub(1) {
            Some(last) => (self.file_of(last), self.lines[last]),
            None => (&self.file, 1),
        }
    }

    /// Session `session`'s rows as the file they were read from: its poses
    /// (numbered session 0), lines and times, its file's name; the whole
    /// for one session. Constraints are not carried (sessions of contacts
    /// share their points: they are checked as one).
    pub fn session_part(&self, session: usize) -> Measurements {
        let rows: Vec<usize> = (0..self.poses.len())
            .filter(|&i| self.poses[i].session == session)
            .collect();
        Measurements {
            file: self.file_of(rows.first().copied().unwrap_or(0)).to_owned(),
            poses: rows
                .iter()
                .map(|&i| Observation {
                    session: 0,
                    ..self.poses[i].clone()
                })
                .collect(),
            lines: rows.iter().map(|&i| self.lines[i]).collect(),
            times: rows.iter().map(|&i| self.times[i]).collect(),
            columns_used: self.columns_used.clone(),
            columns_ignored: Vec::new(),
            warnings: Vec::new(),
            constraints: Constraints::default(),
            sessions: Vec::new(),
        }
    }

    /// Whether there are no poses (never the case for a parsed file).
    pub fn is_empty(&self) -> bool {
        self.poses.is_empty()
    }

    /// Whether every pose has a measured orientation.
    pub fn has_orientation(&self) -> bool {
        self.task() == Task::Pose
    }

    /// What a calibration from these poses compensates: [`Task::Pose`] when
    /// every pose has a measured orientation ([`Self::has_orientation`]).
    pub fn task(&self) -> Task {
        crate::session::observation::task(&self.poses)
    }

    /// The number of scalar equations the poses give: 3 per pose, 6 per pose with
    /// orientation.
    pub fn equations(&self) -> usize {
        self.poses.iter().map(Observation::equations).sum::<usize>() + self.constraints.equations()
    }

    /// The unknowns of a fit of `unknowns` robot parameters to these rows: a
    /// constraint session has no base (6 fewer) and three coordinates per
    /// fixed point or plane.
    fn unknowns(&self, unknowns: usize) -> usize {
        if self.is_constrained() {
            (unknowns + 3 * (self.constraints.points.len() + self.constraints.planes.len()))
                .saturating_sub(6)
        } else {
            unknowns
        }
    }

    /// Refuses the file if its distinct configurations (a configuration measured
    /// again adds no geometry: [`Configurations`]) give fewer equations than
    /// `unknowns` of `robot`.
    ///
    /// The error is placed at the last data line, column 1, and says how many poses
    /// and equations there are, how many unknowns, and how many poses are needed.
    pub fn require_poses(&self, robot: &Robot<f64>, unknowns: usize) -> Result<(), InputError> {
        let needed = self
            .unknowns(unknowns)
            .saturating_sub(self.constraints.equations());
        if distinct_equations_reach(robot, &self.poses, needed, Observation::equations) {
            return Ok(());
        }
        // Too few: the rows' count or the configurations', said as it is
        // (a check before any computation, on the way to a refusal: nothing
        // to cancel).
        let configurations = Configurations::of(robot, &self.poses, Cancel::NEVER);
        if configurations.repeated() {
            let equations = configurations
                .rows
                .iter()
                .map(|rows| self.poses[rows[0]].equations())
                .sum::<usize>()
                + self.constraints.equations();
            let distinct = configurations.count();
            let (file, line) = self.last_place();
            let unknowns = self.unknowns(unknowns);
            if equations < unknowns && self.equations() >= unknowns {
                return Err(InputError::new(
                    file,
                    line,
                    1,
                    format!(
                        "{} in {} (joints equal within the encoder's resolution: a repeat adds no \
                         geometry) give {equations} equations, fewer than the {unknowns} unknowns; \
                         measure more distinct poses",
                        plural(self.poses.len(), "row"),
                        plural(distinct, "distinct configuration"),
                    ),
                ));
            }
        }
        self.require_equations(unknowns)
    }

    /// Refuses a session of several whose rows cannot determine its own
    /// frames: the unknowns of the frames `sharing` makes each session's own
    /// (its base frame 6; its tool 3 with positions, 6 with orientations)
    /// need more equations than its distinct configurations give (as
    /// [`Measurements::require_poses`] counts them). A session with no more
    /// equations than that would fit its own frames and nothing else: it
    /// adds nothing to the robot's geometry, and the robot calibrated
    /// without it cannot be judged on it. The error names the session's
    /// file and its last line, its equations and what it needs. Sessions of
    /// contacts share their frames: nothing to refuse.
    pub fn require_own_frames(
        &self,
        robot: &Robot<f64>,
        sharing: FrameSharing,
    ) -> Result<(), InputError> {
        if self.session_count() < 2 || self.is_constrained() {
            return Ok(());
        }
        for session in 0..self.session_count() {
            let part = self.session_part(session);
            let orientation = part.has_orientation();
            let frames = OwnFrames::of(sharing, orientation);
            let unknowns = frames.unknowns();
            if unknowns == 0
                || distinct_equations_reach(
                    robot,
                    &part.poses,
                    unknowns + 1,
                    Observation::equations,
                )
            {
                continue;
            }
            let per_pose = if orientation { 6 } else { 3 };
            let equations = Configurations::of(robot, &part.poses, Cancel::NEVER)
                .rows
                .iter()
                .map(|rows| part.poses[rows[0]].equations())
                .sum::<usize>();
            let (file, line) = part.last_place();
            return Err(InputError::new(
                file,
                line,
                1,
                format!(
                    "session {file}: {} in {} give {equations} equations ({per_pose} per pose), \
                     no more than the {unknowns} unknowns of its own frames ({}): its rows would \
                     fit its frames alone and add nothing to the robot; measure at least {} \
                     distinct poses in it{}",
                    plural(part.poses.len(), "row"),
                    plural(
                        Configurations::of(robot, &part.poses, Cancel::NEVER).count(),
                        "distinct configuration"
                    ),
                    frames.describe(),
                    fewest_poses_of_a_session(sharing, orientation),
                    frames.share_hint()
                ),
            ));
        }
        Ok(())
    }

    /// Refuses the file if its rows give fewer equations than `unknowns`.
    fn require_equations(&self, unknowns: usize) -> Result<(), InputError> {
        let unknowns = self.unknowns(unknowns);
        let equations = self.equations();
        if equations >= unknowns {
            return Ok(());
        }
        let (file, line) = self.last_place();
        if self.is_constrained() {
            return Err(InputError::new(
                file,
                line,
                1,
                format!(
                    "fewer equations than unknowns: {} and {} give {equations} (3 per row at a \
                     point, 1 per touch of a plane, 1 per distance), fewer than the {unknowns} \
                     unknowns (the arm's less the base's 6, and 3 per point or plane); at least \
                     {} more are needed",
                    plural(self.poses.len(), "row"),
                    plural(self.constraints.distances.len(), "distance"),
                    unknowns - equations
                ),
            ));
        }
        let per_pose = if self.has_orientation() { 6 } else { 3 };
        let needed = unknowns.div_ceil(per_pose);
        Err(InputError::new(
            file,
            line,
            1,
            format!(
                "fewer poses than unknowns: {} give{} {equations} equations ({per_pose} per pose), \
                 fewer than the {unknowns} unknowns; at least {needed} poses are needed",
                plural(self.poses.len(), "pose"),
                if self.poses.len() == 1 { "s" } else { "" }
            ),
        ))
    }
}

/// How far (in units of the robot's reach, [`reach`]) a measured point may lie
/// from the median of the points. Two points the robot reaches are at most two
/// reaches apart, and the coordinate-wise median lies within their bounding box,
/// so a point farther than `2√3` reaches from it cannot be; the margin covers
/// a tool point the model places only roughly.
pub const SPREAD_LIMIT: f64 = 4.0;

/// The largest RMS position residual (as a share of the robot's [`reach`]) a
/// geometric calibration may leave and still be written: a working arm's
/// calibration leaves well under a millimetre per metre of reach, a camera's
/// a few; 2 % is tens of millimetres, only reached when the model cannot be
/// the robot that was measured.
pub const FIT_LIMIT: f64 = 0.02;

/// The farthest the tool point can be from the first joint's frame: the sum of
/// every link's lengths (`|s|`, `|a|`), each prismatic joint's largest
/// reading in `readings` and the tool's offset, m.
pub fn reach<'q>(robot: &Robot<f64>, readings: impl Iterator<Item = &'q [f64]>) -> f64 {
    let mut stroke = vec![0.0_f64; robot.dof()];
    for q in readings {
        for (s, v) in stroke.iter_mut().zip(q) {
            *s = s.max(v.abs());
        }
    }
    robot
        .links
        .iter()
        .zip(&stroke)
        .map(|(l, &q)| {
            l.s.abs()
                + l.a.abs()
                + match l.joint {
                    JointType::Prismatic => q,
                    JointType::Revolute => 0.0,
                }
        })
        .sum::<f64>()
        + robot.tool.xyz.norm()
}

impl Measurements {
    /// Refuses this session unless it is one without a tracker (its rows
    /// name the fixed point or plane their tool point is held to), as
    /// `armcal holdout` needs: its held-out figures need no coordinate, and a
    /// file of coordinates has none of them.
    pub fn require_contacts(&self) -> Result<(), InputError> {
        if self.is_constrained() {
            return Ok(());
        }
        Err(InputError::new(
            &self.file,
            self.lines.first().copied().unwrap_or(1),
            1,
            "holdout checks sessions without a tracker: the rows must name the unknown fixed \
             point or plane their tool point is held to (a `point` or `plane` column; \
             docs/file-formats.md)",
        ))
    }

    /// Refuses data that cannot be measurements of `robot`'s tool point: a
    /// position column with the same value on every row (a degenerate column: no
    /// instrument sees a moving arm so), or a point farther from the median of the
    /// points than [`SPREAD_LIMIT`] times the robot's [`reach`] (a typo, or the
    /// model and the data in different length units). The error names the line.
    pub fn require_plausible(&self, model: &RobotModel) -> Result<(), InputError> {
        let (robot, units) = (&model.robot, &model.units);
        let unit = units.length.name();
        let length = |x: f64| units.length_from_si(x);
        let Some(first) = self.poses.first() else {
            return Ok(());
        };
        if self.is_constrained() {
            // No coordinate is measured.
            return Ok(());
        }
        let moved = self.poses.iter().any(|p| p.q != first.q);
        for (c, name) in POSITION.iter().enumerate() {
            if moved
                && self
                    .poses
                    .iter()
                    .all(|p| p.position[c] == first.position[c])
            {
                return Err(InputError::new(
                    self.file_of(0),
                    self.lines.first().copied().unwrap_or(0),
                    1,
                    format!(
                        "column '{name}' reads {} {unit} on every row while the joints move: \
                         no instrument measures a moving tool point so; check the export",
                        length(first.position[c])
                    ),
                ));
            }
        }
        if let Some(far) = self.beyond_reach(robot) {
            return Err(InputError::new(
                self.file_of(far.pose),
                self.lines[far.pose],
                1,
                format!(
                    "the point {} lies {} {unit} from the median of the points, but the robot \
                     reaches at most {:.4} {unit} from its base: a typo, or the data and the \
                     model in different length units?",
                    self.point(far.pose, units),
                    show(units, far.distance),
                    length(far.reach)
                ),
            ));
        }
        Ok(())
    }

    /// [`Measurements::require_plausible`] for several sessions: each
    /// session's rows checked as the file they were read from (a session has
    /// its own median: with its own base frame, [`Sharing::PerSession`], its
    /// points may lie anywhere from the others'), every message naming the
    /// row's own file and line; and, when the sessions share one base frame
    /// (`base`), all their points against the median of all, a session far
    /// from the others refused as an instrument that moved. One session:
    /// [`Measurements::require_plausible`].
    pub fn require_plausible_sessions(
        &self,
        model: &RobotModel,
        base: Sharing,
    ) -> Result<(), InputError> {
        if self.session_count() < 2 || self.is_constrained() {
            return self.require_plausible(model);
        }
        for session in 0..self.session_count() {
            self.session_part(session).require_plausible(model)?;
        }
        if base == Sharing::PerSession {
            return Ok(());
        }
        let units = &model.units;
        let Some(far) = self.beyond_reach(&model.robot) else {
            return Ok(());
        };
        Err(InputError::new(
            self.file_of(far.pose),
            self.lines[far.pose],
            1,
            format!(
                "the point {} lies {} {unit} from the median of every session's points, but the \
                 robot reaches at most {:.4} {unit} from its base; each session alone is within \
                 reach: the sessions are taken to share one base frame (--same-base), was the \
                 instrument moved between them?",
                self.point(far.pose, units),
                show(units, far.distance),
                units.length_from_si(far.reach),
                unit = units.length.name()
            ),
        ))
    }

    /// The first pose farther from the median of the measured points than
    /// [`SPREAD_LIMIT`] times `robot`'s [`reach`], if one is.
    fn beyond_reach(&self, robot: &Robot<f64>) -> Option<FarPoint> {
        let reach = reach(robot, self.poses.iter().map(|p| p.q.as_slice()));
        let median = |c: usize| {
            let mut v: Vec<f64> = self.poses.iter().map(|p| p.position[c]).collect();
            let half = v.len() / 2;
            *v.select_nth_unstable_by(half, f64::total_cmp).1
        };
        let centre = Point3::new(median(0), median(1), median(2));
        // Scaled, so that a coordinate of 1e300 does not overflow its square.
        let distance = |p: &Observation| {
            let v = p.position - centre;
            let m = v.amax();
            if m > 0.0 { m * (v / m).norm() } else { 0.0 }
        };
        self.poses
            .iter()
            .position(|p| distance(p) > SPREAD_LIMIT * reach.max(1e-3))
            .map(|pose| FarPoint {
                pose,
                distance: distance(&self.poses[pose]),
                reach,
            })
    }

    /// Pose `pose`'s measured point as a message quotes it, `(x, y, z) mm`.
    fn point(&self, pose: usize, units: &Units) -> String {
        let p = &self.poses[pose].position;
        format!(
            "({}, {}, {}) {}",
            show(units, p.x),
            show(units, p.y),
            show(units, p.z),
            units.length.name()
        )
    }

    /// Refuses to let a calibration be written from a fit that still misses
    /// the points by more than [`FIT_LIMIT`] of the robot's reach (`position_rms`,
    /// m): such data do not carry a calibration of this model. `worst`, asked
    /// only then, is the row the nominal model misses most and by how much
    /// (m), with the share of the nominal model's sum of squares it holds:
    /// when that row alone holds most of it (a typo, an absurd joint
    /// reading), the refusal is placed at its file and line and names its
    /// joint reading farthest outside what the other rows read; otherwise
    /// (the joints in another order, another robot) at the files.
    pub fn require_fit_supported(
        &self,
        model: &RobotModel,
        position_rms: f64,
        worst: impl FnOnce() -> Option<WorstRow>,
    ) -> Result<(), InputError> {
        let reach = reach(&model.robot, self.poses.iter().map(|p| p.q.as_slice()));
        if position_rms.is_finite() && position_rms <= FIT_LIMIT * reach {
            return Ok(());
        }
        let u = &model.units;
        let message = format!(
            "the fitted model still misses the measured points by {:.4} {unit} RMS, {:.0} % \
             of the robot's reach ({:.4} {unit}): these data do not support a calibration of \
             this model (joint order, joint units, the tool point?)",
            u.length_from_si(position_rms),
            100.0 * position_rms / reach,
            u.length_from_si(reach),
            unit = u.length.name()
        );
        match worst().filter(|w| w.share > 0.5 && w.pose < self.poses.len()) {
            Some(w) => {
                let joint = self.outlying_joint(w.pose).map_or_else(String::new, |j| {
                    let unit = |k: usize| match model.robot.links[k].joint {
                        JointType::Revolute => u.angle.name(),
                        JointType::Prismatic => u.length.name(),
                    };
                    let angle = |k: usize, v: f64| match model.robot.links[k].joint {
                        JointType::Revolute => u.angle_from_si(v),
                        JointType::Prismatic => u.length_from_si(v),
                    };
                    format!(
                        "; its q{} = {} {} lies outside what the other rows read ({:.4} … {:.4} {})",
                        j.joint + 1,
                        angle(j.joint, self.poses[w.pose].q[j.joint]),
                        unit(j.joint),
                        angle(j.joint, j.others[0]),
                        angle(j.joint, j.others[1]),
                        unit(j.joint)
                    )
                });
                Err(InputError::new(
                    self.file_of(w.pose),
                    self.lines[w.pose],
                    1,
                    format!(
                        "{message}; this row holds {:.0} % of the nominal model's sum of squares \
                         (it misses it by {:.4} {}){joint}: a typo in it? nothing is written",
                        100.0 * w.share,
                        u.length_from_si(w.error),
                        u.length.name()
                    ),
                ))
            }
            None => Err(InputError::new(
                &self.file,
                0,
                0,
                format!("{message}; nothing is written"),
            )),
        }
    }

    /// The joint of pose `pose` whose reading lies farthest outside the
    /// range the other rows read (in units of that range), if one lies
    /// outside it.
    fn outlying_joint(&self, pose: usize) -> Option<OutlyingJoint> {
        let q = &self.poses[pose].q;
        (0..q.len())
            .filter_map(|j| {
                let (lo, hi) = self
                    .poses
                    .iter()
                    .enumerate()
                    .filter(|(i, _)| *i != pose)
                    .map(|(_, p)| p.q[j])
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                        (lo.min(v), hi.max(v))
                    });
                let outside = (lo - q[j]).max(q[j] - hi);
                (lo <= hi && outside > 0.0).then(|| {
                    (
                        outside / (hi - lo).max(f64::MIN_POSITIVE),
                        OutlyingJoint {
                            joint: j,
                            others: [lo, hi],
                        },
                    )
                })
            })
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(_, j)| j)
    }
}

/// The row a model misses most ([`Measurements::require_fit_supported`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WorstRow {
    /// Its pose.
    pub pose: usize,
    /// By how much the model misses it, m.
    pub error: f64,
    /// The share of the model's sum of squares over all the rows it holds.
    pub share: f64,
}

/// A joint reading outside the others' ([`Measurements::outlying_joint`]).
struct OutlyingJoint {
    /// The joint, from 0.
    joint: usize,
    /// The range the other rows read, SI.
    others: [f64; 2],
}

/// The frames a session of several fits on its own
/// ([`Measurements::require_own_frames`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct OwnFrames {
    /// Its own base frame (the instrument's registration).
    base: bool,
    /// Its own tool, and whether its orientation is measured.
    tool: OwnTool,
}

/// A session's own tool, as its rows see it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum OwnTool {
    /// The tool is shared (`--same-tool`).
    Shared,
    /// Its own tool point: 3 unknowns.
    Point,
    /// Its own tool frame, orientations measured: 6 unknowns.
    Frame,
}

/// The fewest distinct poses a session of several needs for the frames
/// `sharing` makes its own, with or without measured `orientation`s: more
/// equations than those frames' unknowns
/// ([`Measurements::require_own_frames`]).
pub fn fewest_poses_of_a_session(sharing: FrameSharing, orientation: bool) -> usize {
    let per_pose = if orientation { 6 } else { 3 };
    (OwnFrames::of(sharing, orientation).unknowns() + 1).div_ceil(per_pose)
}

impl OwnFrames {
    /// The own frames `sharing` gives a session with or without measured
    /// `orientation`s.
    fn of(sharing: FrameSharing, orientation: bool) -> Self {
        Self {
            base: sharing.base == Sharing::PerSession,
            tool: match (sharing.tool, orientation) {
                (Sharing::Shared, _) => OwnTool::Shared,
                (Sharing::PerSession, false) => OwnTool::Point,
                (Sharing::PerSession, true) => OwnTool::Frame,
            },
        }
    }

    /// Their unknowns.
    fn unknowns(self) -> usize {
        let tool = match self.tool {
            OwnTool::Shared => 0,
            OwnTool::Point => 3,
            OwnTool::Frame => 6,
        };
        6 * usize::from(self.base) + tool
    }

    /// `its base frame's 6 and its tool point's 3`.
    fn describe(self) -> String {
        let tool = match self.tool {
            OwnTool::Shared => None,
            OwnTool::Point => Some("its tool point's 3"),
            OwnTool::Frame => Some("its tool frame's 6"),
        };
        match (self.base, tool) {
            (true, Some(t)) => format!("its base frame's 6 and {t}"),
            (true, None) => "its base frame's 6".to_owned(),
            (false, Some(t)) => t.to_owned(),
            (false, None) => "none".to_owned(),
        }
    }

    /// How the session may need fewer: the frames it could share.
    fn share_hint(self) -> &'static str {
        match (self.base, self.tool != OwnTool::Shared) {
            (true, true) => {
                ", or share frames with the others (--same-base, --same-tool) if they did not move"
            }
            (true, false) => {
                ", or share the base frame (--same-base) if the instrument did not move"
            }
            (false, _) => ", or share the tool (--same-tool) if it was not remounted",
        }
    }
}

/// A point far from the others ([`Measurements::beyond_reach`]).
struct FarPoint {
    /// Its pose.
    pose: usize,
    /// Its distance from the median of the points, m.
    distance: f64,
    /// The robot's reach, m.
    reach: f64,
}

/// A length `x` (m) in `units` as an engineer writes it: 1e30 as 1e30, not
/// 31 digits.
fn show(units: &Units, x: f64) -> String {
    let x = units.length_from_si(x);
    if x != 0.0 && !(1e-4..1e6).contains(&x.abs()) {
        format!("{x:e}")
    } else {
        format!("{x}")
    }
}

/// The position columns, x, y, z.
pub(crate) const POSITION: [&str; 3] = ["x", "y", "z"];

/// `1 row`, `2 rows`.
pub(crate) fn plural(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("{n} {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

/// The mean nominal tool point (m, base frame) of the rows of `poses` held
/// to each of `points` fixed points; `None` for a point no row the model
/// can place names.
pub fn nominal_point_means(
    robot: &Robot<f64>,
    poses: &[Observation],
    points: usize,
) -> Vec<Option<Point3<f64>>> {
    let kinematics = robot.prepare();
    let mut sums = vec![(nalgebra::Vector3::zeros(), 0usize); points];
    for p in poses {
        if let (Contact::Point(k), Ok(t)) = (p.contact, kinematics.forward(&p.q))
            && let Some((sum, n)) = sums.get_mut(k)
        {
            *sum += t.translation.vector;
            *n += 1;
        }
    }
    sums.into_iter()
        .map(|(sum, n)| (n > 0).then(|| Point3::from(sum / n as f64)))
        .collect()
}

/// Refuses the distance line `d` when the nominal model puts its two points
/// `nominal` m apart and the stated length contradicts it by far more than
/// a geometric error could: more than a factor of 2 apart and by more than
/// twice [`FIT_LIMIT`] of the robot's `reach` (each point's nominal tool
/// point may miss by that much and the data still carry a calibration). A
/// length unit other than the model's gives a factor of 25.4 or more (mm,
/// in, m): the message names the unit that fits, if one does.
pub fn require_plausible_distance(
    file: &str,
    d: &DistanceLine,
    nominal: f64,
    reach: f64,
    units: &Units,
) -> Result<(), InputError> {
    let (stated, apart) = (d.length, (d.length - nominal).abs());
    let within_factor = |x: f64| x <= 2.0 * nominal && nominal <= 2.0 * x;
    if within_factor(stated) || apart <= 2.0 * FIT_LIMIT * reach {
        return Ok(());
    }
    let unit = units.length;
    let value = units.length_from_si(stated);
    // The unit the written number fits the nominal distance in, if any.
    let hint = armcal_shared::units::LengthUnit::ALL
        .into_iter()
        .filter(|&u| u != unit)
        .find(|&u| {
            let as_u = Units {
                length: u,
                ..*units
            }
            .length_to_si(value);
            within_factor(as_u)
        })
        .map_or_else(
            || "a typo, or the two points' names swapped with others?".to_owned(),
            |u| match u {
                armcal_shared::units::LengthUnit::In => "is the distance in inches?".to_owned(),
                u => format!("is the distance in {}?", u.name()),
            },
        );
    Err(InputError::new(
        file,
        d.length_at.0,
        d.length_at.1,
        format!(
            "distance: {value} {} stated between '{}' and '{}', the nominal model puts them {:.4} \
             {} apart: {hint}",
            unit.name(),
            d.points[0].0,
            d.points[1].0,
            units.length_from_si(nominal),
            unit.name()
        ),
    ))
}
