//! `armcal sweep`: how well the diagnosis finds hidden effects, measured over many
//! simulated sessions.
//!
//! Each case draws a robot (PUMA 560, UR5e, UR10e), an effect of the library or a
//! Hayati tilt between nominally parallel axes (or none: pure geometry, one case
//! in five), its joint, a target signal uniform in 5–20× the noise and a seed;
//! scales the effect's magnitude so that the geometric fit leaves that much
//! (residuals grow linearly with a small effect: one trial fit sets the scale);
//! simulates 300
//! (`--poses`) tracker positions (σ = 20 µm, the true robot off nominal by
//! ±1 mm / ±1 mrad on every parameter or by the [`Settings::errors`] asked,
//! 20–30 °C, payloads 0 and 5 kg); runs the diagnosis (5-fold); and records
//! whether the first finding
//! is the hidden effect on its joints, whether anything was named for pure
//! geometry, the signal (geometric held-out RMS over the noise-limited one) and
//! the time. The detection rate is reported over the cases whose signal is at
//! least 5× (the "leaving 5–20× the noise after a geometric fit").
//! [`Settings::effect`] and [`Settings::robots`] keep the draws of every case
//! and replace its effect (not a pure-geometry case's) or its robot.

use std::time::Instant;

use armcal_shared::Robot;
use armcal_shared::effects::Effect;
use rand::RngExt;

use crate::calibration::diagnose::{DiagnoseOptions, diagnose};
use crate::calibration::fit::FullOptions;
use crate::calibration::simulate::{ErrorSizes, Scenario, rng, simulate};

/// One case of the sweep and its outcome.
#[derive(Clone, Debug)]
pub struct Case {
    /// The robot's built-in name.
    pub robot: &'static str,
    /// The hidden effect's name (`None`: pure geometry).
    pub hidden: Option<&'static str>,
    /// Its joints, 0-based.
    pub joints: Vec<usize>,
    /// Geometric held-out RMS over the noise-limited RMS (σ √3).
    pub signal: f64,
    /// What the diagnosis named first, with joints.
    pub found: Option<(&'static str, Vec<usize>)>,
    /// Number of effects named.
    pub named: usize,
    /// Seconds the diagnosis took.
    pub seconds: f64,
}

impl Case {
    /// The hidden effect was named first, on its joints.
    pub fn detected(&self) -> bool {
        self.hidden.is_some()
            && self.found.as_ref().map(|(n, j)| (Some(*n), j)) == Some((self.hidden, &self.joints))
    }
}

/// One case in the report of `armcal sweep --json`: the case with its joints
/// from 1 and whether the hidden effect was detected.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct CaseReport {
    /// The robot's built-in name.
    pub robot: &'static str,
    /// The hidden effect's name (`null`: pure geometry).
    pub hidden: Option<&'static str>,
    /// Its joints, from 1.
    pub joints: Vec<usize>,
    /// Geometric held-out RMS over the noise-limited RMS.
    pub signal: f64,
    /// The effect the diagnosis named first.
    pub found: Option<&'static str>,
    /// Number of effects named.
    pub named: usize,
    /// Seconds the diagnosis took.
    pub seconds: f64,
    /// Whether the hidden effect was named first, on its joints.
    pub detected: bool,
}

impl Case {
    /// The case as `armcal sweep --json` reports it.
    pub fn report(&self) -> CaseReport {
        CaseReport {
            robot: self.robot,
            hidden: self.hidden,
            joints: self.joints.iter().map(|j| j + 1).collect(),
            signal: self.signal,
            found: self.found.as_ref().map(|f| f.0),
            named: self.named,
            seconds: self.seconds,
            detected: self.detected(),
        }
    }
}

/// The names of the hidden effects of a case's `kind` (see [`hidden_case`]), in order.
pub const KINDS: [&str; 6] = [
    "joint_compliance",
    "gear_transmission",
    "backlash",
    "thermal_expansion",
    "encoder_scale",
    "parallel_axis_tilt",
];

/// The simulated session of one case: a hidden effect of `kind` (0 compliance,
/// 1 gear transmission, 2 backlash, 3 thermal expansion, 4 encoder scale, 5 a tilt
/// between the second and third axes; `None` pure geometry) on `joint`, its size
/// scaled so that the geometric fit leaves about `target` times the noise (capped
/// at what real arms show), `poses` tracker positions, `seed`. Returns the scenario,
/// the hidden effect's name and its joints; `None` if the trial fit failed.
pub fn hidden_case(
    nominal: &Robot<f64>,
    kind: Option<usize>,
    joint: usize,
    target: f64,
    seed: u64,
    poses: usize,
    fit: &FullOptions,
) -> Option<(Scenario, Option<&'static str>, Vec<usize>)> {
    hidden_case_in(
        Scenario::tracker(poses, seed),
        nominal,
        kind,
        joint,
        target,
        fit,
    )
}

