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
//! [`leave_one_out`] is the held-out evaluation: calibrate on every session
//! but one (merged, their points kept apart by name), predict the one left out,
//! for each in turn; beside the nominal model and, optionally, a reference
//! model (another calibration of the same chain) on the same held-out rows.
//! [`Selection`] says how each training set is calibrated: `identify --params
//! full` at the stated prior or at the scale it chooses by cross-validation
//! ([`crate::calibration::identify::prior_scale`]), or the model `armcal
//! diagnose` chooses (its effects applied in the prediction).

use armcal_shared::Robot;
use armcal_shared::effects::EffectModel;
use nalgebra::{Point3, Vector3};

use crate::calibration::diagnose::{DiagnoseOptions, diagnose_session};
use crate::calibration::fit::{FullOptions, PlaneEstimate};
use crate::calibration::identify::prior_scale::PriorScale;
use crate::calibration::identify::{self, IdentifyError, ParamSet};
use crate::io::input_error::InputError;
use crate::io::measurements::{Contact, Measurements};
use crate::io::model_file::RobotModel;

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

/// How a held-out evaluation calibrates each training set.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Selection {
    /// `armcal identify --params full` at the stated prior.
    Stated,
    /// The same at the prior's scale `armcal identify` chooses with `folds`
    /// folds ([`PriorScale::Chosen`]).
    Prior {
        /// Folds of the cross-validation.
        folds: usize,
    },
    /// What `armcal diagnose` chooses with `folds` folds: blunders set aside,
    /// the geometric model and its prior's scale, the effects the data name;
    /// the nominal model when nothing beats it held-out.
    Diagnosis {
        /// Folds of the cross-validation.
        folds: usize,
    },
}

/// One calibration of a training set ([`calibrate`]).
#[derive(Clone, Debug)]
pub struct Calibrated {
    /// The calibrated model, its effects included.
    pub model: EffectModel<f64>,
    /// The RMS distance of the training rows' tool points to their fitted
    /// points (or planes), m.
    pub training_rms: f64,
    /// What was chosen, as reports name it (`prior ×10`; the diagnosis'
    /// model); empty for the stated prior.
    pub choice: String,
}

/// Calibrates `model` on `data` as `selection` says.
pub fn calibrate(
    model: &RobotModel,
    data: &Measurements,
    options: &FullOptions,
    selection: Selection,
) -> Result<Calibrated, IdentifyError> {
    // As identify and diagnose: the masses fitted to measured torques, if
    // any, their sign read from the data.
    let (fitted, _) = crate::calibration::gravity::with_measured_gravity(model, data, None)
        .map_err(IdentifyError::from)?;
    let model = &fitted;
    let identified = |scale: PriorScale| -> Result<Calibrated, IdentifyError> {
        let fit = identify::identify(model, data, ParamSet::Full, options, scale)?;
        Ok(Calibrated {
            model: geometric(&fit.calibrated()),
            training_rms: fit.position_rms,
            choice: match fit.prior.as_ref().map(|c| c.factor()) {
                Some(f) if f != 1.0 => format!("prior ×{f}"),
                _ => String::new(),
            },
        })
    };
    match selection {
        Selection::Stated => identified(PriorScale::Stated),
        Selection::Prior { folds } => identified(PriorScale::Chosen { folds }),
        Selection::Diagnosis { folds } => {
            let options = DiagnoseOptions {
                folds: folds.min(data.len()),
                fit: *options,
                ..DiagnoseOptions::default()
            };
            let d = diagnose_session(&model.robot, &data.poses, &data.constraints, &options)?;
            // The model of the calibration `diagnose --out` writes (the
            // nominal model when nothing beats it held-out).
            let calibration = d.calibration(&model.robot, false, model.units);
            Ok(Calibrated {
                model: calibration.model(),
                training_rms: d.fit.position_rms,
                choice: d.chosen_label(),
            })
        }
    }
}

/// One held-out session of [`leave_one_out`].
#[derive(Clone, Debug)]
pub struct HeldOut {
    /// The session left out (its file).
    pub file: String,
    /// The nominal model's figures on it.
    pub nominal: ContactCheck,
    /// The reference model's, when one is given.
    pub reference: Option<ContactCheck>,
    /// The calibration's from the other sessions.
    pub calibrated: ContactCheck,
    /// The RMS distance of the training rows' tool points to their fitted points, m.
    pub training_rms: f64,
    /// What the calibration chose ([`Calibrated::choice`]).
    pub choice: String,
}

impl HeldOut {
    /// The figures of the nominal model, `reference` and `calibration` on
    /// `held`, the session left out.
    pub fn of(
        held: &Measurements,
        nominal: &Robot<f64>,
        reference: Option<&Robot<f64>>,
        calibration: &Calibrated,
    ) -> Self {
        Self {
            file: held.file.clone(),
            nominal: contact_check(&geometric(nominal), held),
            reference: reference.map(|r| contact_check(&geometric(r), held)),
            calibrated: contact_check(&calibration.model, held),
            training_rms: calibration.training_rms,
            choice: calibration.choice.clone(),
        }
    }
}

