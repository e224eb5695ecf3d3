//! The special Jacobians of Mirman & Gupta, the base and tool columns, and the
//! manipulator Jacobian, all analytic.
//!
//! A column is the [`Twist`] `[νdφ; dη]` that a unit change of one parameter
//! causes in the measured frame: `(∂T/∂p)·T⁻¹` split as in eq. (12). For link `m`
//! with the lines of [`LinkAxes`] (eqs. 51–54):
//!
//! ```text
//! J_θ[:, m] = [ w_m ; ρ_m × w_m ]          J_s[:, m] = [ 0 ; w_m ]
//! J_α[:, m] = [ u_{m+1} ; σ_{m+1} × u_{m+1} ]   J_a[:, m] = [ 0 ; u_{m+1} ]
//! ```
//!
//! The columns of J_θ and J_α are the Plücker coordinates of the link's z and x
//! lines: a revolute motion about a line. Those of J_s and J_a are prismatic
//! motions along them. The base and tool frames `Trans(x, y, z) Rot_z(yaw)
//! Rot_y(pitch) Rot_x(roll)` are chains of six such elementary motions, so their
//! columns have the same form, with the rotation axes `z`, `Rot_z(yaw)·y` and
//! `Rot_z(yaw)·Rot_y(pitch)·x` of the parent frame through the frame's origin.
//!
//! The manipulator Jacobian is the hybrid of J_θ (revolute joints) and J_s
//! (prismatic joints) that relates joint velocities to the twist of the measured
//! frame. For a laser tracker that sees only the measured point `P`, a column
//! maps to the point's displacement `dP = dη + νdφ × P` (eq. 8), see [`at_point`].

use nalgebra::{Dyn, IsometryMatrix3, MatrixView, Point3, SMatrix, U1, U6, Vector3, Vector6};

use crate::{Chain, FrameAxes, FrameAxis, JointType, LinkAxes, MAX_JOINTS, Param, Real};

/// A Jacobian column or an end-effector error: `[νdφ; dη]`, rotation first.
pub type Twist<T> = Vector6<T>;

/// The twist of a revolute motion about the line through `point` along `axis`:
/// `[axis; point × axis]`.
#[inline]
pub fn revolute_twist<T: Real>(axis: &Vector3<T>, point: &Point3<T>) -> Twist<T> {
    let m = point.coords.cross(axis);
    Twist::new(axis.x, axis.y, axis.z, m.x, m.y, m.z)
}

/// The twist of a prismatic motion along `axis`: `[0; axis]`.
#[inline]
pub fn prismatic_twist<T: Real>(axis: &Vector3<T>) -> Twist<T> {
    let z = T::zero();
    Twist::new(z, z, z, axis.x, axis.y, axis.z)
}

/// The displacement `dP = dη + νdφ × P` of the point `P` under the twist `col` (eq. 8).
#[inline]
pub fn at_point<T: Real>(col: &Twist<T>, p: &Point3<T>) -> Vector3<T> {
    let rot = col.fixed_rows::<3>(0);
    let trans = col.fixed_rows::<3>(3);
    trans + rot.cross(&p.coords)
}

/// A 6 × M Jacobian held in fixed storage (no allocation), `M ≤ MAX_JOINTS`.
#[derive(Clone, Debug, PartialEq)]
pub struct Jacobian6<T: Real> {
    cols: usize,
    m: SMatrix<T, 6, MAX_JOINTS>,
}

impl<T: Real> Jacobian6<T> {
    fn from_columns(n: usize, mut col: impl FnMut(usize) -> Twist<T>) -> Self {
        let mut m = SMatrix::<T, 6, MAX_JOINTS>::zeros();
        for i in 0..n {
            m.set_column(i, &col(i));
        }
        Self { cols: n, m }
    }

    /// The number of columns, M.
    #[inline]
    pub fn ncols(&self) -> usize {
        self.cols
    }

    /// The 6 × M matrix.
    #[inline]
    pub fn view(&self) -> MatrixView<'_, T, U6, Dyn, U1, U6> {
        self.m.columns(0, self.cols)
    }

    /// Column `i` (0-based).
    #[inline]
    pub fn column(&self, i: usize) -> Twist<T> {
        self.m.column(i).into_owned()
    }
}

/// The four special Jacobians of Mirman & Gupta eqs. (51)–(54) at one configuration.
#[derive(Clone, Debug, PartialEq)]
pub struct SpecialJacobians<T: Real> {
    /// `J_θ`, eq. (51): the effect of each `dθ_m`.
    pub theta: Jacobian6<T>,
    /// `J_s`, eq. (52): the effect of each `ds_m`.
    pub s: Jacobian6<T>,
    /// `J_α`, eq. (53): the effect of each `dα_m`.
    pub alpha: Jacobian6<T>,
    /// `J_a`, eq. (54): the effect of each `da_m`.
    pub a: Jacobian6<T>,
}

impl<T: Real> Chain<T> {
    /// Column `m` (0-based joint) of `J_θ`: `[w_m; ρ_m × w_m]`.
    #[inline]
    pub fn theta_column(&self, m: usize) -> Twist<T> {
        let LinkAxes { w, rho, .. } = &self.axes[m];
        revolute_twist(w, rho)
    }

