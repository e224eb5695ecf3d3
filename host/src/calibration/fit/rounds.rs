//! The fit itself, as [`super::FitRequest::run`] runs it: the unknowns of
//! one fit ([`Unknowns`]: what the model frees, what it holds and why, the
//! equation count), the start, then the fit's state ([`Fit`]: the model, the
//! noise of each channel, the counters) stepped through its rounds —
//! selection, Levenberg–Marquardt, the variance components or the reselection
//! at a stated noise the residuals show larger — and the report of the
//! solution (standard errors, condition number, observability O1 of Borm &
//! Menq, correlations, each parameter's status). SI units throughout (m, rad);
//! rows in units of their noise. See the parent module's "Identifiability",
//! "Solution" and "Report".

use std::collections::HashMap;

use armcal_shared::effects::Effect;
use armcal_shared::{FrameAxis, Param, Robot};
use faer::Side;
use nalgebra::{Matrix3, Point3, Rotation3, Vector3};

use super::initial::{initial_base_tool, initial_points_tool, session_registrations};
use super::noise::{ChannelNoise, NoiseEstimate, NoiseSource, SETTLED, Weights};
use super::rows::{LinearSystem, NormalEquations};
use super::selection::{constrained_subset, separable_subset};
use super::solve::{levenberg_marquardt, wrap_angle};
use super::{
    Constraints, EffectFit, FullError, FullFit, FullOptions, MAX_NOISE_ROUNDS, Model, ParamResult,
    PlaneEstimate, PlaneFit, PointFit, Posterior, Registrations, SessionFit, Status, Unknown,
    channel_weights, full_params, independent_parameter_count, prior_reach, prior_terms,
};
use crate::session::channel::Weighed;
use crate::session::channel::{Channel, PerChannel};
use crate::session::observation::session_count;
use crate::session::prior::Prior;
use crate::session::rows::Rows;

/// Refuses data the fit cannot read: rows at points or planes the
/// constraints do not name, effects on joints the model lacks, poses with
/// another joint count.
pub(super) fn check_inputs(
    nominal: &Robot<f64>,
    effects: &[Effect<f64>],
    data: Rows<'_>,
    constraints: &Constraints,
) -> Result<(), FullError> {
    if let Some(i) = data.iter().position(|o| {
        o.fixed_point()
            .is_some_and(|k| k >= constraints.points.len())
            || o.on_plane().is_some_and(|k| k >= constraints.planes.len())
    }) {
        return Err(FullError::ConstraintsMissing { pose: i + 1 });
    }
    if let Some(joint) = effects
        .iter()
        .filter_map(|e| e.joint())
        .find(|j| *j >= nominal.dof())
    {
        return Err(FullError::EffectJoint { joint: joint + 1 });
    }
    for (i, obs) in data.iter().enumerate() {
        if obs.q.len() != nominal.dof() {
            return Err(FullError::JointCount {
                pose: i + 1,
                expected: nominal.dof(),
                got: obs.q.len(),
            });
        }
    }
    Ok(())
}

/// The unknowns of one fit: the parameters reported, those the model holds
/// and why, those it frees (in the order of preference), and the equations.
pub(super) struct Unknowns {
    /// Every parameter of the full model and the extra tilts, in the report's order.
    all: Vec<Param>,
    /// The parameters the chosen geometry (or a session without coordinates)
    /// holds at nominal, with the reason.
    held_by_model: Vec<(Unknown, String)>,
    /// The unknowns the model frees: points and planes, parameters, effects.
    params: Vec<Unknown>,
    /// Equations: the rows and the known distances.
    equations: usize,
    /// Whether any row measures an orientation.
    orientation: bool,
    /// Whether the rows sit at unknown points or planes (`constraints` not empty).
    constrained: bool,
    /// The sessions whose frames are their own, each beside the first's
    /// (1: one session, or sessions that share every frame).
    sessions: usize,
}

