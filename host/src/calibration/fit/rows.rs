//! The rows of the fit: each pose's weighted Jacobian rows and residual
//! ([`for_each_pose_rows`], Mirman & Gupta's special Jacobians, eqs. 51–54,
//! and the effects' columns), stored ([`LinearSystem`]) or summed into the
//! normal equations per channel ([`NormalEquations`]: `JᵀJ`, `Jᵀr`, `rᵀr`)
//! in blocks of poses on every core, and the rows of the known distances.
//! See the parent module's "Residuals and weights".

use armcal_shared::effects::{Effect, EffectModel, gravity_torques, joint_param};
use armcal_shared::jacobian::at_point;
use armcal_shared::{Chain, Param, Prepared, Robot, Twist, rotation_error};
use faer::linalg::matmul::{self, triangular, triangular::BlockStructure};
use faer::{Accum, Mat, Par};
use nalgebra::{Point3, Vector3};

use super::{Model, Observation, PlaneEstimate, Unknown, rms_pair};
use crate::calibration::dense::unit_diagonal_scale;
use crate::calibration::fit::noise::Weights;
use crate::calibration::parallel;
use crate::cancel::Cancel;
use crate::session::channel::{Channel, PerChannel};
use crate::session::rows::Rows;

/// The weighted Jacobian and residual of one linearisation, stored whole (rows ×
/// unknowns): what [`linearize`] hands the diagnosis, which solves on subsets of
/// the poses. The fit itself needs only [`NormalEquations`].
pub(super) struct LinearSystem {
    /// Weighted Jacobian, rows × params.
    pub(super) j: Mat<f64>,
    /// Weighted residual, rows × 1.
    pub(super) r: Mat<f64>,
}

impl LinearSystem {
    pub(super) fn rows(data: Rows<'_>) -> usize {
        data.iter().map(Observation::equations).sum()
    }

    /// The linearisation at `model`: per pose its 3 position rows, then its 3
    /// orientation rows when measured ([`for_each_pose_rows`]); the poses in
    /// one piece per core (of at most [`BLOCK_POSES`]: a few ms of rows
    /// between two questions to `cancel`), each piece filling its own rows.
    /// `None` once `cancel` is requested while the Jacobian is allocated
    /// ([`stoppable_zeros`]); requested later, the pieces not started are
    /// left zero: the caller's next check drops the whole.
    pub(super) fn build(
        model: &Model,
        data: Rows<'_>,
        params: &[Unknown],
        weights: &Weights,
        cancel: Cancel,
    ) -> Option<Self> {
        let rows = Self::rows(data);
        let mut j = stoppable_zeros(rows, params.len(), cancel)?;
        let mut r = Mat::zeros(rows, 1);
        let piece = parallel::piece_len(data.len(), MIN_PIECE_POSES).min(BLOCK_POSES);
        let mut pieces = Vec::new();
        let (mut j_rest, mut r_rest) = (j.as_mut(), r.as_mut());
        for poses in data.chunks(piece) {
            let n = Self::rows(poses);
            let (j_piece, j_after) = j_rest.split_at_row_mut(n);
            let (r_piece, r_after) = r_rest.split_at_row_mut(n);
            pieces.push((poses, j_piece, r_piece));
            (j_rest, r_rest) = (j_after, r_after);
        }
        parallel::each(pieces, |(poses, mut j, mut r)| {
            if cancel.requested() {
                return;
            }
            let mut row = 0;
            for_each_pose_rows(model, poses, params, weights, |pose| {
                let orientation = if pose.orientation { 3..6 } else { 0..0 };
                for i in (0..pose.position_rows).chain(orientation) {
                    r[(row, 0)] = pose.r[i];
                    for k in 0..params.len() {
                        j[(row, k)] = pose.row(i)[k];
                    }
                    row += 1;
                }
            });
        });
        Some(Self { j, r })
    }

    /// The system of no rows, of `params` columns.
    pub(super) fn empty(params: usize) -> Self {
        Self {
            j: Mat::zeros(0, params),
            r: Mat::zeros(0, 1),
        }
    }
}

