//! `armcal reproduce`: the examples of the seed papers, rebuilt.
//!
//! Mirman & Gupta (1992), Table 2: the PUMA of Table 1 at its six positions, with
//! induced errors alternating in sign, ±0.01 rad on every `α` and ±0.001 in on
//! every `a` and `s` (`α1 = −0.010, α2 = +0.010, …; a1 = +0.001, a2 = −0.001, …;
//! s1 = −0.001, s2 = +0.001, …`), exact end-effector data, the 3M model and the
//! Iterative Regression Algorithm. Units are the paper's: inches and radians.

use std::fmt::Write as _;

use armcal_shared::{Param, Robot};

use crate::identify::paper::{PaperFit, PaperOptions, PaperPose, identify_paper};
use crate::model_file::load_model;

/// Table 1's six positions, rad, as printed (0.7854 is the paper's value, not π/4).
#[allow(clippy::approx_constant)]
pub const TABLE1_POSITIONS: [[f64; 6]; 6] = [
    [0.7854, -0.5236, -1.2618, 0.2618, -1.6981, -0.3490],
    [0.5708, -0.3491, -1.4363, 0.1745, -0.7854, -1.5360],
    [0.1745, -1.0944, -0.9199, 0.1745, -0.7854, -0.2618],
    [1.0454, -0.1230, -0.9090, 1.2323, -1.2420, -0.7897],
    [1.0000, -0.3000, -0.5656, 0.7890, -1.0000, -0.5400],
    [0.5943, -0.2340, -0.3405, 1.0900, -0.7897, -0.1000],
];

/// The Table 1 PUMA in inches and radians (the built-in `puma560` converted back
/// from SI), so that the regression runs in the paper's units.
pub fn puma_in_inches() -> Robot<f64> {
    // The built-in model ships with the binary; its parse is tested.
    let model = load_model("puma560").expect("built-in puma560 parses");
    let mut robot = model.robot.clone();
    let inch = |x: f64| model.units.length_from_si(x);
    for l in robot.links.iter_mut() {
        l.s = inch(l.s);
        l.a = inch(l.a);
    }
    robot
}

/// The induced error of Table 2 for a paper parameter: alternating signs.
pub fn table2_induced(param: Param) -> f64 {
    let sign = |m: usize, first: f64| if m.is_multiple_of(2) { first } else { -first };
    match param {
        Param::Alpha(m) => sign(m, -0.01),
        Param::A(m) => sign(m, 0.001),
        Param::S(m) => sign(m, -0.001),
        _ => 0.0,
    }
}

/// Table 2: induced errors, exact data at the six positions, and the fit.
pub fn table2(options: &PaperOptions) -> (Vec<f64>, PaperFit) {
    let nominal = puma_in_inches();
    let params = crate::identify::paper::paper_params(&nominal);
    let induced: Vec<f64> = params.iter().map(|p| table2_induced(*p)).collect();
    let mut truth = nominal.clone();
    for (p, e) in params.iter().zip(&induced) {
        if let Some(v) = truth.param_mut(*p) {
            *v += e;
        }
    }
    let poses: Vec<PaperPose> = TABLE1_POSITIONS
        .iter()
        .map(|q| PaperPose {
            q: q.to_vec(),
            actual: truth.forward(q).expect("six joints"),
            joint_errors: None,
        })
        .collect();
    let fit = identify_paper(&nominal, &poses, options).expect("six poses for 18 unknowns");
    (induced, fit)
}

/// Table 2 printed as the paper prints it: a row per parameter, a column per iteration.
pub fn table2_report(induced: &[f64], fit: &PaperFit) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Mirman & Gupta (1992), Table 2: PUMA of Table 1, six positions, exact data,\n\
         induced errors ±0.01 rad (α) and ±0.001 in (a, s), 3M model, iterative regression.\n"
    );
    let _ = write!(out, "{:<10} {:>12}", "parameter", "induced");
    for i in 1..=fit.iterations.len() {
        let _ = write!(out, " {:>12}", format!("iter {i}"));
    }
    let _ = writeln!(out);
    for (j, p) in fit.params.iter().enumerate() {
        let _ = write!(out, "{:<10} {:>12.6}", p.to_string(), induced[j]);
        for it in &fit.iterations {
            let _ = write!(out, " {:>12.6}", it.errors[j]);
        }
        let _ = writeln!(out);
    }
    for (i, it) in fit.iterations.iter().enumerate() {
        for (held, beside, r) in &it.dependent {
            let _ = writeln!(
                out,
                "iteration {}: {held} held at zero, dependent on {beside} (r = {r:.12})",
                i + 1
            );
        }
        if it.step_cuts > 0 {
            let _ = writeln!(
                out,
                "iteration {}: step halved {} times",
                i + 1,
                it.step_cuts
            );
        }
    }
    let worst = fit
        .errors
        .iter()
        .zip(induced)
        .map(|(e, t)| (e - t).abs())
        .fold(0.0, f64::max);
    let _ = writeln!(
        out,
        "\n{} after {} iterations; largest |identified − induced| = {worst:.3e}",
        if fit.converged {
            "converged"
        } else {
            "NOT converged"
        },
        fit.iterations.len()
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Table 2: from exact data the 3M model converges to the induced errors,
    /// to 1e-6, within four iterations; in the first iteration s3 is held at zero
    /// because α2 = 0 makes z2 ∥ z3 (s2 and s3 dependent).
    #[test]
    fn table2_converges_to_the_induced_errors() {
        let (induced, fit) = table2(&PaperOptions::default());
        println!("{}", table2_report(&induced, &fit));
        assert!(fit.converged);
        assert!(
            fit.iterations.len() <= 4,
            "{} iterations",
            fit.iterations.len()
        );
        for (j, p) in fit.params.iter().enumerate() {
            assert!(
                (fit.errors[j] - induced[j]).abs() < 1e-6,
                "{p}: {} vs {}",
                fit.errors[j],
                induced[j]
            );
        }
        let first = &fit.iterations[0];
        assert!(
            first
                .dependent
                .iter()
                .any(|(held, beside, _)| *held == Param::S(2) && *beside == Param::S(1)),
            "{:?}",
            first.dependent
        );
        assert_eq!(
            first.errors[fit.params.iter().position(|p| *p == Param::S(2)).unwrap()],
            0.0
        );
    }
}
