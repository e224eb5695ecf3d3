//! Whether a calibration may be written: its fit converged, and it fits its
//! own rows no worse than the nominal model does.
//!
//! A fit that did not converge stopped somewhere on the way (its iterations
//! ran out, or no damping gave a step that lowered the sum of squares): its
//! parameters are not the least-squares answer and its standard errors
//! describe a point that is not the solution. A calibration whose RMS
//! position residual on the very rows it was fitted to is above the nominal
//! model's makes the robot worse where it was measured. Neither is written
//! (`armcal identify` and `diagnose` exit 1 and name the reason), unless the
//! user asks for it (`--write-failed`).
//!
//! The residuals are compared on the same rows, in the same way: for
//! measured coordinates, the distance of each row's predicted tool point to
//! its measured one (and, with full poses, the orientation angle); for a
//! session without a tracker, the distance of each row's predicted tool
//! point to the mean of the predicted points at its fixed point, or to the
//! least-squares plane of the predicted touches of its plane
//! ([`crate::calibration::validation::contact_check`]), each model placing its own
//! points. A full-pose calibration is worse when both its position and its
//! orientation residual are above the nominal's (the fit weighs one against
//! the other). SI inside; the message is in the model's units.

use armcal_shared::Robot;
use armcal_shared::effects::EffectModel;
use armcal_shared::pose_error::rotation_error;

use crate::calibration::fit::session_registrations;
use crate::calibration::parallel;
use crate::calibration::validation::contact_check::{contact_check, geometric};
use crate::session::measurements::Measurements;
use crate::session::observation::Observation;
use crate::session::registration::Registrations;
use crate::session::registration::in_session;
use armcal_shared::units::Units;

/// RMS residuals of one model on a session's rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Residual {
    /// Position (or contact) residual, m.
    pub position: f64,
    /// Orientation angle, rad; `None` without measured orientations.
    pub orientation: Option<f64>,
}

/// The residuals of `model` on the rows of `data` not in `set_aside`
/// (indices into its poses), as the module header says; with several
/// sessions, each row's as its session's `registrations` place the model.
pub fn residual(
    model: &EffectModel<f64>,
    registrations: &Registrations,
    data: &Measurements,
    set_aside: &[usize],
) -> Residual {
    let mut kept = vec![true; data.poses.len()];
    for &i in set_aside {
        if let Some(k) = kept.get_mut(i) {
            *k = false;
        }
    }
    // Read in place: a session of a million positions is not copied.
    let rows = || {
        data.poses
            .iter()
            .zip(&kept)
            .filter(|(_, k)| **k)
            .map(|(p, _)| p)
    };
    if data.is_constrained() {
        let c = if set_aside.is_empty() {
            contact_check(model, data)
        } else {
            let kept = Measurements {
                poses: rows().cloned().collect(),
                ..data.clone()
            };
            contact_check(model, &kept)
        };
        let sum = c
            .points
            .iter()
            .map(|p| p.spread * p.spread * p.rows as f64)
            .chain(
                c.planes
                    .iter()
                    .map(|p| p.flatness * p.flatness * p.rows as f64),
            )
            .sum::<f64>();
        let n = c.points.iter().map(|p| p.rows).sum::<usize>()
            + c.planes.iter().map(|p| p.rows).sum::<usize>();
        return Residual {
            position: if n > 0 { (sum / n as f64).sqrt() } else { 0.0 },
            orientation: None,
        };
    }
    // Sums of squares over fixed chunks of rows, on every core, added in
    // order: the same answer on any number of cores.
    let models = registrations.effect_models(model);
    let prepared: Option<Vec<_>> = model
        .effects
        .is_empty()
        .then(|| models.iter().map(|m| m.robot.prepare()).collect());
    let chunks: Vec<(&[Observation], &[bool])> =
        data.poses.chunks(CHUNK).zip(kept.chunks(CHUNK)).collect();
    let sums = parallel::map_if(chunks.len() > 1, &chunks, |(poses, kept)| {
        let (mut pos, mut rot, mut n, mut n_rot) = (0.0, 0.0, 0usize, 0usize);
        for (obs, _) in poses.iter().zip(*kept).filter(|(_, k)| **k) {
            n += 1;
            let t = match &prepared {
                Some(k) => in_session(k, obs.session).forward(&obs.q).ok(),
                None => in_session(&models, obs.session)
                    .forward(&obs.q, &obs.context)
                    .ok(),
            };
            let Some(t) = t else {
                // A row the model cannot place counts as far off as it can be.
                pos = f64::INFINITY;
                continue;
            };
            pos += (obs.position.coords - t.translation.vector).norm_squared();
            if let Some(q) = obs.orientation {
                rot += rotation_error(&q.to_rotation_matrix(), &t.rotation).norm_squared();
                n_rot += 1;
            }
        }
        (pos, rot, n, n_rot)
    });
    let (pos, rot, n, n_rot) = sums.into_iter().fold((0.0, 0.0, 0, 0), |a, b| {
        (a.0 + b.0, a.1 + b.1, a.2 + b.2, a.3 + b.3)
    });
    Residual {
        position: (pos / n.max(1) as f64).sqrt(),
        orientation: (n_rot > 0).then(|| (rot / n_rot as f64).sqrt()),
    }
}