/// Refuses `data` unless it is a session without a tracker (its rows name
/// the fixed point or plane their tool point is held to): the held-out
/// figures here need no coordinate, and a file of coordinates has none of
/// them.
pub fn require_session(data: &Measurements) -> Result<(), InputError> {
    if data.is_constrained() {
        return Ok(());
    }
    Err(InputError::new(
        &data.file,
        data.lines.first().copied().unwrap_or(1),
        1,
        "holdout checks sessions without a tracker: the rows must name the unknown fixed \
         point or plane their tool point is held to (a `point` or `plane` column; \
         docs/file-formats.md)",
    ))
}

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

/// The held-out figures of `sessions`, as `armcal holdout` gives them:
/// without `training`, each left out in turn ([`leave_one_out`]); with it,
/// `model` calibrated once on `training` (merged) and each of `sessions`
/// predicted.
pub fn held_out(
    model: &RobotModel,
    sessions: &[Measurements],
    training: &[Measurements],
    reference: Option<&Robot<f64>>,
    options: &FullOptions,
    selection: Selection,
) -> Result<Vec<HeldOut>, IdentifyError> {
    if training.is_empty() {
        return leave_one_out(model, sessions, reference, options, selection);
    }
    let parts: Vec<&Measurements> = training.iter().collect();
    let calibration = calibrate(model, &Measurements::merged(&parts), options, selection)?;
    Ok(sessions
        .iter()
        .map(|s| HeldOut::of(s, &model.robot, reference, &calibration))
        .collect())
}

/// Leaves each of `sessions` out in turn, calibrates `model` on the others
/// as `selection` says (with `options`) and checks the nominal model,
/// `reference` and the calibration on the one left out.
pub fn leave_one_out(
    model: &RobotModel,
    sessions: &[Measurements],
    reference: Option<&Robot<f64>>,
    options: &FullOptions,
    selection: Selection,
) -> Result<Vec<HeldOut>, IdentifyError> {
    let mut out = Vec::new();
    for (i, held) in sessions.iter().enumerate() {
        let training: Vec<&Measurements> = sessions
            .iter()
            .enumerate()
            .filter(|(j, _)| *j != i)
            .map(|(_, s)| s)
            .collect();
        let merged = Measurements::merged(&training);
        let calibration = calibrate(model, &merged, options, selection)?;
        out.push(HeldOut::of(held, &model.robot, reference, &calibration));
    }
    Ok(out)
}

/// The table of [`leave_one_out`], in mm: per held-out session, the spread
/// (RMS over its points) and the worst distance error of each model, and the
/// flatness (RMS over its planes) when a session has planes; `–` where a
/// session has none of that kind.
pub fn holdout_table(rows: &[HeldOut], reference: Option<&str>) -> String {
    use std::fmt::Write as _;
    let planes = rows.iter().any(|r| !r.nominal.planes.is_empty());
    let mut out = String::new();
    let _ = write!(
        out,
        "held-out session: spread of the predicted points (RMS distance to their mean, RMS over the points) \
         and distance error (predicted minus stated)"
    );
    if planes {
        let _ = write!(
            out,
            ", flatness of the predicted touches (RMS distance to their least-squares plane, RMS over the planes)"
        );
    }
    let _ = writeln!(out, ", mm");
    let mut models = vec!["nominal"];
    models.extend(reference);
    models.push("armcal");
    let kinds: &[&str] = if planes {
        &["spread", "distance", "flatness"]
    } else {
        &["spread", "distance"]
    };
    let mut header = format!("  {:<40}", "held out");
    let mut sub = format!("  {:<40}", "");
    for model in models {
        for (i, kind) in kinds.iter().enumerate() {
            let _ = write!(header, " {:>16}", if i == 0 { model } else { "" });
            let _ = write!(sub, " {kind:>16}");
        }
    }
    let _ = writeln!(out, "{header}");
    let _ = writeln!(out, "{sub}");
    let mm = |v: Option<f64>, signed: bool| match v {
        Some(v) if signed => format!(" {:>+16.3}", v * 1e3),
        Some(v) => format!(" {:>16.3}", v * 1e3),
        None => format!(" {:>16}", "–"),
    };
    let figures = |c: &ContactCheck| {
        let mut f = mm(c.spread_rms(), false) + &mm(c.worst_distance_error(), true);
        if planes {
            f.push_str(&mm(c.flatness_rms(), false));
        }
        f
    };
    for r in rows {
        let mut line = format!("  {:<40}", r.file);
        line.push_str(&figures(&r.nominal));
        if let Some(c) = &r.reference {
            line.push_str(&figures(c));
        }
        line.push_str(&figures(&r.calibrated));
        if !r.choice.is_empty() {
            let _ = write!(line, "   ({})", r.choice);
        }
        let _ = writeln!(out, "{line}");
    }
    out
}
