//! What is known of the geometry before measuring: the prior on the D-H
//! parameter errors, and which parameters a candidate model frees.
//!
//! ## The prior
//! A real arm is built to tolerances: each D-H parameter's error has a scale,
//! about 1 mm for a length and 1 mrad for an angle on an industrial arm. The
//! identification estimates the maximum a-posteriori parameters (Tikhonov
//! regularisation in the whitened parameters): it minimises
//!
//! `Σ_rows (r / σ)² + Σ_params ((x − x_nominal) / τ)²`
//!
//! with the measurement noise `σ` of each row's channel and the prior scale `τ`
//! of each D-H parameter ([`Prior::length`](crate::session::prior::Prior::length) for `s` and `a`, [`Prior::angle`](crate::session::prior::Prior::angle)
//! for `θ`, `α` and the Hayati tilts `β`). The base and the tool have no prior:
//! they are where the instrument and the tool happen to be, not built to a
//! drawing. Effect parameters have none either; the diagnosis admits an effect
//! only on held-out evidence.
//!
//! A parameter the data determine well lands where the data put it; one they
//! determine poorly (a near-dependence, too few poses) stays within its
//! tolerance of nominal instead of taking a wild value that fits the noise. The
//! share the data have in an estimate is the diagonal of the resolution matrix
//! `(JᵀWJ + P)⁻¹ JᵀWJ`: 1 when the data alone determine it, 0 when the prior
//! alone holds it.
//!
//! ## The candidate models
//! [`Geometry`] names the nested geometric models the diagnosis compares on
//! held-out poses: the registration alone (base and tool), the joint offsets,
//! every length, every D-H parameter.
//!
//! Units: SI (m, rad).

use armcal_shared::{JointType, Param, Robot};

/// The nested geometric models, from the fewest parameters to the most; each
/// adds to the one before it. The base and the tool are free in all of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Geometry {
    /// The base and the tool: the instrument's registration, the robot nominal.
    Registration,
    /// And each joint's offset (`θ` of a revolute joint, `s` of a prismatic one).
    Offsets,
    /// And every link length (`s`, `a`).
    Lengths,
    /// And every twist (`α`): every D-H parameter.
    Full,
}

impl Geometry {
    /// Every model, fewest parameters first.
    pub const ALL: [Self; 4] = [Self::Registration, Self::Offsets, Self::Lengths, Self::Full];

    /// The name in reports and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Self::Registration => "registration",
            Self::Offsets => "offsets",
            Self::Lengths => "lengths",
            Self::Full => "full",
        }
    }

    /// Whether this model frees `param` of `robot`.
    pub fn frees(self, robot: &Robot<f64>, param: Param) -> bool {
        let offset = |j: usize, p: Param| match robot.links.get(j).map(|l| l.joint) {
            Some(JointType::Revolute) => matches!(p, Param::Theta(_)),
            Some(JointType::Prismatic) => matches!(p, Param::S(_)),
            None => false,
        };
        match param {
            Param::Base(_) | Param::Tool(_) => true,
            Param::Theta(j) | Param::S(j) if self >= Self::Offsets && offset(j, param) => true,
            Param::S(_) | Param::A(_) => self >= Self::Lengths,
            Param::Theta(_) | Param::Alpha(_) | Param::Beta(_) => self >= Self::Full,
        }
    }
}