    /// Column `m` of `J_s`: `[0; w_m]`.
    #[inline]
    pub fn s_column(&self, m: usize) -> Twist<T> {
        prismatic_twist(&self.axes[m].w)
    }

    /// Column `m` of `J_α`: `[u_{m+1}; σ_{m+1} × u_{m+1}]`.
    #[inline]
    pub fn alpha_column(&self, m: usize) -> Twist<T> {
        let LinkAxes { u, sigma, .. } = &self.axes[m];
        revolute_twist(u, sigma)
    }

    /// Column `m` of `J_a`: `[0; u_{m+1}]`.
    #[inline]
    pub fn a_column(&self, m: usize) -> Twist<T> {
        prismatic_twist(&self.axes[m].u)
    }

    /// The column of Hayati's tilt `β_m` (rotation about the line `(v, τ)`).
    #[inline]
    pub fn beta_column(&self, m: usize) -> Twist<T> {
        let LinkAxes { v, tau, .. } = &self.axes[m];
        revolute_twist(v, tau)
    }

    /// The four special Jacobians.
    pub fn special_jacobians(&self) -> SpecialJacobians<T> {
        let n = self.dof();
        SpecialJacobians {
            theta: Jacobian6::from_columns(n, |m| self.theta_column(m)),
            s: Jacobian6::from_columns(n, |m| self.s_column(m)),
            alpha: Jacobian6::from_columns(n, |m| self.alpha_column(m)),
            a: Jacobian6::from_columns(n, |m| self.a_column(m)),
        }
    }

    /// The manipulator Jacobian: column `m` is `J_θ[:, m]` for a revolute joint and
    /// `J_s[:, m]` for a prismatic one, so that `dT·T⁻¹ = J dq`.
    pub fn manipulator_jacobian(&self) -> Jacobian6<T> {
        Jacobian6::from_columns(self.dof(), |m| match self.joints[m] {
            JointType::Revolute => self.theta_column(m),
            JointType::Prismatic => self.s_column(m),
        })
    }

    /// The column of the base parameter `axis`.
    pub fn base_column(&self, axis: FrameAxis) -> Twist<T> {
        frame_column(&IsometryMatrix3::identity(), &self.base_axes, axis)
    }

    /// The column of the tool parameter `axis`.
    pub fn tool_column(&self, axis: FrameAxis) -> Twist<T> {
        frame_column(&self.flange, &self.tool_axes, axis)
    }

    /// The columns of all six base parameters, in the order of [`FrameAxis::ALL`].
    /// They do not depend on the configuration.
    pub fn base_columns(&self) -> [Twist<T>; 6] {
        FrameAxis::ALL.map(|ax| self.base_column(ax))
    }

    /// The columns of all six tool parameters, in the order of [`FrameAxis::ALL`].
    pub fn tool_columns(&self) -> [Twist<T>; 6] {
        let r = self.flange.rotation.matrix();
        let origin = self.flange * self.tool_axes.origin;
        let axes = &self.tool_axes;
        [
            prismatic_twist(&r.column(0).into_owned()),
            prismatic_twist(&r.column(1).into_owned()),
            prismatic_twist(&r.column(2).into_owned()),
            revolute_twist(&(r * axes.roll), &origin),
            revolute_twist(&(r * axes.pitch), &origin),
            revolute_twist(&(r * axes.yaw), &origin),
        ]
    }

    /// The column of any geometric parameter.
    ///
    /// # Panics
    /// If a joint index is not below [`Chain::dof`].
    #[inline(always)]
    pub fn column(&self, param: Param) -> Twist<T> {
        match param {
            Param::Theta(m) => self.theta_column(m),
            Param::S(m) => self.s_column(m),
            Param::A(m) => self.a_column(m),
            Param::Alpha(m) => self.alpha_column(m),
            Param::Beta(m) => self.beta_column(m),
            Param::Base(ax) => self.base_column(ax),
            Param::Tool(ax) => self.tool_column(ax),
        }
    }
}

/// The column of one parameter of a base or tool frame whose parent is `parent`
/// (the identity for the base, the flange for the tool), from the frame's lines.
fn frame_column<T: Real>(
    parent: &IsometryMatrix3<T>,
    axes: &FrameAxes<T>,
    axis: FrameAxis,
) -> Twist<T> {
    let r = parent.rotation.matrix();
    let origin = parent * axes.origin;
    match axis {
        FrameAxis::X => prismatic_twist(&r.column(0).into_owned()),
        FrameAxis::Y => prismatic_twist(&r.column(1).into_owned()),
        FrameAxis::Z => prismatic_twist(&r.column(2).into_owned()),
        FrameAxis::Rz => revolute_twist(&(r * axes.yaw), &origin),
        FrameAxis::Ry => revolute_twist(&(r * axes.pitch), &origin),
        FrameAxis::Rx => revolute_twist(&(r * axes.roll), &origin),
    }
}
