//! Geometric identification: the D-H parameter errors from measured poses.
//!
//! | module | model |
//! | --- | --- |
//! | [`full`] | `--params full` (the default): joint offsets, every `s, a, α`, base and tool, weighted Levenberg–Marquardt with a rank-revealing Cholesky, standard errors and observability |
//! | [`paper`] | `--params paper`: the 3M position-independent model and the Iterative Regression Algorithm of Mirman & Gupta (1992), as the paper gives them |

pub mod full;
pub mod paper;