/// [`hidden_case`] in `scenario` (its poses, seed, the true robot's error
/// sizes, …), the hidden effect added to it.
pub fn hidden_case_in(
    mut scenario: Scenario,
    nominal: &Robot<f64>,
    kind: Option<usize>,
    joint: usize,
    target: f64,
    fit: &FullOptions,
) -> Option<(Scenario, Option<&'static str>, Vec<usize>)> {
    let seed = scenario.seed;
    // Unit-size starting shapes; the scaling below sets the size.
    let (hidden, joints): (Option<&'static str>, Vec<usize>) = match kind {
        Some(0) => {
            scenario.effects.push(Effect::JointCompliance {
                joint,
                compliance: 3e-6,
            });
            (Some("joint_compliance"), vec![joint])
        }
        Some(1) => {
            let a = 2e-4;
            scenario.effects.push(Effect::GearTransmission {
                joint,
                first: [a, -a / 2.0],
                second: [a / 3.0, 0.0],
            });
            (Some("gear_transmission"), vec![joint])
        }
        Some(2) => {
            scenario.effects.push(Effect::Backlash {
                joint,
                half_lost_motion: 2e-4,
            });
            (Some("backlash"), vec![joint])
        }
        Some(3) => {
            scenario.effects.push(Effect::ThermalExpansion {
                coefficient: 2.3e-5,
                reference: 20.0,
            });
            (Some("thermal_expansion"), vec![])
        }
        Some(4) => {
            scenario
                .effects
                .push(Effect::EncoderScale { joint, scale: 2e-4 });
            (Some("encoder_scale"), vec![joint])
        }
        Some(_) => {
            scenario
                .tilts
                .push((1, if seed.is_multiple_of(2) { 1e-3 } else { -1e-3 }));
            (Some("parallel_axis_tilt"), vec![1, 2])
        }
        None => (None, vec![]),
    };
    if hidden.is_none() {
        return Some((scenario, hidden, joints));
    }
    // Scale the effect so that the geometric fit leaves the target signal: the
    // effect's share of the residual, √(rms² − 3σ²), is linear in its size.
    let noise_rms = scenario.position_noise * 3f64.sqrt();
    let trial = simulate(nominal, &scenario).ok()?;
    let geometric = crate::calibration::fit::FitRequest::new(nominal, &trial.observations, fit)
        .run()
        .ok()?;
    let effect_rms = (geometric.position_rms.powi(2) - noise_rms.powi(2))
        .max(1e-18)
        .sqrt();
    let k = noise_rms * (target * target - 1.0).sqrt() / effect_rms;
    // Within what a real arm shows: an effect that would need more to be seen (a
    // joint whose axis runs near the measured point) stays weak, and its case
    // counts below 5× instead of as a miss.
    for e in scenario.effects.iter_mut() {
        let cap = match e {
            Effect::JointCompliance { .. } => 5e-5,
            Effect::ThermalExpansion { .. } => 1e-4,
            _ => 2e-3,
        };
        let largest = (0..e.parameter_count())
            .filter_map(|c| e.parameter(c))
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let k = k.min(cap / largest.max(f64::MIN_POSITIVE));
        for c in 0..e.parameter_count() {
            if let Some(v) = e.parameter_mut(c) {
                *v *= k;
            }
        }
    }
    for t in scenario.tilts.iter_mut() {
        t.1 = (t.1 * k).clamp(-1e-2, 1e-2);
    }
    Some((scenario, hidden, joints))
}

/// The diagnosis settings for a simulated tracker session
/// ([`Scenario::tracker`], σ = 20 µm): 5-fold cross-validation.
pub fn tracker_diagnosis() -> DiagnoseOptions {
    DiagnoseOptions {
        folds: 5,
        fit: FullOptions {
            position_noise: Scenario::tracker(0, 0).position_noise,
            ..FullOptions::default()
        },
        ..DiagnoseOptions::default()
    }
}

/// The robots a sweep draws from, by their built-in names.
pub const ROBOTS: [&str; 3] = ["puma560", "ur5e", "ur10e"];

/// What a sweep runs.
#[derive(Clone, Debug)]
pub struct Settings {
    /// Cases to run.
    pub cases: usize,
    /// Seed of every draw.
    pub seed: u64,
    /// Tracker positions per simulated session.
    pub poses: usize,
    /// How far each true robot is off nominal.
    pub errors: ErrorSizes,
    /// Only this hidden effect (an index into [`KINDS`]), in place of the one
    /// each case draws; pure-geometry cases stay so. `None`: every kind.
    pub effect: Option<usize>,
    /// Only these robots (indices into [`ROBOTS`]): a case's draw among the
    /// three picks one of these in turn. Empty: all three.
    pub robots: Vec<usize>,
}

