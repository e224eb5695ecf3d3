//! `armcal reproduce kirchner`: Kirchner, Gurumoorthy & Prinz, "A Perturbation
//! Approach to Robot Calibration", CMU-RI-TR-85-9 (1985), sections 2 and 3, rebuilt.
//!
//! The paper has no numerical example of a whole robot (its only numbers are the
//! single Stanford link of eq. 2.21, tested in `armcal-shared`), so both parts run
//! on the PUMA of Mirman & Gupta's Table 1 ([`puma_in_inches`]), standard D-H
//! as in the paper (its eq. 2.1 is Paul's), inches and radians.
//!
//! **(a) Section 2, eq. 2.22.** The real forward solution `T^r` against its
//! expansion to first and to second order in all 24 joint-link errors, at Table 1's
//! position 1: the first-order residual shrinks by 4 and the second-order one by 8
//! when the errors are halved. With the paper's literal second-order coefficient
//! `∂²T/∂p_i∂p_j` (no ½) the residual is still of second order.
//!
//! **(b) Section 3, eqs. 3.3–3.7.** The Cartesian coordinates `x` are the pose
//! error `[νdφ; dη]` of Mirman & Gupta eq. 15, `pose_error(T^r, T^i)`, in the
//! measurement frame (rad, in). Four calibration poses (Table 1's positions 1–4)
//! give the 24 equations (3.4)
//!
//! ```text
//! Δx_i = Σ_j K^i_j Δp_j + Σ_j Σ_k Δp_j L^i_jk Δp_k + …        i = 1 … 24     (3.4)
//! ```
//!
//! for the 24 errors `Δp = (Δθ_m, Δα_m, Δa_m, Δs_m)`, `m = 1 … 6`, with `K` from
//! the special-Jacobian columns and `L` from [`armcal_shared::perturbation`]. The
//! series is inverted (3.7):
//!
//! ```text
//! Δp = K⁻¹ { Δx − (K⁻¹Δx)ᵀ L (K⁻¹Δx) + … }                                   (3.7)
//! ```
//!
//! first to first order (`K⁻¹Δx`), then to second (3.7 as printed), then to all
//! orders: the fixed point of `Δp = Δp + K⁻¹(Δx − x(Δp))` with the exact forward
//! solution `x(Δp)`, whose n-th iterate agrees with the inverted series to order n.
//!
//! For the PUMA, `K` is singular: `α_2 = 0` makes the joint axes z₁ and z₂
//! parallel, so the columns of `s_2` and `s_3` are equal at every pose, and 24
//! equations do not determine 24 unknowns. As Mirman & Gupta do in their first
//! iteration, the later of a dependent pair (`s_3`) is held at zero; the other 23
//! are solved in least squares (`K⁺`, the pseudo-inverse the paper names for
//! over-determined sets). The comparison with the Iterative Regression Algorithm
//! ([`identify_paper`], Mirman & Gupta's 3M model: `α, a, s`, no `θ` offsets) runs
//! on the same four exact poses and is made on the parameters both estimate:
//! every `α` and `a`, `s_1, s_4, s_5, s_6` and the sum `s_2 + s_3`.

use std::fmt::Write as _;

use armcal_shared::{Param, Robot, Twist, pose_error};
use nalgebra::{DMatrix, DVector, Matrix4};

use crate::calibration::identify::paper::{PaperFit, PaperOptions, PaperPose, identify_paper};
use crate::calibration::reproduce::mirman_gupta::{TABLE1_POSITIONS, puma_in_inches};

/// The four calibration poses of section 3: Table 1's positions 1–4, rad.
pub fn calibration_poses() -> [[f64; 6]; 4] {
    [
        TABLE1_POSITIONS[0],
        TABLE1_POSITIONS[1],
        TABLE1_POSITIONS[2],
        TABLE1_POSITIONS[3],
    ]
}

/// The paper's 24 joint-link parameters of a 6-joint robot (4M in general):
/// every `θ`, every `α`, every `a`, every `s` (the paper's `r`).
pub fn joint_link_params(robot: &Robot<f64>) -> Vec<Param> {
    let m = robot.dof();
    (0..m)
        .map(Param::Theta)
        .chain((0..m).map(Param::Alpha))
        .chain((0..m).map(Param::A))
        .chain((0..m).map(Param::S))
        .collect()
}

