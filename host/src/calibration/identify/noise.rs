//! The measurement noise of each channel (positions, orientations), estimated
//! from the residuals as variance components.
//!
//! Each row of the fit is divided by its channel's noise `σ_c` (m for position
//! rows, rad for orientation rows). At the solution, with the weighted Jacobian
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
//! given, and the noise its residuals show is reported beside it.

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

/// The noise of both channels after a fit.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoiseEstimate {
    /// Positions, m per axis.
    pub position: ChannelNoise,
    /// Orientations, rad per axis, when measured.
    pub orientation: Option<ChannelNoise>,
}