impl Unknowns {
    /// The unknowns of the fit of `nominal` with `effects` and the `extra`
    /// parameters to `data`; too few equations for the model's independent
    /// parameters (Everett, Driels & Mooring) is an error.
    pub(super) fn of(
        nominal: &Robot<f64>,
        effects: &[Effect<f64>],
        extra: &[Param],
        data: Rows<'_>,
        constraints: &Constraints,
        options: &FullOptions,
    ) -> Result<Self, FullError> {
        let constrained = !constraints.is_empty();
        let orientation = data.iter().any(|o| o.orientation.is_some());
        // Every parameter of the full model and the extra tilts; the chosen geometry
        // frees some of the model's, the others are held at nominal.
        let all: Vec<Param> = full_params(nominal, orientation)
            .into_iter()
            .chain(extra.iter().copied())
            .collect();
        // Without a measured coordinate the base frame is arbitrary: the fixed
        // points are found in whatever frame the base sets.
        let base_unobservable = |p: &Param| constrained && matches!(p, Param::Base(_));
        let frees = |p: &Param| {
            (options.geometry.frees(nominal, *p) || extra.contains(p)) && !base_unobservable(p)
        };
        let held_by_model: Vec<(Unknown, String)> = all
            .iter()
            .filter(|p| !frees(p))
            .map(|p| {
                let reason = if base_unobservable(p) {
                    "not observable: the data measure no coordinate (only unknown fixed points \
                     and distances between them), so the base frame is arbitrary; held at nominal"
                        .to_owned()
                } else {
                    format!(
                        "held at nominal: the {} model does not free it",
                        options.geometry.name()
                    )
                };
                (Unknown::Param(*p), reason)
            })
            .collect();
        let point_unknowns = (0..constraints.points.len())
            .flat_map(|point| (0..3).map(move |axis| Unknown::Point { point, axis }))
            .chain((0..constraints.planes.len()).flat_map(|plane| {
                (0..3).map(move |component| Unknown::Plane { plane, component })
            }));
        // Sessions of measured coordinates after the first: their own frames,
        // after the model's (sessions of contacts share theirs).
        let sessions = if constrained { 1 } else { session_count(data) };
        let is_frame = |p: &&Param| matches!(p, Param::Base(_) | Param::Tool(_));
        let own_frames: Vec<Param> = all
            .iter()
            .filter(|p| is_frame(p) && frees(p) && options.sessions.per_session(**p))
            .copied()
            .collect();
        let session_unknowns = (1..sessions).flat_map(|session| {
            own_frames
                .iter()
                .map(move |&param| Unknown::Session { session, param })
        });
        let free = all.iter().filter(|p| frees(p));
        let mut params: Vec<Unknown> = point_unknowns
            .chain(free.clone().filter(is_frame).map(|p| Unknown::Param(*p)))
            .chain(session_unknowns)
            .chain(free.filter(|p| !is_frame(p)).map(|p| Unknown::Param(*p)))
            .collect();
        let sessions = if own_frames.is_empty() { 1 } else { sessions };
        for (effect, e) in effects.iter().enumerate() {
            params.extend(
                (0..e.parameter_count()).map(|component| Unknown::Effect { effect, component }),
            );
        }
        // However the columns happen to fall, fewer equations than the model's
        // independent parameters (Everett, Driels & Mooring) cannot determine it.
        let equations = LinearSystem::rows(data) + constraints.equations();
        let mut unknowns =
            independent_parameter_count(nominal, data.iter().all(|o| o.orientation.is_some()));
        if constrained {
            // No base (6), three coordinates per point.
            unknowns = (unknowns + 3 * constraints.points.len() + 3 * constraints.planes.len())
                .saturating_sub(6);
        }
        unknowns += (sessions - 1) * own_frames.len();
        if equations < unknowns {
            return Err(FullError::TooFewEquations {
                equations,
                unknowns,
            });
        }
        Ok(Self {
            all,
            held_by_model,
            params,
            equations,
            orientation,
            constrained,
            sessions,
        })
    }

    /// The model the fit starts from: `start` (else `nominal`) with `effects`,
    /// for a constraint session the points, planes and tool estimated from
    /// the rows, else the closed-form base and tool unless a start is given;
    /// what the model holds is nominal.
    pub(super) fn initial_model(
        &self,
        nominal: &Robot<f64>,
        start: Option<&Robot<f64>>,
        effects: &[Effect<f64>],
        data: Rows<'_>,
        constraints: &Constraints,
        options: &FullOptions,
    ) -> Model {
        let mut robot = Model::of(start.unwrap_or(nominal).clone(), effects.to_vec());
        if self.constrained {
            robot.constraints = constraints.clone();
            robot.points = vec![Point3::origin(); constraints.points.len()];
            robot.planes = vec![
                PlaneEstimate::through(&Point3::origin(), &Vector3::z());
                constraints.planes.len()
            ];
            initial_points_tool(
                &mut robot,
                data,
                options.initial_estimate && start.is_none(),
            );
        } else if self.sessions > 1 {
            self.initial_registrations(&mut robot, start.is_none(), data, options);
        } else if options.initial_estimate && start.is_none() {
            initial_base_tool(&mut robot.robot, data);
        }
        // What this model does not free is nominal, whatever the start.
        for (u, _) in &self.held_by_model {
            if let (Unknown::Param(p), Some(v)) = (u, robot.get_mut(*u))
                && let Some(n) = nominal.param(*p)
            {
                *v = n;
            }
        }
        robot
    }