/// Built-in errors in Mirman & Gupta's Table 2 pattern, alternating in sign:
/// `α_1 = −rot, α_2 = +rot, …`, `a_1 = +trans, a_2 = −trans, …`,
/// `s_1 = −trans, s_2 = +trans, …`, and, if `theta`, joint offsets
/// `θ_1 = +rot, θ_2 = −rot, …` (Table 2 has none).
pub fn built_in_errors(params: &[Param], rot: f64, trans: f64, theta: bool) -> Vec<f64> {
    let sign = |m: usize, first: f64| if m.is_multiple_of(2) { first } else { -first };
    params
        .iter()
        .map(|p| match *p {
            Param::Alpha(m) => sign(m, -rot),
            Param::A(m) => sign(m, trans),
            Param::S(m) => sign(m, -trans),
            Param::Theta(m) if theta => sign(m, rot),
            _ => 0.0,
        })
        .collect()
}

/// `nominal` with `errors` added to `params`.
pub fn with_errors(nominal: &Robot<f64>, params: &[Param], errors: &[f64]) -> Robot<f64> {
    let mut robot = nominal.clone();
    for (p, e) in params.iter().zip(errors) {
        if let Some(v) = robot.param_mut(*p) {
            *v += e;
        }
    }
    robot
}

fn pairs(params: &[Param], errors: &[f64]) -> Vec<(Param, f64)> {
    params.iter().copied().zip(errors.iter().copied()).collect()
}

/// One row of part (a): the residuals of the expansions against the exact `T^r`,
/// each as `(point, orientation)`: `|ΔP|` in inches and `|ΔR|` (Frobenius).
#[derive(Clone, Copy, Debug)]
pub struct ExpansionRow {
    /// The error level: `±ε` rad on every `θ` and `α`, `±ε/10` in on every `a` and `s`.
    pub eps: f64,
    /// `T^r − (T^i + Σ K_i Δp_i)`.
    pub first: (f64, f64),
    /// `T^r − (T^i + Σ K_i Δp_i + Σ Δp_i L_ij Δp_j)`, eq. 2.22.
    pub second: (f64, f64),
    /// The same with the paper's literal `L_ij = ∂²T/∂p_i∂p_j` (no ½).
    pub literal: (f64, f64),
}

/// Part (a): the residuals at Table 1's position 1, for each level in `levels`.
pub fn expansion_rows(levels: &[f64]) -> Vec<ExpansionRow> {
    let nominal = puma_in_inches();
    let params = joint_link_params(&nominal);
    let q = TABLE1_POSITIONS[0];
    levels
        .iter()
        .map(|&eps| {
            let errors = built_in_errors(&params, eps, eps / 10.0, true);
            let exact = with_errors(&nominal, &params, &errors)
                .forward(&q)
                .expect("six joints")
                .to_homogeneous();
            let pert = nominal
                .perturbation(&q, &pairs(&params, &errors))
                .expect("six joints, joint parameters");
            let t = pert.nominal.to_homogeneous();
            let residual = |predicted: Matrix4<f64>| {
                let d = exact - predicted;
                (
                    d.fixed_view::<3, 1>(0, 3).norm(),
                    d.fixed_view::<3, 3>(0, 0).norm(),
                )
            };
            ExpansionRow {
                eps,
                first: residual(pert.frame_first_order()),
                second: residual(pert.frame()),
                literal: residual(pert.frame_first_order() + pert.second * 2.0 * t),
            }
        })
        .collect()
}

/// The series inversion of section 3 from the data of `poses`.
#[derive(Clone, Debug)]
pub struct SeriesInversion {
    /// The 24 joint-link parameters, in the order of the estimates.
    pub params: Vec<Param>,
    /// Parameters held at zero, each with the one its column depends on.
    pub held: Vec<(Param, Param)>,
    /// Singular values of `K` (24 × 24) with its columns scaled to unit length,
    /// largest first: one is zero per dependent pair.
    pub singular_values: Vec<f64>,
    /// The rounding floor of each estimate, `Σ_i |K⁺_ji| δx_i`, with `δx_i` the
    /// rounding of one datum: `4 k ε_mach` for a rotation row and `4 k ε_mach L`
    /// for a translation row (`k = 16 (M + 2)` operations per forward solution on
    /// numbers bounded by 1 and by the reach `L`; two solutions make a datum, two
    /// more the model's prediction). No digit below it is certain; 0 for a held
    /// parameter.
    pub floor: Vec<f64>,
    /// `K⁺Δx`: the inversion to first order.
    pub first: Vec<f64>,
    /// Eq. 3.7: `K⁺{Δx − (K⁺Δx)ᵀ L (K⁺Δx)}`, the inversion to second order.
    pub second: Vec<f64>,
    /// The iterates `Δp_{n+1} = Δp_n + K⁺(Δx − x(Δp_n))` from `Δp_0 = 0`, until a
    /// step is below [`SeriesInversion::floor`] in every parameter: the inversion to all orders (the
    /// first iterate is [`SeriesInversion::first`]).
    pub iterates: Vec<Vec<f64>>,
    /// `|Δx − x(Δp)|` (rad and in mixed, as in `x`) of the last iterate.
    pub residual: f64,
}