/// The columns [`stoppable_zeros`] zeroes between two questions to the
/// caller's request to stop: 8 columns of 3·10⁵ rows are 19 MB, a few ms
/// of first touches of fresh memory.
const CANCEL_COLUMNS: usize = 8;

/// A `rows × cols` matrix of zeros (laid out as [`Mat::zeros`] lays it out),
/// zeroed [`CANCEL_COLUMNS`] columns at a time: the Jacobian of 10⁵ poses and
/// every candidate effect's columns is hundreds of MB, whose first touch
/// alone takes 0.1–0.4 s. `None` once `cancel` is requested part way.
pub(super) fn stoppable_zeros(rows: usize, cols: usize, cancel: Cancel) -> Option<Mat<f64>> {
    let mut m = Mat::with_capacity(rows, cols);
    m.resize_with(rows, 0, |_, _| 0.0);
    for start in (0..cols).step_by(CANCEL_COLUMNS) {
        if cancel.requested() {
            return None;
        }
        m.resize_with(rows, (start + CANCEL_COLUMNS).min(cols), |_, _| 0.0);
    }
    Some(m)
}

/// The fewest poses [`LinearSystem::build`] gives a core: about a µs each
/// (their rows of tens of columns), fewer take no longer than waking a
/// sleeping worker ([`parallel::map_if`]).
pub(super) const MIN_PIECE_POSES: usize = 512;

/// The weighted rows of one pose: 3 position rows, then 3 orientation rows when
/// its orientation is measured.
pub(super) struct PoseRows {
    /// Jacobian rows, 6 × params, row after row (rows 3..6 only meaningful when
    /// `orientation`).
    pub(super) j: Vec<f64>,
    /// Params: the length of a row.
    pub(super) params: usize,
    /// Residual rows (3..6 only meaningful when `orientation`).
    pub(super) r: [f64; 6],
    /// Whether the orientation rows are present.
    pub(super) orientation: bool,
    /// The position rows: 3, or 1 for a touch of a plane (its distance along
    /// the normal; rows 1..3 then hold zeros).
    pub(super) position_rows: usize,
    /// The channel of the position rows: a measured position or a contact.
    pub(super) channel: Channel,
}

impl PoseRows {
    /// Row `i` of the Jacobian.
    pub(super) fn row(&self, i: usize) -> &[f64] {
        &self.j[i * self.params..(i + 1) * self.params]
    }
}

