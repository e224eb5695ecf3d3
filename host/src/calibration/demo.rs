//! `armcal demo`: the whole of armcal on one simulated robot, with no files.
//!
//! 1. The Table 1 PUMA (built-in `puma560`) is given random geometric errors
//!    (±1 mm / ±1 mrad on every D-H, base and tool parameter) and one hidden
//!    effect drawn from the seed: a joint compliance, gear-transmission
//!    harmonics, backlash, an encoder-scale error (each on a drawn joint),
//!    thermal expansion, or a Hayati tilt between axes 2 and 3. Its size is set
//!    by [`crate::calibration::sweep::hidden_case`] so that a geometric fit leaves 8–15× the
//!    noise. A draw the tracker cannot see within the sizes real arms show (an
//!    effect on joint 6, which turns the measured point about itself) is drawn
//!    again, so the demo always hides something visible.
//! 2. A laser-tracker session is simulated ([`crate::calibration::simulate`]: 300 positions,
//!    σ = 20 µm, 20–30 °C, payloads 0 and 5 kg) and diagnosed
//!    ([`crate::calibration::diagnose`], 5-fold cross-validation).
//! 3. Compensation: 50 random poses within the joint limits and away from
//!    singularities (where a millimetre needs a large joint motion, and the
//!    controller bounds the correction) are the targets, each where the nominal
//!    model puts the tool point, `T_nom(q_cmd)`. Each is reached by a short move
//!    (from 0.02 rad away in every joint, from a random side) whose two commands
//!    are compensated with the diagnosis's calibration, effects included
//!    ([`crate::apply::compensate::compensate`]), for the warm, loaded arm (30 °C
//!    and 5 kg, the ends of what the session measured, so that every effect
//!    matters there: the diagnosis refers temperature to the session's mean). The true robot (its geometry and hidden
//!    effects, evaluated as the simulator does, each joint approaching from the
//!    direction of its last move) is sent the nominal commands and then the
//!    compensated ones; the distance of its tool point from the target is the
//!    error.
//!
//! Units: SI inside; the summary prints millimetres (and the effects' parameters
//! in SI); the HTML page is that of `armcal diagnose --html`.

use armcal_shared::compensation::Pacing;
use armcal_shared::compensation::Task;
use armcal_shared::effects::{Approach, Context, Effect, EffectModel};
use armcal_shared::jacobian::at_point;
use armcal_shared::{Calibration, JointType, Robot};
use rand::RngExt;

use crate::calibration::diagnose::{DiagnoseOptions, Diagnosis, diagnose};
use crate::calibration::fit::{FitRequest, effect_parameter_name};
use crate::calibration::simulate::{Session, random_configuration, rng, simulate};
use crate::calibration::sweep::{hidden_case, tracker_diagnosis};
use crate::calibration::validation::folds::HeldOut;
use crate::io::model_file::load_model;
use crate::session::joints::JointRows;
use crate::session::model::RobotModel;

/// Targets the compensation is checked at.
pub const TARGETS: usize = 50;
/// Temperature of the compensated moves, °C: the warm end of the session.
pub const TEMPERATURE: f64 = 30.0;
/// Payload of the compensated moves, kg: the heavier of the session's.
pub const PAYLOAD: f64 = 5.0;
/// Targets are this far from singularities: the smallest singular value of the
/// tool point's position Jacobian, m/rad (a 1 mm error needs at most 10 mrad).
pub const SIGMA_MIN: f64 = 0.1;
/// Each target is approached from a command this far in every joint, rad.
pub const APPROACH: f64 = 0.02;

/// What was hidden in the simulated robot.
#[derive(Clone, Debug)]
pub struct Hidden {
    /// The effect name of `docs/file-formats.md` §6.
    pub name: &'static str,
    /// Its joints, 0-based (empty for thermal expansion).
    pub joints: Vec<usize>,
    /// Its parameters, `name = value unit`, SI.
    pub parameters: String,
}

/// The true robot's tool-point errors at the targets, m.
#[derive(Clone, Copy, Debug)]
pub struct Targets {
    /// Sent the nominal commands.
    pub nominal: HeldOut,
    /// Sent the compensated commands.
    pub compensated: HeldOut,
    /// Targets whose compensation was flagged (bounded, not converged).
    pub flagged: usize,
}