    /// Each session's own frames in closed form with the start's joints (the
    /// first session's, the model's, on its own rows and only when
    /// `model_frames`: a start's frames are kept).
    fn initial_registrations(
        &self,
        model: &mut Model,
        model_frames: bool,
        data: Rows<'_>,
        options: &FullOptions,
    ) {
        let shape = Registrations::of(&model.robot, self.sessions, options.sessions);
        if !options.initial_estimate {
            model.registrations = shape;
            return;
        }
        if model_frames {
            let first = data.positions_of((0..data.len()).filter(|&i| data[i].session == 0));
            initial_base_tool(&mut model.robot, Rows::picked(data.all(), &first));
        }
        model.registrations = session_registrations(&model.robot, data, &shape);
    }
}

/// The state of the fit across its rounds: identifiability at the nominal
/// link geometry ([`Fit::structure`]); the fit from the initial estimate;
/// then, for an estimated noise, the variance components and the fit again
/// with their weights until they settle. A stated noise is kept, but when the
/// fit shows it significantly larger the selection is made again with the
/// noise the residuals show.
pub(super) struct Fit<'a> {
    nominal: &'a Robot<f64>,
    data: Rows<'a>,
    constraints: &'a Constraints,
    options: &'a FullOptions,
    unknowns: Unknowns,
    /// The initial estimate: where the held base, tool, effects, points and
    /// planes stay.
    start: Model,
    /// Where the selection of the separable unknowns is made, whatever the
    /// fit starts from: the start with its links' D-H parameters (and
    /// tilts) at their nominal values. Which link parameters the data can separate is
    /// a property of the model's structure: at two nominally parallel
    /// axes `s` of the later link does exactly what `s` of the earlier one
    /// does (Hayati's reason for `β`), but at an estimate whose twist
    /// between them is off by `ε` the two differ by `ε²` of their norm,
    /// which passes the test from about a mrad (`ε² > 10⁻⁶`). Freed there,
    /// `s` of the later link makes the pair's D-H parameters a complete
    /// description of two skew axes: the tilt `β` between them is then in
    /// their span, held as inseparable, and the fit's selection would
    /// change with how far the start lies from nominal.
    structure: Model,
    /// Whether `start` is `structure` (a fit from the nominal model): the
    /// first round's linearisation at the start then serves the selection.
    start_is_structure: bool,
    /// The current estimate.
    robot: Model,
    /// The channels the data have rows in.
    present: PerChannel<bool>,
    /// The channels whose noise is estimated (present and not stated).
    estimate: PerChannel<bool>,
    /// The noise each channel's rows are divided by, m or rad.
    noise: PerChannel<f64>,
    /// The factor of the stated noise the selection assumes (1, or the root of
    /// the variance factor once the fit showed it significantly larger).
    noise_scale: f64,
    /// Levenberg–Marquardt iterations, all rounds.
    iterations: usize,
    /// Rounds: selections and reweightings.
    round: usize,
}

/// A round's solution: the free unknowns and the held ones (with why), how
/// Levenberg–Marquardt ended, the linearisation at the solution, the prior
/// of the free unknowns and the posterior.
struct Solution {
    free_params: Vec<Unknown>,
    fixed: Vec<(Unknown, String)>,
    converged: bool,
    last_decrease: Option<f64>,
    sys: NormalEquations,
    prior: Vec<(f64, f64)>,
    post: Posterior,
}

/// The statistics at the solution.
struct Statistics {
    variance_factor: f64,
    condition_number: f64,
    observability: f64,
    prior_reach: f64,
    correlations: Vec<(String, String, f64)>,
    /// The standard error of each free unknown (NaN without a covariance).
    std_of: Vec<f64>,
}