/// Rows per piece of [`residual`]'s pass: thousands of forward kinematics,
/// far longer than handing a piece to a core.
const CHUNK: usize = 16_384;

/// How a fit ended: what [`verdict`] reads besides the residuals.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ending {
    /// Iterations run.
    pub iterations: usize,
    /// Whether the fit converged.
    pub converged: bool,
    /// The share of the weighted sum of squares the last iteration removed,
    /// `Some(None)` when no step lowered it
    /// ([`crate::calibration::fit::FullFit::last_decrease`]); `None` when the
    /// method does not say (`--params paper`).
    pub last_decrease: Option<Option<f64>>,
}

/// A calibration that is not written: why, for the user.
#[derive(Debug, thiserror::Error)]
#[error("{file}: {reason}; nothing is written ({flag} writes it anyway)")]
pub struct FailedCalibration {
    /// The data file it was fitted to.
    pub file: String,
    /// What failed, with the figures.
    pub reason: String,
    /// The flag (or keyword) that writes it anyway.
    pub flag: &'static str,
}

/// The calibrated model a [`verdict`] judges, and its [`residual`] when the
/// caller has it already (a fit's own RMS, on the same rows, the same way).
#[derive(Clone, Copy, Debug)]
pub struct Judged<'a> {
    /// The model the calibration file holds.
    pub model: &'a EffectModel<f64>,
    /// Where the sessions after the first saw it (empty for one session).
    pub registrations: &'a Registrations,
    /// Its residual on the rows, if known.
    pub residual: Option<Residual>,
}

/// The nominal model's and the calibration's residuals on the same rows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Judgement {
    /// The nominal model's.
    pub nominal: Residual,
    /// The calibration's (the model its file holds).
    pub calibrated: Residual,
}

/// The judgement of a calibration, and why it must not be written, if so.
#[derive(Debug)]
pub struct Verdict {
    /// Both models' residuals on the rows judged.
    pub judgement: Judgement,
    /// Why it must not be written, or `None`.
    pub refusal: Option<FailedCalibration>,
}

/// The nominal `robot` and the `calibrated` model on `data` (its rows but
/// `set_aside`): both residuals, and `None` for the refusal when the fit that
/// `ending` describes converged and the calibration fits the rows no worse
/// than the nominal model, else why it must not be written; `flag` names the
/// way to write it anyway. With several sessions the nominal model is the
/// first session's as it is and each later session's own frames registered
/// to its rows in closed form, as the fit starts.
pub fn verdict(
    robot: &Robot<f64>,
    calibrated: Judged<'_>,
    data: &Measurements,
    set_aside: &[usize],
    ending: Ending,
    units: &Units,
    flag: &'static str,
) -> Verdict {
    let registered = session_registrations(robot, &data.poses, calibrated.registrations);
    let nominal = residual(&geometric(robot), &registered, data, set_aside);
    let ours = calibrated
        .residual
        .unwrap_or_else(|| residual(calibrated.model, calibrated.registrations, data, set_aside));
    let judgement = Judgement {
        nominal,
        calibrated: ours,
    };
    Verdict {
        judgement,
        refusal: refused(judgement, data, ending, units, flag),
    }
}