/// Hands `emit` the weighted rows of each pose in turn, linearised at `model`:
/// the one per-pose computation behind both the stored [`LinearSystem`] and the
/// accumulated [`NormalEquations`]. A pose whose kinematics fail is skipped (joint
/// counts are checked on entry, so none does).
///
/// With effects, each pose is evaluated at its temperature (thermal expansion
/// scales the lengths) and at the joint values `q + Δq(q, context)`; a joint
/// effect's column is the joint's column times `∂Δq_j/∂p`, thermal
/// expansion's is `ΔT Σ_i (a_i ∂/∂a_i + s_i ∂/∂s_i)`. The dependence of `Δq`
/// on the geometry (through the gravity torque) is left out of the Jacobian:
/// it only slows convergence, the residuals stay exact.
pub(super) fn for_each_pose_rows(
    model: &Model,
    data: Rows<'_>,
    params: &[Unknown],
    weights: &Weights,
    mut emit: impl FnMut(&PoseRows),
) {
    let wr = weights[Channel::Orientation];
    // Each session sees the robot through its own base and tool frames.
    let robots = model.registrations.robots(&model.robot);
    let kinematics: Vec<Prepared<f64>> = robots.iter().map(Robot::prepare).collect();
    let Some(Ok(mut chain)) = data.first().map(|o| kinematics[0].chain(&o.q)) else {
        return;
    };
    let mut rows = PoseRows {
        j: vec![0.0; 6 * params.len()],
        params: params.len(),
        r: [0.0; 6],
        orientation: false,
        position_rows: 3,
        channel: Channel::Position,
    };
    let q0 = &data[0].q;
    let base_columns: Vec<[Twist<f64>; 6]> = kinematics
        .iter()
        .map(|k| {
            k.chain(q0)
                .map_or([Twist::zeros(); 6], |c| c.base_columns())
        })
        .collect();
    // Which frames each session has of its own (none for one session).
    let own: Vec<(bool, bool)> = (0..robots.len())
        .map(|k| model.registrations.own_frames(k))
        .collect();
    let effects = PoseEffects::of(model);
    let mut q_eff: Vec<f64> = Vec::new();
    for obs in data {
        let session = obs.session.min(robots.len() - 1);
        // Joint counts were checked on entry.
        let Some(at) = effects.place(
            &robots[session],
            &kinematics[session],
            obs,
            &mut q_eff,
            &mut chain,
        ) else {
            continue;
        };
        let columns = PoseColumns {
            model,
            obs,
            session,
            own: own[session],
            chain: &chain,
            base_columns: &base_columns[session],
            tool_columns: chain.tool_columns(),
            at: &at,
        };
        let p = chain.point();
        let dp = model.target(obs) - p;
        // The tool point's rows are weighed by the noise of their kind.
        let channel = obs.channel();
        let pose = PoseGeometry {
            p,
            orientation: obs
                .orientation
                .map(|q| rotation_error(&q.to_rotation_matrix(), &chain.end.rotation)),
            // A touch of a plane: one row, the distance along the normal.
            touched: obs
                .on_plane()
                .and_then(|k| model.planes.get(k).map(|pl| (k, pl, pl.normal()))),
            wp: weights[channel],
            wr,
        };
        for (k, &u) in params.iter().enumerate() {
            match u {
                Unknown::Plane { plane, component } => {
                    rows.set_plane_column(k, plane, component, &pose);
                }
                Unknown::Point { point, axis } => {
                    // The row's target moves with its own point: −1 on the axis.
                    rows.set_point_column(k, obs.fixed_point() == Some(point), axis, pose.wp);
                }
                Unknown::Param(_) | Unknown::Effect { .. } | Unknown::Session { .. } => {
                    rows.set_column(k, &columns.column(u), &pose);
                }
            }
        }
        rows.set_residual(&dp, channel, &pose);
        emit(&rows);
    }
}

/// The effects as the rows of every pose need them: the effect model, the
/// thermal expansion's coefficient and reference temperature, and whether a
/// compliance asks for the gravity torques.
struct PoseEffects {
    effects: Option<EffectModel<f64>>,
    thermal: Option<(f64, f64)>,
    needs_torque: bool,
}

/// Where one pose is evaluated: its temperature's offset from the reference
/// (°C, 0 without thermal expansion), the lengths' factor there, and the
/// gravity torques (N m; empty unless a compliance needs them).
struct PoseState {
    delta_t: f64,
    length_scale: f64,
    tau: Vec<f64>,
}

impl PoseEffects {
    fn of(model: &Model) -> Self {
        let robot = &model.robot;
        let effects = (!model.effects.is_empty())
            .then(|| EffectModel::new(robot.clone(), &model.effects).ok())
            .flatten();
        let thermal = model.effects.iter().find_map(|e| match e {
            Effect::ThermalExpansion {
                coefficient,
                reference,
            } => Some((*coefficient, *reference)),
            _ => None,
        });
        let needs_torque = model
            .effects
            .iter()
            .any(|e| matches!(e, Effect::JointCompliance { .. }));
        Self {
            effects,
            thermal,
            needs_torque,
        }
    }

    /// Sets `chain` to pose `obs` of `robot` at its temperature and the joint values the
    /// effects give (`q_eff`, reused); `None` if its kinematics fail.
    fn place(
        &self,
        robot: &Robot<f64>,
        kinematics: &Prepared<f64>,
        obs: &Observation,
        q_eff: &mut Vec<f64>,
        chain: &mut Chain<f64>,
    ) -> Option<PoseState> {
        let ctx = &obs.context;
        let delta_t = match (self.thermal, ctx.temperature) {
            (Some((_, reference)), Some(t)) => t - reference,
            _ => 0.0,
        };
        // The lengths at the pose's temperature: the chain of
        // `EffectModel::robot_at`, without preparing a model per pose.
        let length_scale = match (&self.effects, delta_t != 0.0) {
            (Some(em), true) => em.length_factor(ctx.temperature),
            _ => 1.0,
        };
        let mut tau: Vec<f64> = Vec::new();
        q_eff.clear();
        match &self.effects {
            Some(em) => {
                if self.needs_torque
                    && kinematics
                        .chain_scaled_into(&obs.q, length_scale, chain)
                        .is_ok()
                {
                    tau = gravity_torques(robot, chain, ctx.payload.unwrap_or(0.0)).to_vec();
                }
                q_eff.extend_from_slice(&em.joint_values_at(&obs.q, &tau, ctx));
            }
            None => q_eff.extend_from_slice(&obs.q),
        }
        kinematics
            .chain_scaled_into(q_eff, length_scale, chain)
            .ok()?;
        Some(PoseState {
            delta_t,
            length_scale,
            tau,
        })
    }
}