/// Everything the demo did and found.
#[derive(Clone, Debug)]
pub struct Demo {
    /// The seed of every draw.
    pub seed: u64,
    /// The built-in model (the Table 1 PUMA).
    pub model: RobotModel,
    /// What was hidden.
    pub hidden: Hidden,
    /// The simulated session (its `truth` and `effects` are the true robot).
    pub session: Session,
    /// The settings of the diagnosis.
    pub options: DiagnoseOptions,
    /// The diagnosis.
    pub diagnosis: Diagnosis,
    /// The calibration compensated with (geometry and effects).
    pub calibration: Calibration,
    /// The compensation at the targets.
    pub targets: Targets,
}

/// Runs the demo for `seed` (see the module header).
pub fn demo(seed: u64) -> anyhow::Result<Demo> {
    let model = load_model("puma560")?;
    let nominal = &model.robot;
    let options = tracker_diagnosis();
    let mut r = rng(seed);
    let noise_limit = options.fit.position_noise * 3f64.sqrt();
    let mut attempts = 0;
    let (session, hidden) = loop {
        attempts += 1;
        anyhow::ensure!(attempts <= 50, "seed {seed}: no visible effect in 50 draws");
        let kind = r.random_range(0..6);
        let joint = r.random_range(0..nominal.dof());
        let target = r.random_range(8.0..15.0);
        let case_seed = r.random::<u64>();
        let Some((scenario, Some(name), joints)) = hidden_case(
            nominal,
            Some(kind),
            joint,
            target,
            case_seed,
            300,
            &options.fit,
        ) else {
            continue;
        };
        let session = simulate(nominal, &scenario)?;
        let geometric = FitRequest::new(nominal, &session.observations, &options.fit).run()?;
        if geometric.position_rms >= 5.0 * noise_limit {
            let mut parameters: Vec<String> = session
                .effects
                .iter()
                .map(|e| parameters(nominal, e))
                .collect();
            parameters.extend(scenario.tilts.iter().map(|(j, b)| tilt(*j, *b)));
            let parameters = parameters.join(", ");
            break (
                session,
                Hidden {
                    name,
                    joints,
                    parameters,
                },
            );
        }
    };
    let diagnosis = diagnose(nominal, &session.observations, &options)?;
    let calibration = diagnosis.calibration(nominal, Task::Position, model.units);
    let moves = targets(nominal, TARGETS, &mut r)?;
    let targets = compensate_targets(&session, &calibration, &moves)?;
    Ok(Demo {
        seed,
        hidden,
        session,
        options,
        diagnosis,
        calibration,
        targets,
        model,
    })
}

/// The smallest singular value of the tool point's position Jacobian at `q`,
/// m/rad: a position error `e` needs a correction of at most `|e| / σ_min`.
fn sigma_min(robot: &Robot<f64>, q: &[f64]) -> anyhow::Result<f64> {
    let chain = robot.chain(q)?;
    let j = chain.manipulator_jacobian();
    let p = chain.point();
    let m = nalgebra::DMatrix::from_fn(3, robot.dof(), |r, c| at_point(&j.column(c), &p)[r]);
    Ok(m.svd(false, false).singular_values.min())
}

/// `n` random targets within the joint limits of `robot`, away from
/// singularities (`σ_min ≥` [`SIGMA_MIN`]), each with the command it is
/// approached from: [`APPROACH`] away in every joint, from a random side.
fn targets(
    robot: &Robot<f64>,
    n: usize,
    r: &mut rand::rngs::StdRng,
) -> anyhow::Result<Vec<[Vec<f64>; 2]>> {
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let q = random_configuration(robot, r);
        if sigma_min(robot, &q)? < SIGMA_MIN {
            continue;
        }
        let from = q
            .iter()
            .map(|x| {
                x + if r.random::<bool>() {
                    APPROACH
                } else {
                    -APPROACH
                }
            })
            .collect();
        out.push([from, q]);
    }
    Ok(out)
}