/// Why a calibration of `judgement` must not be written, if so.
fn refused(
    Judgement {
        nominal,
        calibrated: ours,
    }: Judgement,
    data: &Measurements,
    ending: Ending,
    units: &Units,
    flag: &'static str,
) -> Option<FailedCalibration> {
    let worse = ours.position > nominal.position
        && match (ours.orientation, nominal.orientation) {
            (Some(a), Some(b)) => a > b,
            _ => true,
        };
    if ending.converged && !worse {
        return None;
    }
    let length = |x: f64| format!("{:.6} {}", units.length_from_si(x), units.length);
    let mut figures = format!(
        "RMS residual on its own rows {} calibrated, {} nominal",
        length(ours.position),
        length(nominal.position)
    );
    if let (Some(a), Some(b)) = (ours.orientation, nominal.orientation) {
        figures.push_str(&format!(
            " (orientation {:.6} {} calibrated, {:.6} {} nominal)",
            units.angle_from_si(a),
            units.angle,
            units.angle_from_si(b),
            units.angle
        ));
    }
    let reason = if ending.converged {
        format!(
            "the calibration fits its own data worse than the nominal model: {figures} \
             (the model, the prior or the data's units?)"
        )
    } else {
        let last = match ending.last_decrease {
            Some(None) => {
                "its last iteration found no step that lowers the sum of squares; ".to_owned()
            }
            Some(Some(d)) => format!("its last step lowered the sum of squares by {d:.2e} of it; "),
            None => String::new(),
        };
        format!(
            "the fit did not converge after {} iterations: {last}{figures} \
             (too tight or too loose a prior, --prior-length and --prior-angle?)",
            ending.iterations
        )
    };
    Some(FailedCalibration {
        file: data.file.clone(),
        reason,
        flag,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::simulate::{Scenario, simulate};
    use crate::io::measurements::parse_measurements;
    use crate::io::model_file::load_model;
    use crate::session::model::RobotModel;

    /// The registrations of one session: none.
    static NONE: Registrations = Registrations {
        sessions: Vec::new(),
    };

    /// `model`, its residual to be computed.
    fn judged(model: &EffectModel<f64>) -> Judged<'_> {
        Judged {
            model,
            registrations: &NONE,
            residual: None,
        }
    }

    /// A simulated UR5e session, read as `armcal` reads it.
    fn session() -> (RobotModel, Measurements) {
        let model = load_model("ur5e").unwrap();
        let s = simulate(&model.robot, &Scenario::tracker(60, 3)).unwrap();
        let text = s.to_csv(&model.units, "test");
        let data = parse_measurements(&text, "s.csv", &model).unwrap();
        (model, data)
    }

    /// The same rows, the same measure: the nominal model against itself is
    /// not worse, and a converged fit that moves `a2` by 50 mm away from
    /// what the ±1 mm robot measured is refused as worse than nominal, with
    /// both residuals; a fit that did not converge is refused whatever its
    /// residual, with its iterations and last step.
    #[test]
    fn refuses_a_calibration_worse_than_nominal_or_not_converged() {
        let (model, data) = session();
        let converged = Ending {
            iterations: 3,
            converged: true,
            last_decrease: Some(Some(1e-12)),
        };
        let same = geometric(&model.robot);
        let units = &model.units;
        assert!(
            verdict(
                &model.robot,
                judged(&same),
                &data,
                &[],
                converged,
                units,
                "--f"
            )
            .refusal
            .is_none()
        );
        let mut off = model.robot.clone();
        off.links[1].a += 0.05;
        let failed = verdict(
            &model.robot,
            judged(&geometric(&off)),
            &data,
            &[],
            converged,
            units,
            "--f",
        )
        .refusal
        .expect("worse than nominal");
        let text = failed.to_string();
        assert!(text.contains("worse than the nominal model"), "{text}");
        assert!(
            text.contains("nothing is written (--f writes it anyway)"),
            "{text}"
        );
        let ours = residual(&geometric(&off), &NONE, &data, &[]).position;
        let nominal = residual(&same, &NONE, &data, &[]).position;
        assert!(ours > 10.0 * nominal, "{ours} {nominal}");
        let stuck = Ending {
            iterations: 2,
            converged: false,
            last_decrease: Some(None),
        };
        let text = verdict(&model.robot, judged(&same), &data, &[], stuck, units, "--f")
            .refusal
            .expect("not converged")
            .to_string();
        assert!(
            text.contains("did not converge after 2 iterations: its last iteration found no step"),
            "{text}"
        );
    }

    /// `identify` takes its fit's own RMS for the calibration it writes (no
    /// second pass over the rows): the same figure [`residual`] computes.
    #[test]
    fn the_fits_own_residual_is_the_calibrations() {
        use crate::calibration::fit::FullOptions;
        use crate::calibration::identify::{IdentifyRequest, identify};
        let (model, data) = session();
        let options = FullOptions::default();
        let fit = identify(&model, &data, &IdentifyRequest::new(options)).unwrap();
        let computed = residual(&geometric(&fit.calibrated()), &NONE, &data, &[]).position;
        assert!(
            (computed - fit.position_rms).abs() < 1e-9 * fit.position_rms,
            "{computed} {}",
            fit.position_rms
        );
    }
}