impl<'a> Fit<'a> {
    /// The fit of `unknowns` to `data` from `robot`, at the options' noise.
    pub(super) fn new(
        nominal: &'a Robot<f64>,
        data: Rows<'a>,
        constraints: &'a Constraints,
        options: &'a FullOptions,
        unknowns: Unknowns,
        robot: Model,
    ) -> Self {
        // The channels the data have rows in: each of those whose noise is not
        // stated is estimated.
        let orientation = unknowns.orientation;
        let present = PerChannel::from_fn(|c| match c {
            Channel::Position => true,
            Channel::Orientation => orientation,
            Channel::Point => data.iter().any(|o| o.fixed_point().is_some()),
            Channel::Plane => data.iter().any(|o| o.on_plane().is_some()),
        });
        // A down-weighted channel keeps the noise it is given: its variance
        // component would restore the weight.
        let estimate = present.map(|c, &present| {
            present
                && options.noise(c).source == NoiseSource::Estimated
                && options.weights.of_channel(c) == 1.0
        });
        let mut structure = robot.clone();
        let mut moved = false;
        let links = nominal
            .params()
            .filter(|p| !matches!(p, Param::Base(_) | Param::Tool(_)))
            .chain((0..nominal.dof()).map(Param::Beta));
        for p in links {
            if let (Some(n), Some(v)) = (nominal.param(p), structure.robot.param_mut(p)) {
                moved |= *v != n;
                *v = n;
            }
        }
        Self {
            nominal,
            data,
            constraints,
            options,
            unknowns,
            start: robot.clone(),
            structure,
            start_is_structure: !moved,
            robot,
            present,
            estimate,
            noise: PerChannel::from_fn(|c| options.noise(c).sigma),
            noise_scale: 1.0,
            iterations: 0,
            round: 0,
        }
    }

    /// Runs the rounds and reports the solution.
    pub(super) fn run(mut self) -> Result<FullFit, FullError> {
        let solution = self.rounds()?;
        self.result(solution)
    }

    /// Selection and fit until the noise settles (estimated) or the
    /// selection stands (stated).
    fn rounds(&mut self) -> Result<Solution, FullError> {
        loop {
            self.round += 1;
            let weights = self.weights();
            let mut solution = self.select_and_solve(&weights)?;
            if self.estimate.0.contains(&true) {
                self.settle_noise(&mut solution)?;
                return Ok(solution);
            }
            if !self.select_again(&solution, &weights) {
                return Ok(solution);
            }
        }
    }

    /// The separable unknowns (indices into the unknowns) at `noise_scale`
    /// and the others with why, at the nominal link geometry
    /// ([`Fit::structure`]); `system`, when given, is the linearisation of
    /// every unknown there.
    fn separable(
        &self,
        system: Option<&NormalEquations>,
        noise_scale: f64,
        weights: &Weights,
    ) -> (Vec<usize>, Vec<(Unknown, String)>) {
        let (params, robot, data, options) = (
            &self.unknowns.params,
            &self.structure,
            self.data,
            self.options,
        );
        if self.unknowns.constrained {
            return constrained_subset(params, robot, data, options, noise_scale, weights);
        }
        let accumulated;
        let system = match system {
            Some(system) => system,
            None => {
                accumulated =
                    NormalEquations::accumulate(robot, data, params, weights, options.cancel);
                &accumulated
            }
        };
        separable_subset(system, params, robot, data, options, noise_scale)
    }

    /// One round's selection at `weights`, the held unknowns put back, and
    /// the fit of the free ones.
    fn select_and_solve(&mut self, weights: &Weights) -> Result<Solution, FullError> {
        // Each round starts with a pass over the rows: the caller may stop it.
        self.options.cancel.check()?;
        let system = NormalEquations::accumulate(
            &self.robot,
            self.data,
            &self.unknowns.params,
            weights,
            self.options.cancel,
        );
        // The first round of a fit from the nominal model linearises where
        // the selection is made.
        let at_structure = self.start_is_structure && self.round == 1;
        let (free, fixed) =
            self.separable(at_structure.then_some(&system), self.noise_scale, weights);
        let equations = self.unknowns.equations;
        if equations < free.len() && self.options.prior == Prior::NONE {
            return Err(FullError::TooFewEquations {
                equations,
                unknowns: free.len(),
            });
        }
        let free_params = free
            .iter()
            .map(|&k| self.unknowns.params[k])
            .collect::<Vec<Unknown>>();
        let moved = self.hold(&fixed);
        // The linearisation of every parameter serves the first iteration unless a
        // held parameter was just moved back.
        let first = if moved {
            NormalEquations::accumulate(
                &self.robot,
                self.data,
                &free_params,
                weights,
                self.options.cancel,
            )
        } else {
            system.select_columns(&free)
        };
        let prior = prior_terms(&free_params, self.nominal, &self.options.prior);
        let (converged, last_decrease, sys) = self.solve(&free_params, &prior, weights, first)?;
        let post = self.posterior(&sys, &prior);
        Ok(Solution {
            free_params,
            fixed,
            converged,
            last_decrease,
            sys,
            prior,
            post,
        })
    }

