//! Causes the data cannot tell apart: another candidate that reproduces what
//! the data show of a chosen effect.
//!
//! Two effects can move the tool alike over a session. A joint's compliance
//! twists it by `c τ_j`; when nothing but joint `j` changes its gravity torque
//! (one payload, the joints beyond it held), `τ_j = A sin(q_j + φ) + B` is a
//! first harmonic of `q_j`, exactly what a gear transmission's `s₁ sin q_j +
//! c₁ cos q_j` is. The session then shows one signature, and naming either
//! cause would claim what the data do not say.
//!
//! ## The test
//! In the linearisation the chosen candidate `c` was scored in (rows whitened
//! by their noise: unit variance), with `F` the columns of the model before
//! it (the fitted geometry and the effects already chosen, their prior
//! precisions `P` on the diagonal), `A` the columns of `c` and `B` those of
//! another candidate `d`: `c`'s one-step estimate `x` about the current fit
//! solves `[F A]` with the prior, and what `d` cannot reproduce of `c`'s
//! signature `A x` is its part outside the span of `[F B]`,
//!
//! ```text
//! u² = xᵀ (AᵀA − Aᵀ[F B] ([F B]ᵀ[F B] + P)⁻¹ [F B]ᵀA) x
//! ```
//!
//! in units of the noise. When `u` is below [`SEPARATED`] (three standard
//! errors), the data cannot tell `c` from `d`: both fit them alike, and only
//! another measurement separates them ([`Alike::separated_by`]). Everything
//! comes from the normal equations the cross-validation already summed (one
//! small solve per pair, with faer's Cholesky factor, as the cross-validation
//! solves), SI units.

use faer::linalg::solvers::Solve;
use faer::linalg::triangular_solve::solve_lower_triangular_in_place;
use faer::{Col, Mat, MatRef, Par, Side};

use super::candidates::Candidate;

/// What the data must show of a chosen effect beyond another candidate for
/// the two to be told apart, in standard errors of the noise: three.
pub const SEPARATED: f64 = 3.0;

/// Another cause that reproduces what the data show of a chosen effect.
#[derive(Clone, Debug, PartialEq)]
pub struct Alike {
    /// The other candidate.
    pub candidate: Candidate,
    /// What of the chosen effect's signature it cannot reproduce, in
    /// standard errors of the noise (below [`SEPARATED`]).
    pub unexplained: f64,
}

/// A linearisation's normal equations and the columns of a test: what
/// [`alike`] reads.
pub struct Columns<'a> {
    /// `(JᵀJ, Jᵀr)` over every column, rows whitened.
    pub normal: &'a (Mat<f64>, Col<f64>),
    /// Each column's prior precision (0: none).
    pub precision: &'a [f64],
    /// How many leading columns are the model before the chosen candidate.
    pub fitted: usize,
}

impl Columns<'_> {
    /// `N[rows, cols]`, with the prior precision on the diagonal when `rows`
    /// and `cols` are the same.
    fn block(&self, rows: &[usize], cols: &[usize]) -> Mat<f64> {
        Mat::from_fn(rows.len(), cols.len(), |i, k| {
            let prior = if rows[i] == cols[k] {
                self.precision[rows[i]]
            } else {
                0.0
            };
            self.normal.0[(rows[i], cols[k])] + prior
        })
    }

    /// The fitted columns followed by `own`.
    fn with(&self, own: &[usize]) -> Vec<usize> {
        (0..self.fitted).chain(own.iter().copied()).collect()
    }
}