/// The columns of one pose's geometric and effect unknowns, as twists.
struct PoseColumns<'a> {
    model: &'a Model,
    obs: &'a Observation,
    /// The pose's session: its base and tool columns are those of its own
    /// frames where it has them, the model's where it shares them.
    session: usize,
    /// Whether the session has its own base frame, its own tool.
    own: (bool, bool),
    chain: &'a Chain<f64>,
    base_columns: &'a [Twist<f64>; 6],
    tool_columns: [Twist<f64>; 6],
    at: &'a PoseState,
}

impl PoseColumns<'_> {
    /// The column of `u`, a parameter or an effect's parameter.
    #[inline]
    fn column(&self, u: Unknown) -> Twist<f64> {
        let (chain, robot, length_scale) = (self.chain, &self.model.robot, self.at.length_scale);
        let frame = |p: Param| match p {
            Param::Base(ax) => self.base_columns[ax.index()],
            Param::Tool(ax) => self.tool_columns[ax.index()],
            _ => Twist::zeros(),
        };
        match u {
            // The model's frames move the poses of the sessions that share them.
            Unknown::Param(Param::Base(ax)) if !self.own.0 => self.base_columns[ax.index()],
            Unknown::Param(Param::Tool(ax)) if !self.own.1 => self.tool_columns[ax.index()],
            Unknown::Param(Param::Base(_) | Param::Tool(_)) => Twist::zeros(),
            Unknown::Session { session, param } => {
                if session == self.session {
                    frame(param)
                } else {
                    Twist::zeros()
                }
            }
            Unknown::Param(pm @ (Param::A(_) | Param::S(_))) => chain.column(pm) * length_scale,
            Unknown::Param(pm) => chain.column(pm),
            Unknown::Effect { effect, component } => {
                let e = &self.model.effects[effect];
                match e.joint() {
                    Some(jt) => {
                        let sens = e.joint_sensitivity(
                            component,
                            self.obs.q[jt],
                            self.at.tau.get(jt).copied().unwrap_or(0.0),
                            &self.obs.context,
                        );
                        chain.column(joint_param(robot, jt)) * sens
                    }
                    // Thermal expansion: every length, scaled by ΔT.
                    None => {
                        (0..robot.dof())
                            .map(|i| {
                                let l = &robot.links[i];
                                chain.column(Param::A(i)) * l.a + chain.column(Param::S(i)) * l.s
                            })
                            .fold(Twist::zeros(), |acc, c| acc + c)
                            * self.at.delta_t
                    }
                }
            }
            // Points and planes have no twist: their rows are written directly.
            Unknown::Point { .. } | Unknown::Plane { .. } => Twist::zeros(),
        }
    }
}

/// What one pose's rows read besides the columns: the tool point (base
/// frame, m), the orientation error (rad), the plane touched (its index, its
/// estimate, its normal), and the weights of the position and orientation rows.
struct PoseGeometry<'a> {
    p: Point3<f64>,
    orientation: Option<Vector3<f64>>,
    touched: Option<(usize, &'a PlaneEstimate, Vector3<f64>)>,
    wp: f64,
    wr: f64,
}

