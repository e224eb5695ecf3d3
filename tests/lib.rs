//! Helpers of the end-to-end tests: the host's simulator, re-exported.

pub use armcal::simulate::{measure, random_configurations, rng, with_random_errors};
