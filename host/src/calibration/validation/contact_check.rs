//! How well a robot model puts its tool point at the fixed points of a session
//! without a tracker: the figures a user can trust with no coordinate measured.
//!
//! For each unknown fixed point of a constraint session (see
//! [`crate::session::constraints`]) the model's tool points of the rows naming it
//! should coincide: their *spread* is the RMS distance of those predicted
//! points to their mean (m). For each unknown plane, the predicted points of
//! its touches should lie on one plane: their *flatness* is their RMS distance
//! to their least-squares plane (m). For each known distance, the distance
//! between the two means less the stated one is the model's *distance error*
//! (m). All in the model's base frame, which the figures do not depend on.
//!
//!
//! [`crate::calibration::holdout`] evaluates calibrations with these figures on
//! sessions left out; [`crate::calibration::validation::acceptance`] judges a
//! calibration on its own rows with them.

use armcal_shared::Robot;
use armcal_shared::effects::EffectModel;
use armcal_shared::units::Units;
use nalgebra::{Point3, Vector3};

use crate::calibration::fit::PlaneEstimate;
use crate::session::measurements::Measurements;
use crate::session::observation::Contact;

/// One point's figures.
#[derive(Clone, Debug)]
pub struct PointSpread {
    /// Its name.
    pub name: String,
    /// The rows naming it.
    pub rows: usize,
    /// The mean of the predicted tool points, base frame, m.
    pub centre: Point3<f64>,
    /// RMS distance of the predicted tool points to their mean, m.
    pub spread: f64,
}

/// One plane's figures.
#[derive(Clone, Debug)]
pub struct PlaneFlatness {
    /// Its name.
    pub name: String,
    /// The rows touching it.
    pub rows: usize,
    /// The least-squares plane of the predicted tool points, base frame.
    pub plane: PlaneEstimate,
    /// RMS distance of the predicted tool points to that plane, m.
    pub flatness: f64,
}

/// One known distance's figures.
#[derive(Clone, Debug)]
pub struct DistanceError {
    /// The two points' names.
    pub points: [String; 2],
    /// The stated distance, m.
    pub stated: f64,
    /// The distance between the predicted centres less the stated one, m.
    pub error: f64,
}

/// What a model predicts of a constraint session.
#[derive(Clone, Debug)]
pub struct ContactCheck {
    /// Per point, in the order of the file.
    pub points: Vec<PointSpread>,
    /// Per plane, in the order of the file.
    pub planes: Vec<PlaneFlatness>,
    /// Per distance line, in the order of the file.
    pub distances: Vec<DistanceError>,
}

impl ContactCheck {
    /// The spreads' RMS over the points (each point's spread squared,
    /// averaged), m; `None` without points.
    pub fn spread_rms(&self) -> Option<f64> {
        rms(self.points.iter().map(|p| p.spread))
    }

    /// The flatness' RMS over the planes, m; `None` without planes.
    pub fn flatness_rms(&self) -> Option<f64> {
        rms(self.planes.iter().map(|p| p.flatness))
    }

    /// The largest distance error in magnitude, signed, m; `None` without
    /// distances.
    pub fn worst_distance_error(&self) -> Option<f64> {
        self.distances
            .iter()
            .map(|d| d.error)
            .reduce(|a, e| if e.abs() > a.abs() { e } else { a })
    }
}

/// A [`ContactCheck`] as the reports give it, lengths in the model's unit:
/// the spreads', flatness' and distance errors' summaries and each point,
/// plane and distance.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ContactCheckReport {
    /// [`ContactCheck::spread_rms`].
    pub spread: Option<f64>,
    /// [`ContactCheck::worst_distance_error`].
    pub distance_error: Option<f64>,
    /// [`ContactCheck::flatness_rms`].
    pub flatness: Option<f64>,
    /// The spread, mm.
    pub spread_mm: Option<f64>,
    /// The distance error, mm.
    pub distance_error_mm: Option<f64>,
    /// The flatness, mm.
    pub flatness_mm: Option<f64>,
    /// Each point.
    pub points: Vec<PointReport>,
    /// Each plane.
    pub planes: Vec<PlaneReport>,
    /// Each known distance.
    pub distances: Vec<DistanceReport>,
}

/// A point's figures in the reports.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PointReport {
    /// Its name.
    pub name: String,
    /// The rows naming it.
    pub rows: usize,
    /// The mean of the predicted tool points, base frame.
    pub centre: Vec<f64>,
    /// Their RMS distance to it.
    pub spread: f64,
}

