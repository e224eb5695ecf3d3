//! Configurations: the distinct poses of a session. Two rows are one
//! configuration when they were measured in the same session (each has its
//! own frames) and held to the same contact, every joint reads
//! the same within the encoder's resolution, each joint approached from the
//! same side and the temperature and payload agree. A repeat adds no
//! geometry: every data-sufficiency rule counts configurations. The repeats'
//! spread about their configuration's mean is the pure error, which
//! [`crate::calibration::validation::replicates`] tests the model's lack of fit against.
//!
//! Units: SI (m, rad, °C, kg).

use armcal_shared::{JointType, Robot};
use nalgebra::{Matrix3, Rotation3, UnitQuaternion, Vector3};

use crate::cancel::Cancel;
use crate::session::observation::{Contact, Observation};
use crate::session::rows::Rows;

/// Two readings of a revolute joint closer than this (rad) are one reading:
/// a 17-bit encoder's count is 4.8·10⁻⁵ rad, a 20-bit one's 6·10⁻⁶ rad.
pub const REVOLUTE_RESOLUTION: f64 = 2e-5;

/// Two readings of a prismatic joint closer than this (m) are one reading.
pub const PRISMATIC_RESOLUTION: f64 = 1e-6;

/// Two temperatures closer than this (°C) are one.
pub const TEMPERATURE_RESOLUTION: f64 = 0.1;

/// Two payloads closer than this (kg) are one.
pub const PAYLOAD_RESOLUTION: f64 = 1e-3;

/// Whether two rows approached every joint from the same side, as far as
/// both are known (a session's first row, and a joint not yet moved, has no
/// approach: 0, or none at all).
fn same_approach(a: &[i8], b: &[i8]) -> bool {
    a.iter().zip(b).all(|(x, y)| *x == 0 || *y == 0 || x == y)
}

/// Repeats whose positions spread by less than this (m per axis) are copies
/// of one reading: no instrument reads the same point to a nanometre twice.
pub const IDENTICAL: f64 = 1e-9;

/// The configurations of a session: which rows repeat which.
#[derive(Clone, Debug, PartialEq)]
pub struct Configurations {
    /// Each configuration's rows, in order, the configurations in order of
    /// their first row.
    pub rows: Vec<Vec<usize>>,
}

/// What two rows must share, besides the joints and context, to be one
/// configuration.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scope {
    /// The session and the contact too: one configuration of one measured
    /// point, whose repeats' spread is the pure error ([`Configurations::of`]).
    Measurement,
    /// Nothing else: one configuration of the robot, whatever point or
    /// session measured it ([`Configurations::of_robot`]). A held-out figure
    /// must hold it out whole: the same joints seen through another SMR, or
    /// in another session, predict it as well as itself.
    Robot,
}

/// When two rows are one configuration, for a robot's joint types.
struct Sameness {
    /// Each joint's resolution: rad, or m for a prismatic joint.
    resolution: Vec<f64>,
    scope: Scope,
}

impl Sameness {
    fn of(robot: &Robot<f64>, scope: Scope) -> Self {
        Self {
            scope,
            resolution: robot
                .links
                .iter()
                .map(|l| match l.joint {
                    JointType::Revolute => REVOLUTE_RESOLUTION,
                    JointType::Prismatic => PRISMATIC_RESOLUTION,
                })
                .collect(),
        }
    }

    /// Whether `a` and `b` are one configuration (see the module header).
    fn same(&self, a: &Observation, b: &Observation) -> bool {
        let close = |x: Option<f64>, y: Option<f64>, tol: f64| match (x, y) {
            (Some(x), Some(y)) => (x - y).abs() <= tol,
            (None, None) => true,
            _ => false,
        };
        let measurement = self.scope == Scope::Measurement;
        (!measurement || (a.contact == b.contact && a.session == b.session))
            && a.q.len() == b.q.len()
            && a.q
                .iter()
                .zip(&b.q)
                .zip(&self.resolution)
                .all(|((x, y), r)| (x - y).abs() <= *r)
            && same_approach(&a.context.approach, &b.context.approach)
            && close(
                a.context.temperature,
                b.context.temperature,
                TEMPERATURE_RESOLUTION,
            )
            && close(a.context.payload, b.context.payload, PAYLOAD_RESOLUTION)
    }
}