impl SeriesInversion {
    /// The last iterate: the inversion to all orders.
    pub fn all_orders(&self) -> &[f64] {
        self.iterates.last().map_or(&self.first, |v| v)
    }

    /// Over every parameter not held: the worst `|estimate − truth|` and the worst
    /// rounding floor, each as `(angles rad, lengths in)`.
    pub fn worst_all(&self, estimate: &[f64], truth: &[f64]) -> ((f64, f64), (f64, f64)) {
        let mut err = (0.0f64, 0.0f64);
        let mut floor = (0.0f64, 0.0f64);
        for (j, p) in self.params.iter().enumerate() {
            if self.held.iter().any(|(h, _)| h == p) {
                continue;
            }
            let e = (estimate[j] - truth[j]).abs();
            if p.is_angle() {
                err.0 = err.0.max(e);
                floor.0 = floor.0.max(self.floor[j]);
            } else {
                err.1 = err.1.max(e);
                floor.1 = floor.1.max(self.floor[j]);
            }
        }
        (err, floor)
    }
}

/// `pose_error(T(p + Δp), T(p))` at every pose, stacked: `x(Δp)`.
fn forward_errors(
    nominal: &Robot<f64>,
    poses: &[[f64; 6]],
    params: &[Param],
    dp: &[f64],
) -> DVector<f64> {
    let real = with_errors(nominal, params, dp);
    let mut x = DVector::zeros(6 * poses.len());
    for (n, q) in poses.iter().enumerate() {
        let e = pose_error(
            &real.forward(q).expect("six joints"),
            &nominal.forward(q).expect("six joints"),
        );
        x.fixed_rows_mut::<6>(6 * n).copy_from(&e);
    }
    x
}

/// Inverts the series (3.4) for the joint-link errors of `nominal` from the
/// measured pose errors `data` (one twist per pose, in the order of `poses`).
pub fn invert_series(
    nominal: &Robot<f64>,
    poses: &[[f64; 6]],
    data: &[Twist<f64>],
) -> SeriesInversion {
    let params = joint_link_params(nominal);
    let rows = 6 * poses.len();
    let chains: Vec<_> = poses
        .iter()
        .map(|q| nominal.chain(q).expect("six joints"))
        .collect();
    // K^i_j of (3.5): the special-Jacobian columns at each pose, stacked.
    let k_full = DMatrix::from_fn(rows, params.len(), |r, c| {
        chains[r / 6].column(params[c])[r % 6]
    });
    let unit = DMatrix::from_fn(rows, params.len(), |r, c| {
        k_full[(r, c)] / k_full.column(c).norm()
    });
    let mut singular_values: Vec<f64> = unit
        .clone()
        .svd(false, false)
        .singular_values
        .iter()
        .copied()
        .collect();
    singular_values.sort_by(|a, b| b.total_cmp(a));

    // Hold a column that lies in the span of the earlier kept ones (relative
    // residual below 1e-9, the dependence threshold of `PaperOptions`).
    let mut kept: Vec<usize> = Vec::new();
    let mut held = Vec::new();
    for j in 0..params.len() {
        if !kept.is_empty() {
            let basis = DMatrix::from_fn(rows, kept.len(), |r, c| unit[(r, kept[c])]);
            let col = unit.column(j).into_owned();
            let fit = basis.clone().svd(true, true).solve(&col, 1e-12);
            if let Some(coef) = fit.ok().filter(|coef| (&basis * coef - &col).norm() < 1e-9) {
                let (i, _) = coef.iamax_full();
                held.push((params[j], params[kept[i]]));
                continue;
            }
        }
        kept.push(j);
    }
    let k = DMatrix::from_fn(rows, kept.len(), |r, c| k_full[(r, kept[c])]);
    let svd = k.svd(true, true);
    let k_pinv = svd
        .clone()
        .pseudo_inverse(0.0)
        .expect("the SVD holds U and Vᵀ");
    let ops = 4.0 * 16.0 * (nominal.dof() as f64 + 2.0) * f64::EPSILON;
    let delta_x = |r: usize| {
        if r % 6 < 3 {
            ops
        } else {
            ops * crate::session::measurements::reach(nominal, std::iter::empty())
        }
    };
    let mut floor = vec![0.0; params.len()];
    for (c, &j) in kept.iter().enumerate() {
        floor[j] = (0..rows).map(|r| k_pinv[(c, r)].abs() * delta_x(r)).sum();
    }
    let solve = |rhs: &DVector<f64>| -> Vec<f64> {
        let mut dp = vec![0.0; params.len()];
        // The kept columns are independent: the SVD solve succeeds.
        if let Ok(sol) = svd.solve(rhs, 0.0) {
            for (c, &j) in kept.iter().enumerate() {
                dp[j] = sol[c];
            }
        }
        dp
    };
    let mut dx = DVector::zeros(rows);
    for (n, d) in data.iter().enumerate() {
        dx.fixed_rows_mut::<6>(6 * n).copy_from(d);
    }

    let first = solve(&dx);
    // Eq. 3.7: take the second-order term of the first-order estimate off the data.
    let mut quadratic = DVector::zeros(rows);
    for (n, q) in poses.iter().enumerate() {
        let pert = nominal
            .perturbation(q, &pairs(&params, &first))
            .expect("six joints, joint parameters");
        quadratic
            .fixed_rows_mut::<6>(6 * n)
            .copy_from(&pert.second_twist());
    }
    let second = solve(&(&dx - quadratic));

    let mut iterates = Vec::new();
    let mut dp = vec![0.0; params.len()];
    for _ in 0..100 {
        let step = solve(&(&dx - forward_errors(nominal, poses, &params, &dp)));
        dp.iter_mut().zip(&step).for_each(|(p, s)| *p += s);
        iterates.push(dp.clone());
        if step.iter().zip(&floor).all(|(s, f)| s.abs() <= *f) {
            break;
        }
    }
    let residual = (&dx - forward_errors(nominal, poses, &params, &dp)).norm();
    SeriesInversion {
        params,
        held,
        singular_values,
        floor,
        first,
        second,
        iterates,
        residual,
    }
}