/// A plane's figures in the reports.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct PlaneReport {
    /// Its name.
    pub name: String,
    /// The rows touching it.
    pub rows: usize,
    /// The least-squares plane's unit normal.
    pub normal: Vec<f64>,
    /// Its distance from the origin.
    pub offset: f64,
    /// The predicted tool points' RMS distance to it.
    pub flatness: f64,
}

/// A known distance's figures in the reports.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct DistanceReport {
    /// The two points' names.
    pub points: [String; 2],
    /// The stated distance.
    pub stated: f64,
    /// The predicted distance less the stated one.
    pub error: f64,
}

impl ContactCheck {
    /// The report of these figures, lengths in `units`.
    pub fn report(&self, units: &Units) -> ContactCheckReport {
        let length = |v: f64| units.length_from_si(v);
        let mm = |v: f64| v * 1e3;
        ContactCheckReport {
            spread_mm: self.spread_rms().map(mm),
            distance_error_mm: self.worst_distance_error().map(mm),
            flatness_mm: self.flatness_rms().map(mm),
            spread: self.spread_rms().map(length),
            distance_error: self.worst_distance_error().map(length),
            flatness: self.flatness_rms().map(length),
            points: self
                .points
                .iter()
                .map(|p| PointReport {
                    name: p.name.clone(),
                    rows: p.rows,
                    centre: p.centre.iter().map(|&x| length(x)).collect(),
                    spread: length(p.spread),
                })
                .collect(),
            planes: self
                .planes
                .iter()
                .map(|p| PlaneReport {
                    name: p.name.clone(),
                    rows: p.rows,
                    normal: p.plane.normal().iter().copied().collect(),
                    offset: length(p.plane.offset),
                    flatness: length(p.flatness),
                })
                .collect(),
            distances: self
                .distances
                .iter()
                .map(|d| DistanceReport {
                    points: d.points.clone(),
                    stated: length(d.stated),
                    error: length(d.error),
                })
                .collect(),
        }
    }
}

/// The RMS of `values`; `None` when there are none.
fn rms(values: impl Iterator<Item = f64>) -> Option<f64> {
    let (n, sum) = values.fold((0usize, 0.0), |(n, s), v| (n + 1, s + v * v));
    (n > 0).then(|| (sum / n as f64).sqrt())
}

/// The spread of `model`'s tool points (its effects included, at each row's
/// context) at each fixed point of `data`, their flatness on each plane and
/// its error of each known distance. Rows whose kinematics fail are left out.
pub fn contact_check(model: &EffectModel<f64>, data: &Measurements) -> ContactCheck {
    let c = &data.constraints;
    let mut predicted: Vec<Vec<Vector3<f64>>> = vec![Vec::new(); c.points.len()];
    let mut touches: Vec<Vec<Vector3<f64>>> = vec![Vec::new(); c.planes.len()];
    for obs in &data.poses {
        let Ok(t) = model.forward(&obs.q, &obs.context) else {
            continue;
        };
        let v = match obs.contact {
            Contact::Point(k) => predicted.get_mut(k),
            Contact::Plane(k) => touches.get_mut(k),
            Contact::Measured => None,
        };
        if let Some(v) = v {
            v.push(t.translation.vector);
        }
    }
    let planes = c
        .planes
        .iter()
        .zip(&touches)
        .map(|(p, v)| {
            let (plane, flatness) = PlaneEstimate::least_squares(v);
            PlaneFlatness {
                name: p.name.clone(),
                rows: v.len(),
                plane,
                flatness,
            }
        })
        .collect();
    let points: Vec<PointSpread> = c
        .points
        .iter()
        .zip(&predicted)
        .map(|(p, v)| {
            let n = v.len().max(1) as f64;
            let centre = v.iter().sum::<Vector3<f64>>() / n;
            let spread = (v.iter().map(|x| (x - centre).norm_squared()).sum::<f64>() / n).sqrt();
            PointSpread {
                name: p.name.clone(),
                rows: v.len(),
                centre: Point3::from(centre),
                spread,
            }
        })
        .collect();
    let distances = c
        .distances
        .iter()
        .map(|d| {
            let [a, b] = d.points.map(|k| &points[k]);
            DistanceError {
                points: [a.name.clone(), b.name.clone()],
                stated: d.length,
                error: (a.centre - b.centre).norm() - d.length,
            }
        })
        .collect();
    ContactCheck {
        points,
        planes,
        distances,
    }
}

/// A robot model without effects, as [`contact_check`] reads it.
pub fn geometric(robot: &Robot<f64>) -> EffectModel<f64> {
    EffectModel {
        robot: robot.clone(),
        effects: heapless::Vec::new(),
    }
}