    /// Parameters held fixed keep their nominal value (base and tool: their
    /// closed-form estimate; effects, points, planes: the start's). Whether
    /// any moved.
    fn hold(&mut self, fixed: &[(Unknown, String)]) -> bool {
        let mut moved = false;
        for (p, _) in fixed {
            let keep = match *p {
                Unknown::Param(Param::Base(_) | Param::Tool(_)) => self.start.get(*p),
                Unknown::Param(q) => self.nominal.param(q),
                Unknown::Effect { .. }
                | Unknown::Point { .. }
                | Unknown::Plane { .. }
                | Unknown::Session { .. } => self.start.get(*p),
            };
            if let (Some(v), Some(slot)) = (keep, self.robot.get_mut(*p)) {
                moved |= *slot != v;
                *slot = v;
            }
        }
        moved
    }

    /// The fit of `free_params` at `weights` from the linearisation `first`:
    /// convergence, the last decrease and the linearisation at the solution.
    fn solve(
        &mut self,
        free_params: &[Unknown],
        prior: &[(f64, f64)],
        weights: &Weights,
        first: NormalEquations,
    ) -> Result<(bool, Option<f64>, NormalEquations), FullError> {
        let (run, converged, last_decrease, sys) = levenberg_marquardt(
            &mut self.robot,
            self.data,
            free_params,
            weights,
            self.options,
            first,
            prior,
        )?;
        self.iterations += run;
        Ok((converged, last_decrease, sys))
    }

    /// The posterior at `sys`; its variance factor counts the channels
    /// weighted by their noise (not a down-weighted orientation channel).
    fn posterior(&self, sys: &NormalEquations, prior: &[(f64, f64)]) -> Posterior {
        let mut post = Posterior::at(sys, prior);
        for c in Channel::ALL {
            post.counted[c] = self.options.weights.of_channel(c) == 1.0;
        }
        post
    }

    /// The variance components: the free parameters stay; each round
    /// reweighs the rows of the solution's linearisation and iterates from
    /// there, until the noise settles.
    fn settle_noise(&mut self, s: &mut Solution) -> Result<(), FullError> {
        loop {
            let next = self.noise.map(|c, &sigma| {
                if self.estimate[c] {
                    ChannelNoise::update(sigma, s.post.omega[c], s.post.redundancy[c])
                } else {
                    sigma
                }
            });
            let settled = Channel::ALL
                .iter()
                .all(|&c| (next[c] / self.noise[c] - 1.0).abs() < SETTLED);
            if settled || self.round >= MAX_NOISE_ROUNDS {
                return Ok(());
            }
            self.round += 1;
            let before = self.weights();
            self.noise = next;
            let weights = self.weights();
            let first = s.sys.reweighted(&before, &weights);
            (s.converged, s.last_decrease, s.sys) =
                self.solve(&s.free_params, &s.prior, &weights, first)?;
            s.post = self.posterior(&s.sys, &s.prior);
        }
    }

    /// Whether a stated noise needs another round: the fit shows it
    /// significantly larger than the selection assumed and the selection at
    /// the noise shown frees other unknowns (the noise scale is then that noise's).
    fn select_again(&mut self, s: &Solution, weights: &Weights) -> bool {
        let variance_factor = s.post.variance_factor();
        // Select again only if the noise is significantly larger than stated: the
        // variance factor of correctly stated noise scatters about 1 with a
        // standard deviation of √(2/dof).
        let significant = 1.0 + 3.0 * (2.0 / s.post.redundancy().max(1.0)).sqrt();
        let new_scale = variance_factor.sqrt();
        if variance_factor <= significant * self.noise_scale * self.noise_scale {
            return false;
        }
        let (free_again, _) = self.separable(None, new_scale, weights);
        self.noise_scale = new_scale;
        free_again
            .iter()
            .map(|&k| self.unknowns.params[k])
            .collect::<Vec<_>>()
            != s.free_params
    }