impl PoseRows {
    /// Column `k` for the twist `col` of a parameter or effect: the position
    /// rows `v = col at p` (or its component along a touched plane's
    /// normal), the orientation rows the rotation part.
    fn set_column(&mut self, k: usize, col: &Twist<f64>, pose: &PoseGeometry) {
        let (n, wp, wr) = (self.params, pose.wp, pose.wr);
        let v = at_point(col, &pose.p);
        if let Some((_, _, normal)) = pose.touched {
            self.j[k] = normal.dot(&Vector3::new(v[0], v[1], v[2])) * wp;
            for i in 1..6 {
                self.j[i * n + k] = 0.0;
            }
            return;
        }
        for i in 0..3 {
            self.j[i * n + k] = v[i] * wp;
        }
        if pose.orientation.is_some() {
            for i in 0..3 {
                self.j[(3 + i) * n + k] = col[i] * wr;
            }
        }
    }

    /// Column `k` for component `component` of plane `plane`: nonzero only
    /// in the row of a touch of that plane.
    fn set_plane_column(&mut self, k: usize, plane: usize, component: usize, pose: &PoseGeometry) {
        let n = self.params;
        for i in 0..6 {
            self.j[i * n + k] = 0.0;
        }
        if let Some((own, pl, _)) = pose.touched
            && own == plane
        {
            // The plane's side of the row: `offset`, against the model's `n · p`.
            self.j[k] = pose.wp
                * match component {
                    0 | 1 => pl.normal_derivative(component).dot(&pose.p.coords),
                    _ => -1.0,
                };
        }
    }

    /// Column `k` for coordinate `axis` of a fixed point: `−wp` on the axis
    /// when the pose sits at that point (`own`), else zero.
    fn set_point_column(&mut self, k: usize, own: bool, axis: usize, wp: f64) {
        let n = self.params;
        for i in 0..6 {
            self.j[i * n + k] = if own && i == axis { -wp } else { 0.0 };
        }
    }

    /// The residual rows: the position residual `dp` (or the distance from a
    /// touched plane), then the orientation residual when measured.
    fn set_residual(&mut self, dp: &Vector3<f64>, channel: Channel, pose: &PoseGeometry) {
        let wp = pose.wp;
        for i in 0..3 {
            self.r[i] = dp[i] * wp;
        }
        self.position_rows = 3;
        self.channel = channel;
        if let Some((_, pl, normal)) = pose.touched {
            self.r = [0.0; 6];
            self.r[0] = (pl.offset - normal.dot(&pose.p.coords)) * wp;
            self.position_rows = 1;
        }
        self.orientation = pose.orientation.is_some() && pose.touched.is_none();
        if let Some(e) = pose.orientation {
            for i in 0..3 {
                self.r[3 + i] = e[i] * pose.wr;
            }
        }
    }
}

/// Poses whose rows [`NormalEquations::accumulate`] gathers before adding their
/// products: large enough for the matrix product to run at full speed, small
/// enough (a few MB) not to matter.
pub(super) const BLOCK_POSES: usize = 2048;

/// Poses whose normal equations [`NormalEquations::accumulate`] sums alone (on
/// one thread) before adding them to the others': a few blocks, so that 10⁵
/// poses already give each core several.
pub(super) const CHUNK_POSES: usize = 8 * BLOCK_POSES;

/// The normal equations of one weighted linearisation, summed pose by pose: all
/// that the fit, the separability test, the posterior and the statistics need of
/// it, in memory independent of the number of poses (`O(p²)`, plus
/// `O(BLOCK_POSES · p)` while accumulating).
///
/// Per channel ([`Channel`]: measured positions and orientations, point and
/// plane contacts) of the weighted Jacobian `J` and residual `r` of
/// [`for_each_pose_rows`] — each row divided by its channel's noise (`σ_c` in
/// m, or rad for orientations), so the residual is
/// in units of the noise and a column is the change of the predictions, in units
/// of the noise, per SI unit of its unknown:
/// - `jtj`: `JᵀJ`, params × params;
/// - `jtr`: `Jᵀr`, params × 1;
/// - `rtr`: `rᵀr`, the channel's weighted sum of squares;
/// - `rows`: the channel's rows (3 per pose, 1 per touch of a plane; 3 per
///   pose with an orientation).
///
/// Each channel is kept apart for the per-channel redundancy of
/// [`Posterior`], and so that a change of the noises is a scalar multiply of
/// each channel ([`NormalEquations::reweighted`]).
///
/// The known distances of a constraint session are rows of their own
/// (`distances`), each divided by its stated uncertainty and never reweighed.
#[derive(Clone)]
pub(super) struct NormalEquations {
    pub(super) jtj: PerChannel<Mat<f64>>,
    pub(super) jtr: PerChannel<Mat<f64>>,
    pub(super) rtr: PerChannel<f64>,
    pub(super) rows: PerChannel<usize>,
    pub(super) distances: DistanceRows,
}