/// Part (b) on one set of built-in errors.
#[derive(Clone, Debug)]
pub struct Section3 {
    /// The built-in errors, in the order of [`SeriesInversion::params`].
    pub truth: Vec<f64>,
    /// Kirchner et al.'s series inversion.
    pub inversion: SeriesInversion,
    /// Mirman & Gupta's iterative regression on the same four poses.
    pub ira: PaperFit,
}

/// Part (b) for the built-in errors `truth` (in the order of
/// [`joint_link_params`]): exact data at the four poses, both methods.
pub fn section3(truth: Vec<f64>) -> Section3 {
    let nominal = puma_in_inches();
    let params = joint_link_params(&nominal);
    let real = with_errors(&nominal, &params, &truth);
    let poses = calibration_poses();
    let actual: Vec<_> = poses
        .iter()
        .map(|q| real.forward(q).expect("six joints"))
        .collect();
    let data: Vec<Twist<f64>> = poses
        .iter()
        .zip(&actual)
        .map(|(q, a)| pose_error(a, &nominal.forward(q).expect("six joints")))
        .collect();
    let inversion = invert_series(&nominal, &poses, &data);
    let paper_poses: Vec<PaperPose> = poses
        .iter()
        .zip(actual)
        .map(|(q, actual)| PaperPose {
            q: q.to_vec(),
            actual,
            joint_errors: None,
        })
        .collect();
    let ira = identify_paper(&nominal, &paper_poses, &PaperOptions::default())
        .expect("four poses give 24 equations for 18 unknowns");
    Section3 {
        truth,
        inversion,
        ira,
    }
}

/// A parameter the two methods are compared on: one of the 24, or the sum of a
/// dependent pair.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Compared {
    /// One parameter.
    One(Param),
    /// The sum of a parameter held at zero and the one it depends on.
    Sum(Param, Param),
}

impl Section3 {
    /// The parameters both methods estimate: those of the IRA's 3M model, with a
    /// pair the inversion cannot separate (held, beside) replaced by its sum.
    pub fn compared(&self) -> Vec<Compared> {
        let mut out: Vec<Compared> = Vec::new();
        for p in &self.ira.params {
            if let Some(&(held, beside)) =
                self.inversion.held.iter().find(|(h, b)| h == p || b == p)
            {
                if *p == beside {
                    out.push(Compared::Sum(beside, held));
                }
            } else if self.inversion.params.contains(p) {
                out.push(Compared::One(*p));
            }
        }
        out
    }

    /// The value of a compared parameter in `values` (ordered as `params`).
    fn value(params: &[Param], values: &[f64], c: Compared) -> f64 {
        let at = |p: Param| {
            params
                .iter()
                .position(|x| *x == p)
                .map_or(0.0, |i| values[i])
        };
        match c {
            Compared::One(p) => at(p),
            Compared::Sum(a, b) => at(a) + at(b),
        }
    }