    /// Statistics at the solution (the last linearisation is at the solution).
    fn statistics(&self, s: &Solution) -> Statistics {
        let (g, _, scale) = s.sys.scaled_normal_equations();
        let variance_factor = s.post.variance_factor();
        let equations = self.unknowns.equations;
        let eig = g.self_adjoint_eigenvalues(Side::Lower).unwrap_or_default();
        let (smin, smax) = (
            eig.first().copied().unwrap_or(0.0).max(0.0).sqrt(),
            eig.last().copied().unwrap_or(0.0).max(0.0).sqrt(),
        );
        let condition_number = if smin > 0.0 {
            smax / smin
        } else {
            f64::INFINITY
        };
        let observability = {
            let p = eig.len().max(1) as f64;
            let log_sum: f64 = eig
                .iter()
                .map(|l| 0.5 * l.max(f64::MIN_POSITIVE).ln())
                .sum();
            (log_sum / p).exp() / (equations.max(1) as f64).sqrt()
        };
        let free_params = &s.free_params;
        let prior_reach = prior_reach(&g, &scale, &self.robot, free_params, &s.prior, equations);
        let mut correlations = Vec::new();
        let mut std_of = vec![f64::NAN; free_params.len()];
        if let Some(c) = &s.post.cov {
            for k in 0..free_params.len() {
                std_of[k] = (variance_factor * c[(k, k)]).sqrt() * scale[k];
                for l in 0..k {
                    let rho = c[(k, l)] / (c[(k, k)] * c[(l, l)]).sqrt();
                    correlations.push((
                        self.robot.name(free_params[l]),
                        self.robot.name(free_params[k]),
                        rho,
                    ));
                }
            }
        }
        correlations.sort_by(|a, b| b.2.abs().total_cmp(&a.2.abs()));
        correlations.truncate(5);
        Statistics {
            variance_factor,
            condition_number,
            observability,
            prior_reach,
            correlations,
            std_of,
        }
    }

    /// The noise of each channel: used, and shown by the residuals; the
    /// known distances' at their stated uncertainties.
    fn noise_estimate(&self, s: &Solution) -> NoiseEstimate {
        let (noise, post, constraints) = (&self.noise, &s.post, self.constraints);
        // A down-weighted contact's weighted squares are its factor times
        // its own: what its rows show, over the factor's square root.
        let channel = |c: Channel| {
            let shown = ChannelNoise::update(noise[c], post.omega[c], post.redundancy[c]);
            let factor = match c {
                Channel::Point | Channel::Plane => self.options.weights.fitted_channel(c),
                Channel::Position | Channel::Orientation => 1.0,
            };
            ChannelNoise {
                source: self.options.noise(c).source,
                used: noise[c],
                shown: shown / factor.sqrt(),
                rows: post.rows[c],
                redundancy: post.redundancy[c],
            }
        };
        let distance = (!constraints.distances.is_empty()).then(|| {
            let n = constraints.distances.len();
            let used = (constraints
                .distances
                .iter()
                .map(|d| d.std * d.std)
                .sum::<f64>()
                / n as f64)
                .sqrt();
            let (omega, redundancy) = post.distances;
            ChannelNoise {
                source: NoiseSource::Stated,
                used,
                shown: ChannelNoise::update(used, omega, redundancy),
                rows: n,
                redundancy,
            }
        });
        NoiseEstimate {
            position: channel(Channel::Position),
            orientation: self
                .unknowns
                .orientation
                .then(|| channel(Channel::Orientation)),
            point: self.present[Channel::Point].then(|| channel(Channel::Point)),
            plane: self.present[Channel::Plane].then(|| channel(Channel::Plane)),
            distance,
        }
    }

    /// Each parameter's and each effect's result: identified with its
    /// standard error and data share, or held with the reason (`reasons`).
    fn statuses(
        &self,
        free_params: &[Unknown],
        share: &[f64],
        std_of: &[f64],
        mut reasons: HashMap<Unknown, String>,
    ) -> (Vec<ParamResult>, Vec<EffectFit>) {
        let (nominal, robot, start) = (self.nominal, &self.robot, &self.start);
        let mut status_of = |u: Unknown| match free_params.iter().position(|p| *p == u) {
            Some(k) => (Status::Identified { std: std_of[k] }, share[k]),
            None => {
                let mut reason = reasons.remove(&u).unwrap_or_else(|| "not separable".into());
                // The error shown is then the registration's, not a fitted one.
                if let Unknown::Param(p @ (Param::Base(_) | Param::Tool(_))) = u
                    && start.get(u) != nominal.param(p)
                {
                    reason.push_str(
                        "; held at its closed-form estimate from the data, not at nominal",
                    );
                }
                (Status::Fixed { reason }, 0.0)
            }
        };
        let effect_fits: Vec<EffectFit> = robot
            .effects
            .iter()
            .enumerate()
            .map(|(effect, e)| EffectFit {
                effect: *e,
                status: (0..e.parameter_count())
                    .map(|component| status_of(Unknown::Effect { effect, component }).0)
                    .collect(),
            })
            .collect();
        let results = self
            .unknowns
            .all
            .iter()
            .map(|&param| {
                let nominal_value = nominal.param(param).unwrap_or(0.0);
                let mut error = robot.robot.param(param).unwrap_or(0.0) - nominal_value;
                if param.is_angle() {
                    error = wrap_angle(error);
                }
                let (status, data_share) = status_of(Unknown::Param(param));
                ParamResult {
                    param,
                    nominal: nominal_value,
                    error,
                    status,
                    data_share,
                }
            })
            .collect();
        (results, effect_fits)
    }

