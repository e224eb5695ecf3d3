//! The measurement noise of each channel, estimated from the residuals as
//! variance components.
//!
//! A channel is a kind of measurement ([`Channel`]): measured positions and
//! orientations, and the two kinds of contact of a session without a tracker,
//! a tool point at an unknown fixed point (a ball in a socket: 3 rows, tool
//! point less fixed point) and a tool point on an unknown plane (a probe on a
//! plate: 1 row, the signed distance to the plane). Each seats or scatters
//! differently, so each has its own noise. Each row of the fit is divided by
//! its channel's noise `σ_c` (m, or rad for orientation rows). At the solution, with the weighted Jacobian
//! `J`, the prior precision `P` ([`super::prior`]) and `N = JᵀJ + P`, channel
//! `c` has the weighted sum of squares `Ω_c` and the redundancy
//! `r_c = n_c − tr(N⁻¹ J_cᵀ J_c)`: its rows' count less the share of the
//! parameters they determine. Förstner's simplified form of Helmert's
//! variance-component estimator (Koch, *Parameter Estimation and Hypothesis
//! Testing in Linear Models*, 2nd ed., §3.6) updates
//!
//! `σ_c² ← σ_c² · Ω_c / r_c`
//!
//! and the fit is repeated with the new weights until the estimates settle (to
//! [`SETTLED`]). With one channel this is the familiar `s² = RSS / (n − p)`;
//! with two it weighs a camera's 5 mrad orientations against its 1 mm
//! positions by what each delivers, and a channel whose rows scatter far more
//! than the other's gets a weight to match: it adds only the information it
//! carries. A stated noise (`--position-noise`, `--orientation-noise`) is used as
//! given, and the noise its residuals show is reported beside it. A stated
//! position noise is the noise of every row that locates the tool point:
//! measured positions and both kinds of contact, unless `--point-noise` or
//! `--plane-noise` states a kind's own; without any, each kind present is
//! estimated on its own.
//!
//! The known distances of a constraint session are a length standard: their
//! rows keep the uncertainty each line states and are never reweighed; the
//! noise their residuals show, `σ̄ √(Ω_d / r_d)` with `σ̄` the RMS of the stated
//! uncertainties, is reported beside it.

use crate::session::channel::{Channel, PerChannel};

/// The weight of each channel's rows, `1/σ_c`.
pub type Weights = PerChannel<f64>;

impl Weights {
    /// The weights of the noises `noise`.
    pub fn of(noise: &PerChannel<f64>) -> Self {
        noise.map(|_, s| 1.0 / s)
    }
}

/// A channel's noise as an option gives it: the value, and whether it is the
/// user's or a start to estimate from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Noise {
    /// One standard deviation per axis, m or rad.
    pub sigma: f64,
    /// Stated or estimated.
    pub source: NoiseSource,
}

/// Where a channel's noise comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NoiseSource {
    /// Given by the user; the fit weighs the rows by it.
    Stated,
    /// Estimated from the residuals (variance components).
    Estimated,
}

/// Relative change of every estimated noise below which the estimates have settled.
pub const SETTLED: f64 = 1e-3;

/// The smallest noise an estimate may take (m or rad): noise-free (simulated)
/// data would otherwise drive the weights to infinity.
pub const FLOOR: f64 = 1e-9;

/// One channel's noise: the one the fit used and the one its residuals show.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ChannelNoise {
    /// Where the noise the fit used came from.
    pub source: NoiseSource,
    /// The noise the rows were divided by: one standard deviation per axis, m or rad.
    pub used: f64,
    /// The noise the residuals show, `σ √(Ω / r)`: equal to `used` when estimated.
    pub shown: f64,
    /// The channel's rows.
    pub rows: usize,
    /// Its redundancy `r_c` (rows less the parameters' share they determine).
    pub redundancy: f64,
}

impl ChannelNoise {
    /// The variance-component update of this channel's noise from its weighted
    /// sum of squares `omega` and redundancy `redundancy`; the noise is kept when
    /// the channel has too little redundancy to estimate it (below one row).
    pub fn update(used: f64, omega: f64, redundancy: f64) -> f64 {
        if redundancy < 1.0 || !omega.is_finite() {
            return used;
        }
        (used * (omega / redundancy).sqrt()).max(FLOOR)
    }
}

/// The noise of every channel after a fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseEstimate {
    /// Positions, m per axis (no rows in a session without a tracker).
    pub position: ChannelNoise,
    /// Orientations, rad per axis, when measured.
    pub orientation: Option<ChannelNoise>,
    /// Tool points at unknown fixed points, m per axis, when the data have them.
    pub point: Option<ChannelNoise>,
    /// Tool points on unknown planes, m along the normal, when the data have them.
    pub plane: Option<ChannelNoise>,
    /// The known distances, m, when the data have them: always
    /// [`NoiseSource::Stated`], `used` the RMS of their stated uncertainties.
    pub distance: Option<ChannelNoise>,
}

impl NoiseEstimate {
    /// The noise of channel `c`, when the data have it.
    pub fn channel(&self, c: Channel) -> Option<ChannelNoise> {
        match c {
            Channel::Position => Some(self.position),
            Channel::Orientation => self.orientation,
            Channel::Point => self.point,
            Channel::Plane => self.plane,
        }
    }

    /// The noise of the rows that locate the tool point: the measured
    /// positions, or in a session without a tracker the point contacts, else
    /// the plane contacts.
    pub fn tool_point(&self) -> ChannelNoise {
        [self.point, self.plane]
            .into_iter()
            .flatten()
            .find(|_| self.position.rows == 0)
            .unwrap_or(self.position)
    }

    /// The channels the data have rows in, in report order, the known
    /// distances last (`None`): what the reports list. Positions are listed
    /// whenever nothing else locates the tool point.
    pub fn rows(&self) -> Vec<(Option<Channel>, ChannelNoise)> {
        let contacts = self.point.is_some() || self.plane.is_some();
        Channel::ALL
            .into_iter()
            .filter_map(|c| self.channel(c).map(|n| (c, n)))
            .filter(|(c, n)| *c != Channel::Position || n.rows > 0 || !contacts)
            .map(|(c, n)| (Some(c), n))
            .chain(self.distance.map(|n| (None, n)))
            .collect()
    }
}