/// The candidates of `others` (each with its own columns) that reproduce
/// the chosen candidate's signature (its own columns `chosen`) to within
/// [`SEPARATED`] standard errors (see the module header). Empty when the
/// system cannot be solved.
pub fn alike(columns: &Columns, chosen: &[usize], others: &[(&Candidate, &[usize])]) -> Vec<Alike> {
    let fa = columns.with(chosen);
    let Some(z) = columns
        .block(&fa, &fa)
        .llt(Side::Lower)
        .ok()
        .map(|l| l.solve(Col::from_fn(fa.len(), |i| columns.normal.1[fa[i]])))
    else {
        return Vec::new();
    };
    let x = z.subrows(columns.fitted, chosen.len()).to_owned();
    // `[F B]`'s factor from `F`'s, shared by every other candidate: with
    // `W = L_F⁻¹ N_FB` and `L_S` the factor of `N_BB − WᵀW` it is
    // `[L_F 0; Wᵀ L_S]`, so `N_A[F B] N_[F B]⁻¹ N_[F B]A = Y_FᵀY_F + Y_BᵀY_B`
    // with `Y_F = L_F⁻¹ N_FA` (the same for every other) and
    // `Y_B = L_S⁻¹ (N_BA − Wᵀ Y_F)`.
    let fitted: Vec<usize> = (0..columns.fitted).collect();
    let Ok(l_f) = columns.block(&fitted, &fitted).llt(Side::Lower) else {
        return Vec::new();
    };
    let l_f = l_f.L();
    let y_f = lower_solve(l_f, columns.block(&fitted, chosen));
    let beside_fitted = columns.block(chosen, chosen) - y_f.transpose() * &y_f;
    others
        .iter()
        .filter(|(_, own)| !own.is_empty() && own.iter().all(|c| !chosen.contains(c)))
        .filter_map(|(candidate, own)| {
            let w = lower_solve(l_f, columns.block(&fitted, own));
            let schur = (columns.block(own, own) - w.transpose() * &w)
                .llt(Side::Lower)
                .ok()?;
            let y_b = lower_solve(schur.L(), columns.block(own, chosen) - w.transpose() * &y_f);
            let outside = &beside_fitted - y_b.transpose() * &y_b;
            let unexplained: f64 = x.transpose() * (outside * &x);
            let unexplained = unexplained.max(0.0).sqrt();
            (unexplained < SEPARATED).then(|| Alike {
                candidate: (*candidate).clone(),
                unexplained,
            })
        })
        .collect()
}

/// `L⁻¹ b` for a lower triangular `l`, in the place of `b`.
fn lower_solve(l: MatRef<'_, f64>, mut b: Mat<f64>) -> Mat<f64> {
    solve_lower_triangular_in_place(l, b.as_mut(), Par::Seq);
    b
}

impl Alike {
    /// What measurement would separate `chosen` from this candidate, for
    /// the report.
    pub fn separated_by(&self, chosen: &Candidate) -> &'static str {
        let names = [chosen.name, self.candidate.name];
        let either = |n: &str| names.contains(&n);
        if either("joint_compliance") {
            "measure at another payload, or with the joints beyond it in other configurations: its gravity torque then changes where its reading does not"
        } else if either("thermal_expansion") {
            "measure the same poses at another temperature"
        } else if either("backlash") {
            "approach each pose from both directions"
        } else {
            "measure over a wider range of the joints involved"
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn candidate(name: &'static str) -> Candidate {
        Candidate {
            name,
            joints: vec![1],
            effect: None,
            extra: Vec::new(),
        }
    }

    /// Rows of a signature `a` and of two other candidates, one that spans
    /// it (`sin`, `cos` of the same angle: a first harmonic) and one that
    /// does not (twice the angle), with the data `r = 0.01 a`, whitened:
    /// the first is alike, the second is not, and the first stops being
    /// alike when a quarter of `a` is something it cannot make.
    #[test]
    fn a_signature_another_candidate_spans_is_alike() {
        let n = 400;
        let angle = |i: usize| -2.0 + 4.0 * i as f64 / n as f64;
        let rows = |leak: f64| {
            Mat::from_fn(n, 5, |i, c| {
                let q = angle(i);
                match c {
                    0 => 1.0,                                  // a fitted offset
                    1 => 3.0 * (q + 0.4).sin() + leak * q * q, // the chosen signature
                    2 => q.sin(),                              // a first harmonic
                    3 => q.cos(),
                    _ => (2.0 * q).sin(), // a second one
                }
            })
        };
        for (leak, harmonic_alike) in [(0.0, true), (0.75, false)] {
            let j = rows(leak);
            // A signal of 100 standard errors in all.
            let r = j.col(1) * (100.0 / j.col(1).norm_l2());
            let normal = (j.transpose() * &j, j.transpose() * r);
            let columns = Columns {
                normal: &normal,
                precision: &[0.0; 5],
                fitted: 1,
            };
            let (harmonic, second) = (candidate("gear_transmission"), candidate("encoder_scale"));
            let found = alike(&columns, &[1], &[(&harmonic, &[2, 3]), (&second, &[4])]);
            let names: Vec<&str> = found.iter().map(|a| a.candidate.name).collect();
            if harmonic_alike {
                assert_eq!(names, ["gear_transmission"]);
                assert!(found[0].unexplained < 1e-6, "{}", found[0].unexplained);
            } else {
                assert!(names.is_empty(), "{found:?}");
            }
        }
    }
}