/// Whether the distinct configurations of `data` give at least `needed`
/// equations (`equations` of each configuration's first row). Rows are taken
/// in order and kept when they repeat none kept before, until the kept ones
/// give enough: a session of distinct poses is decided on its first few rows,
/// one of few configurations read many times in one pass over few kept rows
/// (never a partition of 10⁶ rows, as [`Configurations::of`] makes).
pub fn distinct_equations_reach(
    robot: &Robot<f64>,
    data: &[Observation],
    needed: usize,
    equations: impl Fn(&Observation) -> usize,
) -> bool {
    let sameness = Sameness::of(robot, Scope::Measurement);
    let mut kept: Vec<&Observation> = Vec::new();
    let mut total = 0;
    for o in data {
        if total >= needed {
            break;
        }
        if !kept.iter().any(|k| sameness.same(k, o)) {
            total += equations(o);
            kept.push(o);
        }
    }
    total >= needed
}

impl Configurations {
    /// The configurations of `data` for `robot`'s joint types: of one
    /// measured point in one session each. Once `cancel` is requested the
    /// rows not yet sorted are each a configuration of their own: the
    /// caller's next check drops the whole.
    pub fn of<'a>(robot: &Robot<f64>, data: impl Into<Rows<'a>>, cancel: Cancel) -> Self {
        Self::partition(
            &Sameness::of(robot, Scope::Measurement),
            data.into(),
            cancel,
        )
    }

    /// The configurations of the robot in `data`, whatever point or session
    /// measured them (several SMRs on the flange, sessions that overlap);
    /// `cancel` as [`Configurations::of`] asks it.
    pub fn of_robot<'a>(robot: &Robot<f64>, data: impl Into<Rows<'a>>, cancel: Cancel) -> Self {
        Self::partition(&Sameness::of(robot, Scope::Robot), data.into(), cancel)
    }

    /// For each row, its configuration's index (configurations in order of
    /// their first row).
    pub fn index(&self, rows: usize) -> Vec<usize> {
        let mut index = vec![0; rows];
        for (c, members) in self.rows.iter().enumerate() {
            for &i in members {
                index[i] = c;
            }
        }
        index
    }

    /// `data` partitioned by `sameness`.
    ///
    /// Rows are taken in the order of the joint that varies most; a repeat
    /// lies within the resolution of its configuration there. Each row is
    /// compared with the first row of every configuration within that reach
    /// (not with every repeat, which would make a session of 10⁶ readings of
    /// one pose — a repeatability test — 10¹² comparisons): it joins the
    /// configuration it matches, and joins into one the configurations it
    /// matches several of; it starts a configuration of its own when it
    /// matches none. `cancel` is asked before the sort and every
    /// [`crate::cancel::ROWS`] rows taken; once requested, the rows not taken are
    /// left alone, each its own configuration.
    fn partition(sameness: &Sameness, data: Rows<'_>, cancel: Cancel) -> Self {
        if cancel.requested() {
            // Not even sorted: every row its own configuration.
            return Self {
                rows: (0..data.len()).map(|i| vec![i]).collect(),
            };
        }
        let resolution = &sameness.resolution;
        let spread = |j: usize| {
            let (lo, hi) = data
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), o| {
                    (a.min(o.q[j]), b.max(o.q[j]))
                });
            hi - lo
        };
        let dof = data.first().map_or(0, |o| o.q.len());
        let key = (0..dof).max_by(|&a, &b| spread(a).total_cmp(&spread(b)));
        let mut order: Vec<usize> = (0..data.len()).collect();
        if let Some(j) = key {
            order.sort_by(|&a, &b| data[a].q[j].total_cmp(&data[b].q[j]));
        }
        let mut parent: Vec<usize> = (0..data.len()).collect();
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        // The first row of each configuration so far, in the order taken.
        let mut firsts: Vec<usize> = Vec::new();
        for (taken, &i) in order.iter().enumerate() {
            if cancel.requested_at(taken) {
                break;
            }
            let mut joined: Option<usize> = None;
            let mut merged = Vec::new();
            for (at, &f) in firsts.iter().enumerate().rev() {
                if let Some(j) = key
                    && data[i].q[j] - data[f].q[j] > resolution[j]
                {
                    break;
                }
                if sameness.same(&data[i], &data[f]) {
                    let r = root(&mut parent, f);
                    match joined {
                        None => {
                            parent[i] = r;
                            joined = Some(r);
                        }
                        Some(into) if into != r => {
                            parent[r] = into;
                            merged.push(at);
                        }
                        Some(_) => {}
                    }
                }
            }
            for at in merged {
                firsts.remove(at);
            }
            if joined.is_none() {
                firsts.push(i);
            }
        }
        let mut number = vec![usize::MAX; data.len()];
        let mut rows: Vec<Vec<usize>> = Vec::new();
        for i in 0..data.len() {
            let r = root(&mut parent, i);
            if number[r] == usize::MAX {
                number[r] = rows.len();
                rows.push(Vec::new());
            }
            rows[number[r]].push(i);
        }
        Self { rows }
    }

    /// These configurations less those holding any of the `rows` (sorted).
    pub fn without(&self, rows: &[usize]) -> Self {
        Self {
            rows: self
                .rows
                .iter()
                .filter(|c| c.iter().all(|i| rows.binary_search(i).is_err()))
                .cloned()
                .collect(),
        }
    }

    /// How many distinct configurations.
    pub fn count(&self) -> usize {
        self.rows.len()
    }

    /// Whether some configuration was measured more than once.
    pub fn repeated(&self) -> bool {
        self.rows.iter().any(|r| r.len() > 1)
    }

    /// Whether some configuration of measured positions (rows of `data`) was
    /// measured more than once.
    pub fn measured_repeats<'a>(&self, data: impl Into<Rows<'a>>) -> bool {
        let data = data.into();
        self.rows
            .iter()
            .any(|r| r.len() > 1 && data[r[0]].contact == Contact::Measured)
    }

    /// One observation per configuration: the mean of its rows' joints,
    /// context, position and orientation (the rotation nearest the mean of
    /// the rotation matrices), held to the same contact.
    pub fn means<'a>(&self, data: impl Into<Rows<'a>>) -> Vec<Observation> {
        let data = data.into();
        self.rows
            .iter()
            .map(|rows| {
                let n = rows.len() as f64;
                let mut mean = data[rows[0]].clone();
                if rows.len() == 1 {
                    return mean;
                }
                for (j, q) in mean.q.iter_mut().enumerate() {
                    *q = rows.iter().map(|&i| data[i].q[j]).sum::<f64>() / n;
                }
                mean.position = nalgebra::Point3::from(
                    rows.iter()
                        .map(|&i| data[i].position.coords)
                        .sum::<Vector3<f64>>()
                        / n,
                );
                let average = |f: fn(&Observation) -> Option<f64>| {
                    rows.iter()
                        .map(|&i| f(&data[i]))
                        .sum::<Option<f64>>()
                        .map(|s| s / n)
                };
                mean.context.temperature = average(|o| o.context.temperature);
                mean.context.payload = average(|o| o.context.payload);
                if let Some(rotations) = rows
                    .iter()
                    .map(|&i| {
                        data[i]
                            .orientation
                            .map(|q| q.to_rotation_matrix().into_inner())
                    })
                    .sum::<Option<Matrix3<f64>>>()
                {
                    let r = Rotation3::from_matrix(&(rotations / n));
                    mean.orientation = Some(UnitQuaternion::from_rotation_matrix(&r));
                }
                mean
            })
            .collect()
    }

    /// The pure error of the measured positions: their spread about their
    /// configuration's mean; `None` when no measured configuration repeats,
    /// or when the repeats are identical (within [`IDENTICAL`]: rows copied,
    /// not measured again).
    pub fn pure_error<'a>(&self, data: impl Into<Rows<'a>>) -> Option<PureError> {
        let data = data.into();
        let (mut sum, mut dof, mut repeated) = (0.0, 0usize, 0usize);
        for rows in &self.rows {
            if rows.len() < 2 || data[rows[0]].contact != Contact::Measured {
                continue;
            }
            let mean = rows
                .iter()
                .map(|&i| data[i].position.coords)
                .sum::<Vector3<f64>>()
                / rows.len() as f64;
            sum += rows
                .iter()
                .map(|&i| (data[i].position.coords - mean).norm_squared())
                .sum::<f64>();
            dof += 3 * (rows.len() - 1);
            repeated += 1;
        }
        // Rows copied rather than measured again spread by rounding alone:
        // they show no instrument.
        (dof > 0 && (sum / dof as f64).sqrt() > IDENTICAL).then(|| PureError {
            sigma: (sum / dof as f64).sqrt(),
            dof,
            repeated,
        })
    }

    /// `mean_g(1 / n_g)` over the measured configurations: the share of the
    /// pure-error variance a configuration's mean keeps, on average.
    pub fn mean_inverse_count<'a>(&self, data: impl Into<Rows<'a>>) -> f64 {
        let data = data.into();
        let measured: Vec<usize> = self
            .rows
            .iter()
            .filter(|r| data[r[0]].contact == Contact::Measured)
            .map(Vec::len)
            .collect();
        measured.iter().map(|&n| 1.0 / n as f64).sum::<f64>() / measured.len().max(1) as f64
    }
}