impl Settings {
    /// `cases` cases of `poses` positions from `seed`, every kind and robot,
    /// ±1 mm / ±1 mrad.
    pub fn new(cases: usize, seed: u64, poses: usize) -> Self {
        Self {
            cases,
            seed,
            poses,
            errors: ErrorSizes::default(),
            effect: None,
            robots: Vec::new(),
        }
    }
}

/// Runs `cases` cases of `poses` positions each from `seed`; `progress` is
/// called after each.
pub fn sweep(
    cases: usize,
    seed: u64,
    poses: usize,
    progress: impl FnMut(usize, &Case),
) -> Vec<Case> {
    sweep_with(&Settings::new(cases, seed, poses), progress)
}

/// Runs the sweep `settings` asks; `progress` is called after each case.
/// Every case draws its robot, effect, joint, target and seed as
/// [`sweep`] does, whatever the settings keep of them, so that a sweep
/// restricted to one effect runs the same sessions but for the effect.
pub fn sweep_with(settings: &Settings, mut progress: impl FnMut(usize, &Case)) -> Vec<Case> {
    let robots: Vec<(&'static str, Robot<f64>)> = ROBOTS
        .into_iter()
        .filter_map(|n| {
            crate::io::model_file::load_model(n)
                .ok()
                .map(|m| (n, m.robot))
        })
        .collect();
    let (cases, seed, poses) = (settings.cases, settings.seed, settings.poses);
    let mut r = rng(seed);
    let options = tracker_diagnosis();
    let mut out = Vec::with_capacity(cases);
    for i in 0..cases {
        let drawn = r.random_range(0..robots.len());
        let robot = match settings.robots.as_slice() {
            [] => drawn,
            only => only[drawn % only.len()],
        };
        let Some((name, nominal)) = robots.get(robot) else {
            continue;
        };
        // PUMA in SI is a 1 m class arm like the others; the UR and PUMA axes 2, 3
        // are nominally parallel (tilt candidates).
        let kind = if i % 5 == 4 {
            None
        } else {
            let drawn = r.random_range(0..6);
            Some(settings.effect.unwrap_or(drawn))
        };
        let joint = r.random_range(0..nominal.dof());
        let target: f64 = r.random_range(5.0..20.0);
        let case_seed = seed.wrapping_mul(1000).wrapping_add(i as u64);
        let scenario = Scenario {
            errors: settings.errors,
            ..Scenario::tracker(poses, case_seed)
        };
        let Some((scenario, hidden, joints)) =
            hidden_case_in(scenario, nominal, kind, joint, target, &options.fit)
        else {
            continue;
        };
        let Ok(session) = simulate(nominal, &scenario) else {
            continue;
        };
        let started = Instant::now();
        let Ok(d) = diagnose(nominal, &session.observations, &options) else {
            continue;
        };
        let seconds = started.elapsed().as_secs_f64();
        let case = Case {
            robot: name,
            hidden,
            joints,
            signal: d.holdout.geometric.rms / (20e-6 * 3f64.sqrt()),
            found: d
                .findings
                .first()
                .map(|f| (f.candidate.name, f.candidate.joints.clone())),
            named: d.findings.len(),
            seconds,
        };
        progress(i, &case);
        out.push(case);
    }
    out
}

/// The rates of a sweep ([`rates`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rates {
    /// Hidden effects named, of the cases with an effect and signal ≥ 5×.
    pub detected: usize,
    /// The cases with an effect and signal ≥ 5×.
    pub strong: usize,
    /// Pure-geometry cases in which an effect was named.
    pub false_positives: usize,
    /// The pure-geometry cases.
    pub pure: usize,
    /// The mean seconds per diagnosis.
    pub seconds: f64,
}

/// The detection and false-positive rates of `cases`, and the mean time of a
/// diagnosis.
pub fn rates(cases: &[Case]) -> Rates {
    let strong: Vec<&Case> = cases
        .iter()
        .filter(|c| c.hidden.is_some() && c.signal >= 5.0)
        .collect();
    let pure: Vec<&Case> = cases.iter().filter(|c| c.hidden.is_none()).collect();
    Rates {
        detected: strong.iter().filter(|c| c.detected()).count(),
        strong: strong.len(),
        false_positives: pure.iter().filter(|c| c.named > 0).count(),
        pure: pure.len(),
        seconds: cases.iter().map(|c| c.seconds).sum::<f64>() / cases.len().max(1) as f64,
    }
}
