//! Geometric identification: the D-H parameter errors from measured poses.
//!
//! | module | model |
//! | --- | --- |
//! | [`paper`] | `--params paper`: the 3M position-independent model and the Iterative Regression Algorithm of Mirman & Gupta (1992), as the paper gives them |

pub mod paper;