    /// Built-in value of a compared parameter.
    pub fn truth_of(&self, c: Compared) -> f64 {
        Self::value(&self.inversion.params, &self.truth, c)
    }

    /// The inversion's estimate (`estimate` is one of its vectors).
    pub fn inversion_of(&self, estimate: &[f64], c: Compared) -> f64 {
        Self::value(&self.inversion.params, estimate, c)
    }

    /// The iterative regression's estimate.
    pub fn ira_of(&self, c: Compared) -> f64 {
        Self::value(&self.ira.params, &self.ira.errors, c)
    }

    /// Worst `|estimate − built-in|` over the compared parameters, `(angles rad,
    /// lengths in)`, of an estimator.
    pub fn worst(&self, estimate: impl Fn(Compared) -> f64) -> (f64, f64) {
        self.compared()
            .into_iter()
            .fold((0.0f64, 0.0f64), |(r, t), c| {
                let e = (estimate(c) - self.truth_of(c)).abs();
                let angle = match c {
                    Compared::One(p) | Compared::Sum(p, _) => p.is_angle(),
                };
                if angle { (r.max(e), t) } else { (r, t.max(e)) }
            })
    }
}

fn compared_name(c: Compared) -> String {
    match c {
        Compared::One(p) => p.to_string(),
        Compared::Sum(a, b) => format!("{a}+{b}"),
    }
}

/// Writes a line per element of `lines`, each indented by `indent`.
fn lines(out: &mut String, indent: &str, text: &[&str]) {
    for l in text {
        let _ = writeln!(out, "{indent}{l}");
    }
}

/// The table of one part-(b) case: a row per parameter, a column per estimator.
fn section3_table(out: &mut String, s: &Section3) {
    let inv = &s.inversion;
    let _ = writeln!(
        out,
        "  {:<12} {:>11} {:>11} {:>11} {:>11} {:>11}",
        "parameter", "built in", "1st order", "eq. 3.7", "all orders", "IRA (3M)"
    );
    let row = |out: &mut String, name: String, truth: f64, cells: [Option<f64>; 4]| {
        let _ = write!(out, "  {name:<12} {truth:>11.6}");
        for c in cells {
            let _ = match c {
                Some(v) => write!(out, " {v:>11.6}"),
                None => write!(out, " {:>11}", "—"),
            };
        }
        let _ = writeln!(out);
    };
    for (j, p) in inv.params.iter().enumerate() {
        let held = inv.held.iter().any(|(h, _)| h == p);
        let ira = s
            .ira
            .params
            .iter()
            .position(|x| x == p)
            .map(|i| s.ira.errors[i]);
        let mine = |v: &[f64]| (!held).then_some(v[j]);
        row(
            out,
            format!("{p}{}", if held { " (held)" } else { "" }),
            s.truth[j],
            [
                mine(&inv.first),
                mine(&inv.second),
                mine(inv.all_orders()),
                ira,
            ],
        );
    }
    for c in s.compared() {
        if let Compared::Sum(..) = c {
            row(
                out,
                compared_name(c),
                s.truth_of(c),
                [
                    Some(s.inversion_of(&inv.first, c)),
                    Some(s.inversion_of(&inv.second, c)),
                    Some(s.inversion_of(inv.all_orders(), c)),
                    Some(s.ira_of(c)),
                ],
            );
        }
    }
    let _ = writeln!(
        out,
        "  worst |estimate − built in| over the {} compared parameters:   rad   |    in",
        s.compared().len()
    );
    let worst = |out: &mut String, label: &str, (r, t): (f64, f64)| {
        let _ = writeln!(out, "    {label:<42} {r:>9.2e} | {t:>9.2e}");
    };
    worst(
        out,
        "first order, K⁺Δx",
        s.worst(|c| s.inversion_of(&inv.first, c)),
    );
    worst(
        out,
        "second order, eq. 3.7",
        s.worst(|c| s.inversion_of(&inv.second, c)),
    );
    worst(
        out,
        &format!("all orders ({} iterations)", inv.iterates.len()),
        s.worst(|c| s.inversion_of(inv.all_orders(), c)),
    );
    worst(
        out,
        &format!(
            "IRA ({} iterations, {})",
            s.ira.iterations.len(),
            if s.ira.converged {
                "converged"
            } else {
                "NOT converged"
            }
        ),
        s.worst(|c| s.ira_of(c)),
    );
    worst(
        out,
        "rounding floor of the inversion",
        s.worst(|c| s.truth_of(c) + s.inversion_of(&inv.floor, c)),
    );
}

/// The levels of part (a), rad (lengths a tenth of it, in).
pub const EXPANSION_LEVELS: [f64; 5] = [0.04, 0.02, 0.01, 0.005, 0.0025];