    /// The estimated points (with the standard error of each coordinate),
    /// the estimated planes, and the known distances' residuals, m.
    fn constraint_fits(&self, s: &Solution, std_of: &[f64]) -> ConstraintFits {
        let robot = &self.robot;
        let points = robot
            .constraints
            .points
            .iter()
            .zip(&robot.points)
            .enumerate()
            .map(|(point, (named, position))| PointFit {
                name: named.name.clone(),
                position: *position,
                std: Vector3::from_fn(|axis, _| {
                    s.free_params
                        .iter()
                        .position(|u| *u == Unknown::Point { point, axis })
                        .map_or(f64::NAN, |k| std_of[k])
                }),
            })
            .collect();
        let distance_residuals = robot
            .constraints
            .distances
            .iter()
            .map(|d| {
                let [a, b] = d
                    .points
                    .map(|k| robot.points.get(k).copied().unwrap_or_else(Point3::origin));
                (a - b).norm() - d.length
            })
            .collect();
        let planes = robot
            .constraints
            .planes
            .iter()
            .zip(&robot.planes)
            .map(|(named, p)| PlaneFit {
                name: named.name.clone(),
                normal: p.normal(),
                offset: p.offset,
            })
            .collect();
        ConstraintFits {
            points,
            planes,
            distance_residuals,
        }
    }

    /// The result at solution `s`.
    fn result(mut self, s: Solution) -> Result<FullFit, FullError> {
        // Orientations not used: the tool's rotation registered to them.
        let unused = self.options.weights[Weighed::Orientation] == 0.0 && self.unknowns.orientation;
        let tool_rotation_std = if unused {
            self.register_tool_rotation()
        } else {
            None
        };
        let stats = self.statistics(&s);
        let (position_rms, mut orientation_rms) = s.sys.residual_rms(&self.weights());
        let mut noise = self.noise_estimate(&s);
        // A down-weighted orientation channel: its residuals measured
        // unweighted, whatever its weight (0 included).
        if let (Some(o), true) = (
            &mut noise.orientation,
            self.options.weights[Weighed::Orientation] != 1.0,
        ) {
            let (sum, rows) = self.orientation_squares();
            orientation_rms = (sum / (rows / 3).max(1) as f64).sqrt();
            o.shown = if o.redundancy >= 1.0 {
                (sum / o.redundancy).sqrt()
            } else {
                o.used
            };
        }
        let held_by_model = std::mem::take(&mut self.unknowns.held_by_model);
        let reasons = s
            .fixed
            .iter()
            .cloned()
            .chain(held_by_model)
            .collect::<HashMap<_, _>>();
        let sessions = self.session_fits(&s, &stats.std_of, &reasons);
        let (mut params, effects) =
            self.statuses(&s.free_params, &s.post.share, &stats.std_of, reasons);
        if let Some(std) = tool_rotation_std {
            for p in &mut params {
                if matches!(
                    p.param,
                    Param::Tool(FrameAxis::Rx | FrameAxis::Ry | FrameAxis::Rz)
                ) {
                    p.status = Status::Identified { std };
                    p.data_share = 1.0;
                }
            }
        }
        if !s.sys.cost().is_finite() {
            return Err(FullError::NonFinite);
        }
        let ConstraintFits {
            points,
            planes,
            distance_residuals,
        } = self.constraint_fits(&s, &stats.std_of);
        Ok(FullFit {
            registrations: self.robot.registrations.clone(),
            sessions,
            points,
            planes,
            distance_residuals,
            params,
            calibrated: self.robot.robot,
            effects,
            iterations: self.iterations,
            converged: s.converged,
            last_decrease: s.last_decrease,
            position_rms,
            orientation_rms,
            condition_number: stats.condition_number,
            observability: stats.observability,
            variance_factor: stats.variance_factor,
            correlations: stats.correlations,
            equations: self.unknowns.equations,
            redundancy: s.post.redundancy(),
            noise,
            weights: self.options.weights,
            prior_reach: stats.prior_reach,
            cancel: self.options.cancel,
        })
    }