/// The normal equations of the known-distance rows: `(L − |P_a − P_b|)/σ`,
/// whose Jacobian row is `u/σ` on the columns of `P_a` and `−u/σ` on those of
/// `P_b` (`u` the unit vector from `P_b` to `P_a`).
#[derive(Clone)]
pub(super) struct DistanceRows {
    pub(super) jtj: Mat<f64>,
    pub(super) jtr: Mat<f64>,
    pub(super) rtr: f64,
    pub(super) rows: usize,
}

impl DistanceRows {
    /// The rows of `model`'s distances over the unknowns `params`.
    pub(super) fn of(model: &Model, params: &[Unknown]) -> Self {
        let p = params.len();
        let mut sums = Self {
            jtj: Mat::zeros(p, p),
            jtr: Mat::zeros(p, 1),
            rtr: 0.0,
            rows: model.constraints.distances.len(),
        };
        for (row, r) in Self::rows(model, params) {
            for i in 0..p {
                sums.jtr[(i, 0)] += row[i] * r;
                for j in 0..p {
                    sums.jtj[(i, j)] += row[i] * row[j];
                }
            }
            sums.rtr += r * r;
        }
        sums
    }

    /// Each distance's weighted Jacobian row over `params` and weighted residual.
    pub(super) fn rows(model: &Model, params: &[Unknown]) -> Vec<(Vec<f64>, f64)> {
        let mut out = Vec::new();
        for d in &model.constraints.distances {
            let [a, b] = d
                .points
                .map(|k| model.points.get(k).copied().unwrap_or_else(Point3::origin));
            let v = a - b;
            let length = v.norm();
            let u = if length > 0.0 {
                v / length
            } else {
                Vector3::zeros()
            };
            let r = (d.length - length) / d.std;
            let row: Vec<f64> = params
                .iter()
                .map(|x| match *x {
                    Unknown::Point { point, axis } if point == d.points[0] => u[axis] / d.std,
                    Unknown::Point { point, axis } if point == d.points[1] => -u[axis] / d.std,
                    _ => 0.0,
                })
                .collect();
            out.push((row, r));
        }
        out
    }
}

impl NormalEquations {
    /// The normal equations of the linearisation at `model`: the poses in
    /// chunks of [`CHUNK_POSES`], each chunk's sums accumulated alone
    /// ([`NormalEquations::accumulate_chunk`]), on as many threads as the machine
    /// has, then added in pose order — the same sums whatever the number of
    /// threads. Once `cancel` is requested the chunks not started add
    /// nothing: the caller's next check drops the sums.
    pub(super) fn accumulate(
        model: &Model,
        data: Rows<'_>,
        params: &[Unknown],
        weights: &Weights,
        cancel: Cancel,
    ) -> Self {
        let chunks: Vec<Rows<'_>> = data.chunks(CHUNK_POSES).collect();
        let partials = parallel::map(&chunks, |c| {
            let c = if cancel.requested() {
                c.slice(0..0)
            } else {
                *c
            };
            Self::accumulate_chunk(model, c, params, weights)
        });
        let mut partials = partials.into_iter();
        let Some(mut sums) = partials.next() else {
            let mut sums = Self::accumulate_chunk(model, data, params, weights);
            sums.distances = DistanceRows::of(model, params);
            return sums;
        };
        sums.distances = DistanceRows::of(model, params);
        for part in partials {
            for c in Channel::ALL {
                sums.jtj[c] += &part.jtj[c];
                sums.jtr[c] += &part.jtr[c];
                sums.rtr[c] += part.rtr[c];
                sums.rows[c] += part.rows[c];
            }
        }
        sums
    }