/// Sends the true robot of `session` to each target (approached from its
/// starting command, as [`targets`] gives them) with the nominal commands and
/// with the commands compensated with `cal`, and measures how far its tool point
/// lands from where the nominal model puts it.
fn compensate_targets(
    session: &Session,
    cal: &Calibration,
    moves: &[[Vec<f64>; 2]],
) -> anyhow::Result<Targets> {
    let truth = EffectModel::new(session.truth.clone(), &session.effects)?;
    // Where the true robot puts the tool point after the move `sent`, and how far
    // that is from the target of the move `commanded`.
    let miss = |sent: &[Vec<f64>], commanded: &[Vec<f64>]| -> anyhow::Result<f64> {
        // Each joint approaches from the direction of its last move.
        let mut approach = Approach::new();
        let _ = approach.next(&sent[0]);
        let ctx = Context {
            temperature: Some(TEMPERATURE),
            payload: Some(PAYLOAD),
            approach: approach.next(&sent[1]),
        };
        let reached = truth.forward(&sent[1], &ctx)?.translation.vector;
        let target = cal.nominal.forward(&commanded[1])?.translation.vector;
        Ok((reached - target).norm())
    };
    let (mut nominal, mut compensated, mut flagged) = (Vec::new(), Vec::new(), 0);
    for commands in moves {
        let rows = JointRows::commands("demo target", commands, Some(TEMPERATURE), Some(PAYLOAD));
        let result = crate::apply::compensate::compensate(cal, &rows, Pacing::Program);
        flagged += usize::from(result.rows.iter().any(|(_, c)| c.fault.is_some()));
        let sent: Vec<Vec<f64>> = result.rows.iter().map(|(_, c)| c.q.to_vec()).collect();
        nominal.push(miss(commands, commands)?);
        compensated.push(miss(&sent, commands)?);
    }
    Ok(Targets {
        nominal: HeldOut::of(&nominal),
        compensated: HeldOut::of(&compensated),
        flagged,
    })
}

/// The unit of an effect's parameters, SI.
fn unit(robot: &Robot<f64>, e: &Effect<f64>) -> &'static str {
    let prismatic = e.joint().is_some_and(|j| {
        robot
            .links
            .get(j)
            .is_some_and(|l| l.joint == JointType::Prismatic)
    });
    match (e, prismatic) {
        (Effect::JointCompliance { .. }, false) => " rad/(N·m)",
        (Effect::JointCompliance { .. }, true) => " m/N",
        (Effect::GearTransmission { .. } | Effect::Backlash { .. }, false) => " rad",
        (Effect::GearTransmission { .. } | Effect::Backlash { .. }, true) => " m",
        (Effect::ThermalExpansion { .. }, _) => " /°C",
        (Effect::EncoderScale { .. }, _) => "",
    }
}