/// The instrument noise the repeats show.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PureError {
    /// One standard deviation per axis, m.
    pub sigma: f64,
    /// Its degrees of freedom, `3 Σ (n_g − 1)`.
    pub dof: usize,
    /// How many configurations were measured more than once.
    pub repeated: usize,
}

#[cfg(test)]
mod tests {
    use super::*;
    use armcal_shared::Link;
    use nalgebra::Point3;

    /// A repeatability test (one pose read 10⁵ times, the encoders jittering
    /// within their resolution) is one configuration, found by comparing each
    /// reading with the configuration's first: in milliseconds, where comparing
    /// every pair of readings took minutes (5·10⁹ comparisons). Beside it, a
    /// pose one resolution step away is another configuration.
    #[test]
    fn a_pose_read_many_times_is_one_configuration_found_in_linear_time() {
        // Six revolute joints with a UR5e's lengths.
        let link = |s: f64, a: f64, alpha: f64| Link::new(JointType::Revolute, 0.0, s, a, alpha);
        let half = std::f64::consts::FRAC_PI_2;
        let links = [
            link(0.1625, 0.0, half),
            link(0.0, -0.425, 0.0),
            link(0.0, -0.3922, 0.0),
            link(0.1333, 0.0, half),
            link(0.0997, 0.0, -half),
            link(0.0996, 0.0, 0.0),
        ];
        let robot = Robot::new(armcal_shared::Convention::Dh, &links).unwrap();
        let q0 = [0.1, -1.2, 1.3, -0.4, 1.5, 0.6];
        let mut data: Vec<Observation> = (0..100_000)
            .map(|i| {
                let jitter = REVOLUTE_RESOLUTION * 0.4 * ((i % 7) as f64 / 6.0 - 0.5);
                let q = q0.iter().map(|v| v + jitter).collect();
                let mut o = Observation::at_contact(q, Contact::Measured);
                o.position = Point3::new(0.5, 0.1, 0.3);
                o
            })
            .collect();
        let mut other = data[0].clone();
        other.q[2] += 3.0 * REVOLUTE_RESOLUTION;
        data.push(other);
        let start = std::time::Instant::now();
        let c = Configurations::of(&robot, &data, Cancel::NEVER);
        assert!(start.elapsed().as_secs_f64() < 5.0, "{:?}", start.elapsed());
        assert_eq!(c.count(), 2);
        assert_eq!(c.rows[0].len(), 100_000);
        assert_eq!(c.rows[1], [100_000]);
    }

    /// Asked to stop, the partition sorts nothing: every row is a
    /// configuration of its own (what the caller's next check drops); never
    /// asked, the repeats are one.
    #[test]
    fn a_partition_asked_to_stop_leaves_every_row_alone() {
        let link = Link::new(JointType::Revolute, 0.0, 0.1, 0.3, 0.0);
        let robot = Robot::new(armcal_shared::Convention::Dh, &[link, link]).unwrap();
        let data: Vec<Observation> = (0..3)
            .map(|_| Observation::at_contact(vec![0.1, 0.2], Contact::Measured))
            .collect();
        assert_eq!(Configurations::of(&robot, &data, Cancel::NEVER).count(), 1);
        let interrupt = crate::cancel::Interrupt::new();
        interrupt.raise();
        for c in [
            Configurations::of(&robot, &data, interrupt.cancel()),
            Configurations::of_robot(&robot, &data, interrupt.cancel()),
        ] {
            assert_eq!(c.rows, [[0], [1], [2]]);
        }
    }
}