    /// The normal equations of the poses `data` at `model`, their rows filled a
    /// block of [`BLOCK_POSES`] poses at a time into a reused block matrix
    /// whose `JᵀJ` (lower half) and `Jᵀr` are then added by faer's matrix product.
    pub(super) fn accumulate_chunk(
        model: &Model,
        data: Rows<'_>,
        params: &[Unknown],
        weights: &Weights,
    ) -> Self {
        let p = params.len();
        let mut rows = PerChannel::<usize>::default();
        for o in data {
            rows[o.channel()] += o.position_rows();
            rows[Channel::Orientation] += o.orientation_rows();
        }
        let mut sums = Self {
            jtj: PerChannel::from_fn(|_| Mat::zeros(p, p)),
            jtr: PerChannel::from_fn(|_| Mat::zeros(p, 1)),
            rtr: PerChannel::default(),
            rows,
            distances: DistanceRows {
                jtj: Mat::zeros(p, p),
                jtr: Mat::zeros(p, 1),
                rtr: 0.0,
                rows: 0,
            },
        };
        // Room for the rows of a block of poses in each channel the poses have.
        let block_rows = 3 * BLOCK_POSES.min(data.len().max(1));
        let capacity = rows.map(|_, &n| if n > 0 { block_rows } else { 0 });
        let mut block = Block {
            j: capacity.map(|_, &n| Mat::zeros(p, n)),
            r: capacity.map(|_, &n| Mat::zeros(n, 1)),
            filled: PerChannel::default(),
        };
        for_each_pose_rows(model, data, params, weights, |pose| {
            let orientation = pose.orientation.then_some((Channel::Orientation, 3, 3));
            for (c, offset, count) in
                std::iter::once((pose.channel, 0, pose.position_rows)).chain(orientation)
            {
                let row = block.filled[c];
                for i in 0..count {
                    block.r[c][(row + i, 0)] = pose.r[offset + i];
                    if p > 0 {
                        block
                            .row_mut(c, row + i)
                            .copy_from_slice(pose.row(offset + i));
                    }
                }
                block.filled[c] += count;
            }
            // Room for the next pose's rows in every channel.
            if Channel::ALL
                .iter()
                .any(|&c| capacity[c] > 0 && block.filled[c] + 3 > capacity[c])
            {
                block.add_to(&mut sums);
            }
        });
        block.add_to(&mut sums);
        // Mirror the lower halves.
        for g in &mut sums.jtj.0 {
            for a in 0..p {
                for b in a + 1..p {
                    g[(a, b)] = g[(b, a)];
                }
            }
        }
        sums
    }

    /// The weighted sum of squares of the residual.
    pub(super) fn cost(&self) -> f64 {
        self.rtr.0.iter().sum::<f64>() + self.distances.rtr
    }

    /// `JᵀJ` of every channel and of the distance rows.
    pub(super) fn normal_matrix(&self) -> Mat<f64> {
        let d = &self.distances.jtj;
        Mat::from_fn(d.nrows(), d.ncols(), |a, b| {
            self.jtj.0.iter().map(|g| g[(a, b)]).sum::<f64>() + d[(a, b)]
        })
    }

    /// `(Gs, Jsᵀr, scale)`: the normal matrix of the columns scaled to unit norm,
    /// its right-hand side, and the scale factors (`δ = scale · δs`). A zero column
    /// keeps scale 0 (it cannot move anything).
    pub(super) fn scaled_normal_equations(&self) -> (Mat<f64>, Mat<f64>, Vec<f64>) {
        let g = self.normal_matrix();
        let n = g.nrows();
        let scale = unit_diagonal_scale(&g);
        let gs = Mat::from_fn(n, n, |a, b| g[(a, b)] * scale[a] * scale[b]);
        let d = &self.distances.jtr;
        let rhs = Mat::from_fn(n, 1, |a, _| {
            (self.jtr.0.iter().map(|v| v[(a, 0)]).sum::<f64>() + d[(a, 0)]) * scale[a]
        });
        (gs, rhs, scale)
    }