/// Part (a): the residual table.
fn expansion_report(out: &mut String) {
    lines(
        out,
        "",
        &[
            "(a) Eq. 2.22: the real forward solution T^r (the model with the errors added) against",
            "its expansion in the 24 joint-link errors, at Table 1's position 1. Errors alternate in",
            "sign, ±ε rad on every θ and α, ±ε/10 in on every a and s (ε = 0.01: Table 2's errors plus",
            "joint offsets). |ΔP|: the measured point, in; |ΔR|: the rotation block (Frobenius);",
            "ratio: |ΔP| at 2ε over |ΔP| at ε.",
            "",
        ],
    );
    let _ = writeln!(
        out,
        "  {:>7} | {:>10} {:>10} {:>6} | {:>10} {:>10} {:>6} | {:>10} {:>6}",
        "ε", "1st |ΔP|", "1st |ΔR|", "ratio", "2nd |ΔP|", "2nd |ΔR|", "ratio", "no-½ |ΔP|", "ratio"
    );
    let rows = expansion_rows(&EXPANSION_LEVELS);
    for (i, r) in rows.iter().enumerate() {
        let ratio = |f: fn(&ExpansionRow) -> f64| {
            i.checked_sub(1)
                .map_or(String::new(), |h| format!("{:.3}", f(&rows[h]) / f(r)))
        };
        let _ = writeln!(
            out,
            "  {:>7} | {:>10.3e} {:>10.3e} {:>6} | {:>10.3e} {:>10.3e} {:>6} | {:>10.3e} {:>6}",
            r.eps,
            r.first.0,
            r.first.1,
            ratio(|r| r.first.0),
            r.second.0,
            r.second.1,
            ratio(|r| r.second.0),
            r.literal.0,
            ratio(|r| r.literal.0),
        );
    }
    lines(
        out,
        "",
        &[
            "",
            "First order leaves ε² (ratio 4), second order ε³ (ratio 8). The paper prints",
            "L_ij = ∂²T/∂p_i∂p_j in (2.22) (and ∂²A_1/∂α_1² as the coefficient of Δα_1Δα_1 in 2.21);",
            "the Taylor series needs ½ ∂²T/∂p_i∂p_j: with the literal coefficient (last columns) the",
            "residual stays of second order, as large as the first-order one.",
            "",
        ],
    );
}

/// `armcal reproduce kirchner`: parts (a) and (b).
pub fn report() -> String {
    let mut out = String::new();
    lines(
        &mut out,
        "",
        &[
            "Kirchner, Gurumoorthy & Prinz (1985), \"A Perturbation Approach to Robot Calibration\",",
            "sections 2 and 3. The paper gives no whole-robot example: the robot is the PUMA of",
            "Mirman & Gupta (1992), Table 1, standard D-H (the paper's eq. 2.1), inches and radians.",
            "",
        ],
    );
    expansion_report(&mut out);

    let nominal = puma_in_inches();
    let params = joint_link_params(&nominal);
    let case1 = section3(built_in_errors(&params, 0.01, 0.001, false));
    let inv = &case1.inversion;
    let sv = &inv.singular_values;
    lines(
        &mut out,
        "",
        &[
            "(b) Section 3: four calibration poses (Table 1's positions 1–4); the Cartesian coordinates",
            "x are the pose error [νdφ; dη] of Mirman & Gupta eq. 15 (rad, in): 24 equations (3.4) for",
            "the 24 errors θ, α, a, s. The series is inverted to first order (K⁺Δx), to second order",
            "(eq. 3.7 as printed) and to all orders (Δp ← Δp + K⁺(Δx − x(Δp)) with the exact forward",
            "solution x, until a step is below the rounding floor).",
        ],
    );
    let _ = writeln!(
        out,
        "K (24 × 24, columns scaled to unit length) has singular values {:.2e} … {:.2e}, {:.2e}:",
        sv[0],
        sv[sv.len() - 2],
        sv[sv.len() - 1],
    );
    for (held, beside) in &inv.held {
        let _ = writeln!(
            out,
            "the column of {held} equals that of {beside} at every pose (α2 = 0 makes z1 ∥ z2), so K is\n\
             singular and the 24 equations do not fix the 24 unknowns. {held} is held at zero (as the\n\
             IRA does in its first iteration) and 23 unknowns are solved in least squares (K⁺)."
        );
    }
    let sums: Vec<String> = case1
        .compared()
        .into_iter()
        .filter(|c| matches!(c, Compared::Sum(..)))
        .map(compared_name)
        .collect();
    let _ = writeln!(
        out,
        "The IRA (Mirman & Gupta's 3M model: α, a, s; no θ) runs on the same four exact poses.\n\
         The two are compared on the parameters both estimate: every α and a, and every s, with\n\
         {} as a sum.\n",
        sums.join(", ")
    );

    let _ = writeln!(
        out,
        "Case 1: Table 2's errors (α ±0.01 rad, a and s ±0.001 in), no joint offsets."
    );
    section3_table(&mut out, &case1);

    let case2 = section3(built_in_errors(&params, 0.01, 0.001, true));
    let _ = writeln!(
        out,
        "\nCase 2: the same plus joint offsets θ ±0.01 rad: the paper's 24 errors. The IRA's 3M\n\
         model has no place for the offsets."
    );
    section3_table(&mut out, &case2);

    let case3 = section3(model_exact(&params, &inv.held, 0.01, 0.001));
    let ((r, t), (fr, ft)) = case3
        .inversion
        .worst_all(case3.inversion.all_orders(), &case3.truth);
    let _ = writeln!(
        out,
        "\nCase 3: case 2 with the held parameter's built-in error zero, so that the 23-unknown model\n\
         is exact. The inversion to all orders recovers all 23 errors (θ included) to {r:.1e} rad\n\
         and {t:.1e} in after {} iterations, within its rounding floor ({fr:.1e} rad, {ft:.1e} in).",
        case3.inversion.iterates.len(),
    );
    let _ = writeln!(
        out,
        "\nThe four poses are ill-conditioned for 23 unknowns (smallest scaled singular value\n\
         {:.1e}): the truncation error of the second-order series, O(ε³) in x, is amplified by |K⁺|\n\
         into the estimates. So eq. 3.7, though third-order accurate (its error shrinks 8-fold when\n\
         the errors are halved), is still far from Table 2's errors. Carried to all orders the\n\
         inversion converges; where the parallel axes force a parameter to be held, it converges to\n\
         the least-squares compromise (case 1: within the coupling of the held s3 with α2). The IRA\n\
         re-linearises at each iterate, where α2 ≠ 0 separates s2 from s3, and recovers case 1 to\n\
         rounding; it cannot fit case 2, whose joint offsets its model lacks.",
        sv[sv.len() - 2]
    );
    out
}

