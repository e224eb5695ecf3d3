//! Repeated configurations: poses measured more than once.
//!
//! Trackers average repeated readings and engineers re-measure poses to see
//! the repeatability, so a session often holds the same configuration several
//! times. Two rows are one configuration when they are held to the same
//! contact, every joint reads the same within the encoder's resolution
//! ([`REVOLUTE_RESOLUTION`](crate::session::configurations::REVOLUTE_RESOLUTION), [`PRISMATIC_RESOLUTION`](crate::session::configurations::PRISMATIC_RESOLUTION)), each joint approached
//! from the same side (backlash) and the temperature and payload agree
//! ([`TEMPERATURE_RESOLUTION`](crate::session::configurations::TEMPERATURE_RESOLUTION), [`PAYLOAD_RESOLUTION`](crate::session::configurations::PAYLOAD_RESOLUTION)).
//!
//! A repeat adds no geometry: what the data can determine, how many poses
//! they hold for every data-sufficiency rule, and which rows a held-out fold
//! may separate are counted in distinct configurations. Repeats left in the
//! folds land in the training and the held-out set at once, and the held-out
//! error then measures the instrument's repeatability, not the model.
//!
//! The spread of the repeats about their configuration's mean is a model-free
//! estimate of the instrument noise (the pure error of a regression with
//! replicates: Draper & Smith, *Applied Regression Analysis*, 3rd ed., §2.1),
//!
//! `σ²_pe = Σ_g Σ_{i∈g} |x_i − x̄_g|² / (3 Σ_g (n_g − 1))` per axis,
//!
//! and the residuals of the model at the configurations' means are tested
//! against it (the lack-of-fit test): a mean of `n_g` readings scatters by
//! `σ²_pe / n_g` when the model is right, so
//!
//! `F = s²_means / (σ²_pe · mean_g(1 / n_g))`
//!
//! follows `F(R, ν_pe)` (`R` the redundancy of the fit to the means, `ν_pe`
//! the pure error's degrees of freedom). A larger `F` is lack of fit: what
//! the model still leaves (an effect not modelled, or the robot's own
//! repeatability, which repeated readings of one reach do not see).
//!
//! Units: SI (m, rad, °C, kg).

use crate::calibration::validation::stats::f_cdf;

use crate::session::configurations::PureError;

/// The lack-of-fit test of a model fitted to the configurations' means.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LackOfFit {
    /// The instrument noise from the repeats.
    pub pure: PureError,
    /// The noise per axis the model's residuals at the means show, m.
    pub shown: f64,
    /// What the instrument alone would leave at the means, `σ_pe √mean(1/n_g)`, m.
    pub expected: f64,
    /// `F = shown² / expected²`.
    pub f: f64,
    /// Its `1 − α` quantile of `F(R, ν_pe)`.
    pub threshold: f64,
    /// The chance of an `F` this large when the model is right.
    pub p: f64,
}

impl LackOfFit {
    /// The test of residuals showing `shown` per axis with redundancy
    /// `redundancy` against `pure` (`mean_inverse_count`:
    /// [`Configurations::mean_inverse_count`](crate::session::configurations::Configurations::mean_inverse_count)) at level `alpha`.
    pub fn test(
        pure: PureError,
        shown: f64,
        redundancy: f64,
        mean_inverse_count: f64,
        alpha: f64,
    ) -> Self {
        let expected = pure.sigma * mean_inverse_count.sqrt();
        let f = (shown / expected.max(f64::MIN_POSITIVE)).powi(2);
        let (d1, d2) = (redundancy.max(1.0), pure.dof as f64);
        Self {
            pure,
            shown,
            expected,
            f,
            threshold: crate::calibration::validation::stats::f_quantile(1.0 - alpha, d1, d2),
            p: 1.0 - f_cdf(f, d1, d2),
        }
    }

    /// Whether the model leaves more than the instrument's noise.
    pub fn significant(&self) -> bool {
        self.f > self.threshold
    }
}

#[cfg(test)]
mod tests {
    use crate::calibration::simulate::{Scenario, simulate};
    use crate::io::model_file::load_model;
    use crate::session::configurations::Configurations;
    use nalgebra::Vector3;

    /// Each of 12 poses repeated five times, each repeat read with its own
    /// tracker noise (20 µm per axis) and the joints with encoder jitter below
    /// the resolution: 12 configurations of 5 rows, and the pure error the
    /// simulated 20 µm within its sampling error (144 degrees of freedom:
    /// a relative standard error of 1/√288 = 6 %; 20 % is over three).
    #[test]
    fn repeats_are_one_configuration_and_show_the_noise() {
        let robot = load_model("ur5e").unwrap().robot;
        let truth = simulate(
            &robot,
            &Scenario {
                position_noise: 0.0,
                ..Scenario::tracker(12, 2)
            },
        )
        .unwrap();
        let mut rng = 1u64;
        let mut noise = || {
            // A small deterministic generator: the sum of twelve uniforms less
            // six is close to a standard normal.
            (0..12)
                .map(|_| {
                    rng = rng
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    (rng >> 11) as f64 / (1u64 << 53) as f64
                })
                .sum::<f64>()
                - 6.0
        };
        let mut data = Vec::new();
        for _ in 0..5 {
            for o in &truth.observations {
                let mut o = o.clone();
                for q in &mut o.q {
                    *q += 2e-6 * noise();
                }
                o.position += Vector3::new(noise(), noise(), noise()) * 20e-6;
                data.push(o);
            }
        }
        let c = Configurations::of(&robot, &data, crate::cancel::Cancel::NEVER);
        assert_eq!(c.count(), 12);
        assert!(c.rows.iter().all(|r| r.len() == 5));
        let pure = c.pure_error(&data).unwrap();
        assert_eq!((pure.dof, pure.repeated), (144, 12));
        assert!((pure.sigma / 20e-6 - 1.0).abs() < 0.2, "{pure:?}");
    }
}
