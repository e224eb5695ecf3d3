//! `holdout`: sessions without a tracker, each left out in turn (or each
//! predicted from training sessions), as
//! [`crate::calibration::holdout::held_out`] computes it, with the
//! sessions checked the same way whichever front end asks.
//!
//! Scales are in the model's units as the user states them; the figures are
//! SI.

use super::{Argument, Front, fit_options};
use crate::calibration::fit::FullOptions;
use crate::calibration::holdout::{self, HeldOut, HeldOutReport, Selection};
use crate::calibration::identify::StatedScales;
use crate::calibration::validation::contact_check::ContactCheckReport;
use crate::calibration::validation::folds::DEFAULT_FOLDS;
use crate::cancel::Cancel;
use crate::session::input_error::InputError;
use crate::session::measurements::Measurements;
use crate::session::model::RobotModel;

/// How each training set is calibrated.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Calibrate {
    /// `identify` at the stated prior (`--prior-scale stated`).
    Stated,
    /// `identify` at the prior's scale it chooses (its default).
    Prior,
    /// What `diagnose` chooses (`--diagnose`).
    Diagnosis,
}

impl Calibrate {
    /// The selection of [`holdout::held_out`], with the default folds
    /// of the cross-validations.
    pub fn selection(self) -> Selection {
        let folds = DEFAULT_FOLDS;
        match self {
            Self::Stated => Selection::Stated,
            Self::Prior => Selection::Prior { folds },
            Self::Diagnosis => Selection::Diagnosis { folds },
        }
    }
}

/// What `holdout` is asked.
#[derive(Clone, Copy, Debug)]
pub struct Request {
    /// How each training set is calibrated.
    pub calibrate: Calibrate,
    /// The noise and prior scales stated (model units).
    pub scales: StatedScales,
    /// The caller's request to stop, asked at the computation's step
    /// boundaries ([`crate::cancel`]); [`Cancel::NEVER`] on the
    /// command line, which SIGINT ends.
    pub cancel: Cancel,
}

/// The sessions of a `holdout`, each read and accepted as a session without
/// a tracker ([`Measurements::require_contacts`]).
#[derive(Clone, Copy, Debug)]
pub struct Sessions<'a> {
    /// The sessions left out (or predicted), each in turn.
    pub held_out: &'a [Measurements],
    /// The sessions trained on instead, when given.
    pub training: &'a [Measurements],
    /// Another model of the same chain checked on the same rows.
    pub reference: Option<&'a RobotModel>,
}

/// The held-out figures of every session: refused when the sessions cannot
/// make a holdout ([`require_sessions`]) or a scale is not positive.
pub fn run(
    front: Front,
    model: &RobotModel,
    sessions: Sessions<'_>,
    request: &Request,
) -> anyhow::Result<Vec<HeldOut>> {
    require_sessions(front, model, sessions)?;
    let options = FullOptions {
        cancel: request.cancel,
        ..fit_options(front, model, &request.scales)?
    };
    let reference = sessions.reference.map(|r| &r.robot);
    let held_out = holdout::held_out(
        model,
        sessions.held_out,
        sessions.training,
        reference,
        &options,
        request.calibrate.selection(),
    )?;
    // What a computation asked to stop part way found is not returned.
    request.cancel.check()?;
    Ok(held_out)
}

/// `holdout`'s sessions: two or more to leave out in turn unless training
/// sessions are given, none given twice among both, and a reference model
/// (when given) of as many joints as `model`.
pub fn require_sessions(
    front: Front,
    model: &RobotModel,
    sessions: Sessions<'_>,
) -> Result<(), InputError> {
    let Sessions {
        held_out,
        training,
        reference,
    } = sessions;
    crate::session::distinct::require_distinct(
        &held_out.iter().chain(training).collect::<Vec<_>>(),
        crate::session::distinct::HOLDOUT_TWICE,
    )?;
    if training.is_empty() && held_out.len() < 2 {
        return Err(Argument::Sessions.refused(
            front,
            format!(
                "give two or more sessions to leave out in turn, or the training sessions with {}",
                Argument::Training.given(front)
            ),
        ));
    }
    if let Some(r) = reference
        && r.robot.dof() != model.robot.dof()
    {
        return Err(Argument::Reference.refused(
            front,
            format!(
                "{} joints, the model has {}",
                r.robot.dof(),
                model.robot.dof()
            ),
        ));
    }
    Ok(())
}

/// The table of [`crate::calibration::holdout::held_out`], rendered from
/// its reports ([`HeldOut::report`], Python's dicts), in mm: per held-out
/// session, the spread (RMS over its points) and the worst distance error of
/// each model, and the flatness (RMS over its planes) when a session has
/// planes; `–` where a session has none of that kind.
pub fn holdout_table(rows: &[HeldOutReport], reference: Option<&str>) -> String {
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
        Some(v) if signed => format!(" {v:>+16.3}"),
        Some(v) => format!(" {v:>16.3}"),
        None => format!(" {:>16}", "–"),
    };
    let figures = |c: &ContactCheckReport| {
        let mut f = mm(c.spread_mm, false) + &mm(c.distance_error_mm, true);
        if planes {
            f.push_str(&mm(c.flatness_mm, false));
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