/// Built-in errors at level `rot`, `trans` with joint offsets (case 2's pattern)
/// and those of the `held` parameters zero: errors the inversion's model with
/// those parameters held represents exactly.
pub fn model_exact(params: &[Param], held: &[(Param, Param)], rot: f64, trans: f64) -> Vec<f64> {
    let mut truth = built_in_errors(params, rot, trans, true);
    for (j, p) in params.iter().enumerate() {
        if held.iter().any(|(h, _)| h == p) {
            truth[j] = 0.0;
        }
    }
    truth
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The order of a residual is read from the ratio `r(2ε)/r(ε) = 2ᵐ`. A ratio
    /// within a factor √2 of `2ᵐ` is nearer (geometrically) to order m than to
    /// m − 1 or m + 1: that is the bound asserted, so the tests identify the order
    /// without a tuned tolerance.
    fn assert_order(what: &str, ratio: f64, m: i32) {
        let want = 2f64.powi(m);
        assert!(
            ratio > want / 2f64.sqrt() && ratio < want * 2f64.sqrt(),
            "{what}: ratio {ratio}, order {m} wants {want}"
        );
    }

    /// Part (a), the claim of eq. 2.22: to first order the residual is of order
    /// ε², to second order (with the ½) of order ε³; with the paper's literal
    /// coefficient it stays of order ε².
    #[test]
    fn expansion_residuals_have_the_orders_claimed() {
        let rows = expansion_rows(&EXPANSION_LEVELS);
        for w in rows.windows(2) {
            let (big, small) = (&w[0], &w[1]);
            let at = format!("ε = {}", small.eps);
            assert_order(
                &format!("{at}, first order, point"),
                big.first.0 / small.first.0,
                2,
            );
            assert_order(
                &format!("{at}, first order, rotation"),
                big.first.1 / small.first.1,
                2,
            );
            assert_order(
                &format!("{at}, second order, point"),
                big.second.0 / small.second.0,
                3,
            );
            assert_order(
                &format!("{at}, second order, rotation"),
                big.second.1 / small.second.1,
                3,
            );
            assert_order(
                &format!("{at}, literal L, point"),
                big.literal.0 / small.literal.0,
                2,
            );
        }
    }

    /// For the PUMA, `K` is singular through `s2`, `s3` only: its smallest scaled
    /// singular value is zero to rounding (`24 ε_mach σ_max`, the backward error of
    /// the SVD of a 24 × 24 matrix), the next is not.
    #[test]
    fn puma_k_is_singular_through_s2_and_s3_only() {
        let nominal = puma_in_inches();
        let params = joint_link_params(&nominal);
        let s = section3(built_in_errors(&params, 0.01, 0.001, false));
        assert_eq!(s.inversion.held, vec![(Param::S(2), Param::S(1))]);
        let sv = &s.inversion.singular_values;
        let zero = 24.0 * f64::EPSILON * sv[0];
        assert!(sv[23] <= zero, "{sv:?}");
        assert!(sv[22] > 1e6 * zero, "{sv:?}");
    }

    /// Section 3's claim: with errors constant over the workspace, four poses and
    /// the inverted series give the errors. From exact data of a model the
    /// inversion can represent (s3's error zero), the inversion carried to all
    /// orders recovers every one of the 23 errors, θ offsets included, to its
    /// rounding floor `Σ_i |K⁺_ji| δx_i`.
    #[test]
    fn series_inversion_converges_to_the_built_in_errors_from_exact_data() {
        let nominal = puma_in_inches();
        let params = joint_link_params(&nominal);
        let held = [(Param::S(2), Param::S(1))];
        let s = section3(model_exact(&params, &held, 0.01, 0.001));
        let inv = &s.inversion;
        assert!(inv.iterates.len() < 100, "not converged");
        for (j, p) in params.iter().enumerate() {
            let err = (inv.all_orders()[j] - s.truth[j]).abs();
            assert!(
                err <= inv.floor[j],
                "{p}: |error| {err:e} > floor {:e}",
                inv.floor[j]
            );
        }
    }

    /// Eq. 3.7 is the inversion to second order: its error is of third order in
    /// the errors, that of `K⁺Δx` of second order (model-exact data, so that the
    /// truncation is the only error).
    #[test]
    fn eq_3_7_is_third_order_accurate() {
        let nominal = puma_in_inches();
        let params = joint_link_params(&nominal);
        let held = [(Param::S(2), Param::S(1))];
        let worst = |eps: f64| {
            let s = section3(model_exact(&params, &held, eps, eps / 10.0));
            let (first, _) = s.inversion.worst_all(&s.inversion.first, &s.truth);
            let (second, _) = s.inversion.worst_all(&s.inversion.second, &s.truth);
            (first, second)
        };
        let (big, small) = (worst(0.0025), worst(0.00125));
        assert_order("K⁺Δx, angles", big.0.0 / small.0.0, 2);
        assert_order("K⁺Δx, lengths", big.0.1 / small.0.1, 2);
        assert_order("eq. 3.7, angles", big.1.0 / small.1.0, 3);
        assert_order("eq. 3.7, lengths", big.1.1 / small.1.1, 3);
    }

    /// On the same data: with Table 2's errors (case 1) the IRA recovers every
    /// parameter it estimates to 1e-6 (Mirman & Gupta's Table 2, here from four
    /// poses), and each order of the series inversion improves on the one before;
    /// with joint offsets (case 2) the 3M model cannot fit, and the inversion,
    /// which estimates them, does better on the compared parameters.
    #[test]
    fn inversion_and_ira_on_the_same_data() {
        let nominal = puma_in_inches();
        let params = joint_link_params(&nominal);
        let case1 = section3(built_in_errors(&params, 0.01, 0.001, false));
        assert!(case1.ira.converged);
        for c in case1.compared() {
            let e = (case1.ira_of(c) - case1.truth_of(c)).abs();
            assert!(e < 1e-6, "{}: IRA error {e:e}", compared_name(c));
        }
        let inv = &case1.inversion;
        let first = case1.worst(|c| case1.inversion_of(&inv.first, c));
        let second = case1.worst(|c| case1.inversion_of(&inv.second, c));
        let all = case1.worst(|c| case1.inversion_of(inv.all_orders(), c));
        assert!(
            second.0 < first.0 && second.1 < first.1,
            "{first:?} {second:?}"
        );
        assert!(all.0 < second.0 && all.1 < second.1, "{second:?} {all:?}");

        let case2 = section3(built_in_errors(&params, 0.01, 0.001, true));
        let ira = case2.worst(|c| case2.ira_of(c));
        let all = case2.worst(|c| case2.inversion_of(case2.inversion.all_orders(), c));
        assert!(
            all.0 < ira.0 && all.1 < ira.1,
            "IRA {ira:?}, inversion {all:?}"
        );
    }

    #[test]
    fn report_says_which_robot_and_what_is_held() {
        let text = report();
        assert!(text.contains("Mirman & Gupta (1992), Table 1"), "{text}");
        assert!(text.contains("s3 is held at zero"), "{text}");
        assert!(text.contains("Case 3"), "{text}");
    }
}