    /// The normal equations of the parameters `columns` (indices into this one's):
    /// their rows and columns.
    pub(super) fn select_columns(&self, columns: &[usize]) -> Self {
        let n = columns.len();
        Self {
            jtj: self
                .jtj
                .map(|_, g| Mat::from_fn(n, n, |a, b| g[(columns[a], columns[b])])),
            jtr: self
                .jtr
                .map(|_, v| Mat::from_fn(n, 1, |a, _| v[(columns[a], 0)])),
            rtr: self.rtr,
            rows: self.rows,
            distances: DistanceRows {
                jtj: Mat::from_fn(n, n, |a, b| self.distances.jtj[(columns[a], columns[b])]),
                jtr: Mat::from_fn(n, 1, |a, _| self.distances.jtr[(columns[a], 0)]),
                rtr: self.distances.rtr,
                rows: self.distances.rows,
            },
        }
    }

    /// These normal equations with their rows weighed by `after` in place of
    /// `before`: the same linearisation at other noises, each channel
    /// multiplied by the square of its weight ratio.
    pub(super) fn reweighted(&self, before: &Weights, after: &Weights) -> Self {
        let mut next = self.clone();
        for c in Channel::ALL {
            // A weight unchanged (0 too: a channel not used) keeps its rows.
            let ratio = if after[c] == before[c] {
                1.0
            } else {
                after[c] / before[c]
            };
            let f = ratio * ratio;
            let (g, v) = (&mut next.jtj[c], &mut next.jtr[c]);
            for b in 0..g.ncols() {
                for a in 0..g.nrows() {
                    g[(a, b)] *= f;
                }
                v[(b, 0)] *= f;
            }
            next.rtr[c] *= f;
        }
        next
    }

    /// RMS of the unweighted residual of the rows that locate the tool point
    /// (3-D distance of a measured position or a fixed point, m; a touch of a
    /// plane counts a third) and of the orientation residual angle (rad), from
    /// the sums of squares.
    pub(super) fn residual_rms(&self, weights: &Weights) -> (f64, f64) {
        let located = [Channel::Position, Channel::Point, Channel::Plane];
        let sum = |c: Channel| self.rtr[c] / (weights[c] * weights[c]);
        let wr = weights[Channel::Orientation];
        // Orientation rows weighed 0 (not used) keep no residual here: the
        // fit measures them apart.
        let wr = if wr == 0.0 { f64::INFINITY } else { wr };
        rms_pair(
            located.iter().map(|&c| sum(c)).sum(),
            located.iter().map(|&c| self.rows[c]).sum::<usize>() / 3,
            self.rtr[Channel::Orientation] / (wr * wr),
            self.rows[Channel::Orientation] / 3,
        )
    }
}

/// The rows of up to [`BLOCK_POSES`] poses, per channel, waiting to be added to
/// [`NormalEquations`].
pub(super) struct Block {
    /// The Jacobian rows, transposed: params × rows, a row of `J` a column here.
    pub(super) j: PerChannel<Mat<f64>>,
    pub(super) r: PerChannel<Mat<f64>>,
    /// Rows filled, per channel.
    pub(super) filled: PerChannel<usize>,
}

impl Block {
    /// Row `row` of channel `c`'s Jacobian, to write.
    pub(super) fn row_mut(&mut self, c: Channel, row: usize) -> &mut [f64] {
        self.j[c]
            .col_mut(row)
            .try_as_col_major_mut()
            .expect("a column of an owned matrix is contiguous")
            .as_slice_mut()
    }

    /// Adds the filled rows' `JᵀJ` (lower half), `Jᵀr` and `rᵀr` to `sums`, and
    /// empties the block.
    pub(super) fn add_to(&mut self, sums: &mut NormalEquations) {
        for c in Channel::ALL {
            let n = self.filled[c];
            if n == 0 {
                continue;
            }
            let jt = self.j[c].as_ref().subcols(0, n);
            let r = self.r[c].as_ref().subrows(0, n);
            triangular::matmul(
                sums.jtj[c].as_mut(),
                BlockStructure::TriangularLower,
                Accum::Add,
                jt,
                BlockStructure::Rectangular,
                jt.transpose(),
                BlockStructure::Rectangular,
                1.0,
                Par::Seq,
            );
            matmul::matmul(sums.jtr[c].as_mut(), Accum::Add, jt, r, 1.0, Par::Seq);
            sums.rtr[c] += r.squared_norm_l2();
            self.filled[c] = 0;
        }
    }
}