    /// Orientations not used (weight 0): the tool's rotation, which no
    /// position sees, registered to them with the geometry held — the
    /// rotation nearest the mean of `R_modelᵀ R_measured` over the first
    /// session's rows (the chordal mean) put on the tool. The standard
    /// error of each of its angles, rad: the rows' scatter about it per
    /// axis over `√n`; `None` without such rows.
    fn register_tool_rotation(&mut self) -> Option<f64> {
        let kinematics = self.robot.robot.prepare();
        let pairs: Vec<(Rotation3<f64>, Rotation3<f64>)> = self
            .data
            .iter()
            .filter(|o| o.session == 0)
            .filter_map(|o| {
                let measured = o.orientation?.to_rotation_matrix();
                let model = kinematics.forward(&o.q).ok()?.rotation;
                Some((model, measured))
            })
            .collect();
        if pairs.is_empty() {
            return None;
        }
        let mean: Matrix3<f64> = pairs
            .iter()
            .map(|(model, measured)| (model.transpose() * measured).into_inner())
            .sum();
        let correction = super::initial::project_to_rotation(&mean);
        let tool = &mut self.robot.robot.tool;
        let rotation = tool.isometry().rotation * correction;
        let (roll, pitch, yaw) = rotation.euler_angles();
        tool.rpy = Vector3::new(roll, pitch, yaw);
        let n = pairs.len() as f64;
        let squares: f64 = pairs
            .iter()
            .map(|(model, measured)| {
                (correction.transpose() * model.transpose() * measured)
                    .scaled_axis()
                    .norm_squared()
            })
            .sum();
        Some((squares / (3.0 * n)).sqrt() / n.sqrt())
    }

    /// The weight of each channel's rows at the current noises.
    fn weights(&self) -> Weights {
        channel_weights(&self.noise, &self.options.weights)
    }

    /// The sum of squares of the orientation rows' residuals, rad², and
    /// their count, at the current model (each session's own frames).
    fn orientation_squares(&self) -> (f64, usize) {
        let (mut sum, mut rows) = (0.0, 0);
        let ones = Weights::of(&PerChannel::from_fn(|_| 1.0));
        super::rows::for_each_pose_rows(&self.robot, self.data, &[], &ones, |pose| {
            if pose.orientation {
                sum += pose.r[3..6].iter().map(|x| x * x).sum::<f64>();
                rows += 3;
            }
        });
        (sum, rows)
    }
}

impl Fit<'_> {
    /// Each session's figures and own frames at solution `s`, when there are
    /// several: the RMS of its rows' residuals, and each own frame
    /// parameter's value and status.
    fn session_fits(
        &self,
        s: &Solution,
        std_of: &[f64],
        reasons: &HashMap<Unknown, String>,
    ) -> Vec<SessionFit> {
        let count = session_count(self.data);
        if count < 2 {
            return Vec::new();
        }
        // Each session's sums of squares: the rows of no unknown, unweighted.
        let mut sums = vec![(0usize, 0.0, 0.0, 0usize); count];
        let mut poses = self.data.iter();
        let ones = Weights::of(&PerChannel::from_fn(|_| 1.0));
        super::rows::for_each_pose_rows(&self.robot, self.data, &[], &ones, |rows| {
            let Some(obs) = poses.next() else { return };
            let sum = &mut sums[obs.session];
            sum.0 += 1;
            sum.1 += rows.r[..rows.position_rows]
                .iter()
                .map(|x| x * x)
                .sum::<f64>();
            if rows.orientation {
                sum.2 += rows.r[3..6].iter().map(|x| x * x).sum::<f64>();
                sum.3 += 1;
            }
        });
        let frames: Vec<Param> = self
            .unknowns
            .all
            .iter()
            .filter(|p| matches!(p, Param::Base(_) | Param::Tool(_)))
            .copied()
            .collect();
        let regs = &self.robot.registrations;
        sums.iter()
            .enumerate()
            .map(|(session, &(n, pos, rot, n_rot))| SessionFit {
                poses: n,
                position_rms: (pos / n.max(1) as f64).sqrt(),
                orientation_rms: (n_rot > 0).then(|| (rot / n_rot as f64).sqrt()),
                frames: frames
                    .iter()
                    .filter_map(|&param| {
                        let value = regs.param(session, param)?;
                        let u = Unknown::Session { session, param };
                        let status = match s.free_params.iter().position(|p| *p == u) {
                            Some(k) => Status::Identified { std: std_of[k] },
                            None => Status::Fixed {
                                reason: reasons
                                    .get(&u)
                                    .cloned()
                                    .unwrap_or_else(|| "not separable".into()),
                            },
                        };
                        Some((param, value, status))
                    })
                    .collect(),
            })
            .collect()
    }
}

/// What a constraint session estimates besides the robot.
struct ConstraintFits {
    points: Vec<PointFit>,
    planes: Vec<PlaneFit>,
    distance_residuals: Vec<f64>,
}