/// An effect's parameters, `c2 = 1.2e-5 rad/(N·m)`.
fn parameters(robot: &Robot<f64>, e: &Effect<f64>) -> String {
    let unit = unit(robot, e);
    (0..e.parameter_count())
        .map(|i| {
            let v = e.parameter(i).unwrap_or(0.0);
            format!("{} = {v:.2e}{unit}", effect_parameter_name(e, i))
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// A Hayati tilt `β` (rad) of `joint` (0-based).
fn tilt(joint: usize, beta: f64) -> String {
    format!("beta{} = {beta:.2e} rad", joint + 1)
}

/// Joints as a reader counts them: `"joint 2"`, `"joints 2, 3"`, `"all joints"`.
fn joints_text(joints: &[usize]) -> String {
    let list: Vec<String> = joints.iter().map(|j| (j + 1).to_string()).collect();
    match list.len() {
        0 => "all joints".into(),
        1 => format!("joint {}", list[0]),
        _ => format!("joints {}", list.join(", ")),
    }
}

impl Demo {
    /// The diagnosis named the hidden effect first, on its joints.
    pub fn named_hidden(&self) -> bool {
        self.diagnosis.findings.first().is_some_and(|f| {
            f.candidate.name == self.hidden.name && f.candidate.joints == self.hidden.joints
        })
    }

    /// What the diagnosis named, each with its fitted parameters.
    fn named(&self) -> Vec<String> {
        self.diagnosis
            .findings
            .iter()
            .map(|f| {
                let mut fitted: Vec<String> = self
                    .diagnosis
                    .fit
                    .effects
                    .iter()
                    .filter(|e| {
                        f.candidate.effect.is_some_and(|c| {
                            c.name() == e.effect.name() && c.joint() == e.effect.joint()
                        })
                    })
                    .map(|e| parameters(&self.model.robot, &e.effect))
                    .collect();
                fitted.extend(f.candidate.extra.iter().filter_map(|p| {
                    let r = self.diagnosis.fit.params.iter().find(|r| r.param == *p)?;
                    Some(format!("{p} = {:.2e} rad", r.error))
                }));
                format!(
                    "{} on {} ({}), held-out gain ×{:.1}",
                    f.candidate.name,
                    joints_text(&f.candidate.joints),
                    fitted.join(", "),
                    f.gain
                )
            })
            .collect()
    }

    /// The HTML page of `armcal diagnose --html` for the simulated session.
    pub fn html(&self) -> String {
        use crate::calibration::diagnose::report::{ApproachOrder, DiagnoseReport, RowPlaces};
        let rows = &self.session.observations;
        // A simulated row is named by its index.
        let lines: Vec<usize> = (0..rows.len()).collect();
        let report = DiagnoseReport {
            data: format!("simulated by armcal demo --seed {}", self.seed),
            poses: rows.len(),
            diagnosis: self
                .diagnosis
                .report(&self.model, RowPlaces::lines(&lines), &self.options),
            outlier_files: None,
            gravity: None,
            approach_order: ApproachOrder::Rows,
            weights: Default::default(),
            sessions: None,
        };
        crate::calibration::diagnose::html::html(&report, &self.model, &self.diagnosis, rows)
    }

    /// The short summary, ending with where the report was written.
    pub fn summary(&self, report: &str) -> String {
        let mut out = String::new();
        let mm = |x: f64| x * 1e3;
        let d = &self.diagnosis;
        let (nominal, geometric, extended) =
            (d.holdout.nominal, d.holdout.geometric, d.holdout.extended);
        let noise_limit = self.options.fit.position_noise * 3f64.sqrt();
        let mut line = |text: String| {
            out.push_str(&text);
            out.push('\n');
        };
        line(format!(
            "armcal demo --seed {} (another seed draws other errors and another effect)",
            self.seed
        ));
        line(format!(
            "simulated: the Table 1 PUMA ({}), ±1 mm / ±1 mrad geometric errors; {} tracker positions, σ = {:.0} µm, 20–30 °C, payloads 0 and 5 kg",
            self.model.name,
            self.session.observations.len(),
            self.options.fit.position_noise * 1e6
        ));
        line(format!(
            "hidden:    {} on {} ({})",
            self.hidden.name,
            joints_text(&self.hidden.joints),
            self.hidden.parameters
        ));
        let named = self.named();
        if named.is_empty() {
            line("named:     nothing beyond geometry".into());
        }
        for n in named {
            line(format!("named:     {n}"));
        }
        line(format!(
            "geometric model alone: held-out RMS {:.3} mm, {:.1}× the noise limit σ√3 = {:.3} mm",
            mm(geometric.rms),
            geometric.rms / noise_limit,
            mm(noise_limit),
        ));
        let mut tried = d.tried.clone();
        tried.sort_by(|a, b| b.1.total_cmp(&a.1));
        let strongest: Vec<String> = tried
            .iter()
            .take(3)
            .map(|(c, g)| format!("{} {} ×{:.2}", c.name, c.joints_label(), g))
            .collect();
        line(format!(
            "strongest candidates (held-out gain): {}",
            strongest.join("; ")
        ));
        line(String::new());
        line(format!(
            "{:<38} {:>8}  {:>8}",
            "tool-point error", "rms mm", "max mm"
        ));
        let rows = [
            ("held-out, nominal model", nominal),
            ("held-out, geometric calibration", geometric),
            ("held-out, extended calibration", extended),
            ("targets, nominal commands", self.targets.nominal),
            ("targets, compensated commands", self.targets.compensated),
        ];
        for (label, h) in rows {
            line(format!(
                "{label:<38} {:>8.4}  {:>8.4}",
                mm(h.rms),
                mm(h.max)
            ));
        }
        line(format!(
            "held-out: {}-fold cross-validation of the session; targets: {TARGETS} random poses away from",
            self.options.folds
        ));
        line(format!(
            "singularities, the true robot at {TEMPERATURE} °C with {PAYLOAD} kg; compensation flagged {} of them",
            self.targets.flagged
        ));
        line(format!("report: {report}"));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Seed 1: the diagnosis names the effect the simulator hid, on its joints.
    #[test]
    fn demo_names_the_hidden_effect() {
        let d = demo(1).unwrap();
        assert!(
            d.named_hidden(),
            "hidden {:?}, named {:?}",
            d.hidden,
            d.named()
        );
    }
}
