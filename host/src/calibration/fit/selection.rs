//! Identifiability: which unknowns the data can separate (a rank-revealing
//! Cholesky of the unit-scaled normal matrix, in the order base, tool, joints
//! base to tip), which a standard error too large holds, and the reason each
//! held one is given. See the parent module's "Identifiability".

use armcal_shared::{FrameAxis, Param, Robot};
use faer::linalg::solvers::Solve;
use faer::{Mat, Side};
use nalgebra::Vector3;

use super::rows::NormalEquations;
use super::{FullOptions, Model, Unknown};
use crate::calibration::fit::noise::Weights;
use crate::session::rows::Rows;

/// The rank-revealing Cholesky of the scaled normal matrix in the order of
/// preference: the indices of the separable parameters, and the others with the
/// reason each is not.
pub(super) fn separable_subset(
    sys: &NormalEquations,
    params: &[Unknown],
    robot: &Model,
    data: Rows<'_>,
    options: &FullOptions,
    noise_scale: f64,
) -> (Vec<usize>, Vec<(Unknown, String)>) {
    let tolerance = options.separability;
    let (g, _, scale) = sys.scaled_normal_equations();
    let n = g.nrows();
    // Cholesky factor columns of the kept parameters: L[k] holds row k of L.
    let mut l = Mat::<f64>::zeros(n, n);
    let mut kept: Vec<usize> = Vec::new();
    let mut fixed = Vec::new();
    let tol2 = tolerance * tolerance;
    for k in 0..n {
        if scale[k] == 0.0 {
            fixed.push((
                params[k],
                "does not move the measured point or frame".to_string(),
            ));
            continue;
        }
        // Residual of column k after projecting out the kept columns: d = G_kk − Σ L_kj².
        let mut lk = vec![0.0; kept.len()];
        for (a, &i) in kept.iter().enumerate() {
            let mut s = g[(k, i)];
            for b in 0..a {
                s -= lk[b] * l[(i, b)];
            }
            lk[a] = s / l[(i, a)];
        }
        let d = g[(k, k)] - lk.iter().map(|x| x * x).sum::<f64>();
        // The standard error this parameter would have beside the ones kept so far.
        let std = noise_scale * scale[k] / d.max(0.0).sqrt();
        // Effect parameters have units of their own: only exact dependence holds them.
        // A parameter with a prior is held near nominal by the prior, not here.
        let (limit, unit) = match params[k] {
            // A constraint session's base, in its selection only: kept to
            // absorb the joint parameters that move the arm as it would.
            Unknown::Param(Param::Base(_)) if !robot.points.is_empty() => (f64::INFINITY, ""),
            Unknown::Param(p) if options.prior.precision(p) > 0.0 => (f64::INFINITY, ""),
            Unknown::Param(p) | Unknown::Session { param: p, .. } if p.is_angle() => {
                (options.max_std_angle, "rad")
            }
            Unknown::Plane {
                component: 0 | 1, ..
            } => (options.max_std_angle, "rad"),
            Unknown::Param(_)
            | Unknown::Point { .. }
            | Unknown::Plane { .. }
            | Unknown::Session { .. } => (options.max_std_length, "m"),
            Unknown::Effect { .. } => (f64::INFINITY, ""),
        };
        if d > tol2 && std > limit {
            fixed.push((
                params[k],
                format!("not determined by these data: its standard error would be {std:.2e} {unit}, above {limit:.0e} {unit}"),
            ));
        } else if d > tol2 {
            let a = kept.len();
            for (b, v) in lk.iter().enumerate() {
                l[(k, b)] = *v;
            }
            l[(k, a)] = d.sqrt();
            kept.push(k);
        } else {
            fixed.push((
                params[k],
                dependence_reason(k, &kept, &g, params, robot, data),
            ));
        }
    }
    (kept, fixed)
}

/// [`separable_subset`] of a constraint session's unknowns `params` (the
/// points first; no base): the selection is made with the six base columns
/// after the points, as though the base were free, and the base then left out.
/// A joint parameter that moves the whole arm as the base would (`θ1`, `s1`
/// about a first axis along the base z) is so held as not separable from the
/// base, exactly at any linearisation, where beside the points alone it would
/// be only at the solution (the start's tool points of one point's rows are
/// apart by the model's errors).
pub(super) fn constrained_subset(
    params: &[Unknown],
    robot: &Model,
    data: Rows<'_>,
    options: &FullOptions,
    noise_scale: f64,
    weights: &Weights,
) -> (Vec<usize>, Vec<(Unknown, String)>) {
    let points = params
        .iter()
        .take_while(|u| matches!(u, Unknown::Point { .. } | Unknown::Plane { .. }))
        .count();
    let selection: Vec<Unknown> = params[..points]
        .iter()
        .copied()
        .chain(
            FrameAxis::ALL
                .into_iter()
                .map(|a| Unknown::Param(Param::Base(a))),
        )
        .chain(params[points..].iter().copied())
        .collect();
    let system = NormalEquations::accumulate(robot, data, &selection, weights, options.cancel);
    let (kept, fixed) = separable_subset(&system, &selection, robot, data, options, noise_scale);
    let is_base = |u: &Unknown| matches!(u, Unknown::Param(Param::Base(_)));
    let free = kept
        .into_iter()
        .filter_map(|k| params.iter().position(|u| *u == selection[k]))
        .collect();
    let fixed = fixed
        .into_iter()
        .filter(|(u, _)| !is_base(u))
        .map(|(u, reason)| {
            if reason.contains("base.") {
                (
                    u,
                    format!("{reason} (a motion of the base frame, which these data cannot see)"),
                )
            } else {
                (u, reason)
            }
        })
        .collect();
    (free, fixed)
}

/// Names the kept parameters that column `k` depends on, and the geometry behind it.
pub(super) fn dependence_reason(
    k: usize,
    kept: &[usize],
    g: &Mat<f64>,
    params: &[Unknown],
    robot: &Model,
    data: Rows<'_>,
) -> String {
    // Least-squares coefficients of column k on the kept columns: G_SS c = G_Sk.
    let n = kept.len();
    let gss = Mat::from_fn(n, n, |a, b| g[(kept[a], kept[b])]);
    let gsk = Mat::from_fn(n, 1, |a, _| g[(kept[a], k)]);
    let mut names: Vec<(f64, Unknown)> = match gss.llt(Side::Lower) {
        Ok(llt) => {
            let c = llt.solve(&gsk);
            (0..n).map(|a| (c[(a, 0)].abs(), params[kept[a]])).collect()
        }
        Err(_) => Vec::new(),
    };
    names.sort_by(|a, b| b.0.total_cmp(&a.0));
    let top = names.first().map_or(0.0, |x| x.0);
    // With several sessions the model's own base and tool are the first
    // session's, named so beside another session's.
    let several = !robot.registrations.sessions.is_empty();
    let name = |u: Unknown| match u {
        Unknown::Param(p @ (Param::Base(_) | Param::Tool(_))) if several => {
            format!("session 1 {p}")
        }
        u => robot.name(u),
    };
    let list: Vec<String> = names
        .iter()
        .take_while(|x| x.0 >= 0.1 * top && x.0 > 0.0)
        .take(3)
        .map(|x| name(x.1))
        .collect();
    let mut reason = if list.is_empty() {
        "not separable by these data".to_string()
    } else {
        format!("not separable from {}", list.join(", "))
    };
    let geometry = match params[k] {
        // Without a measured coordinate the first axis is a line of the arbitrary frame.
        Unknown::Param(Param::Theta(0)) if !robot.constraints.is_empty() => Some(
            "a turn about axis 1 moves every tool point as a turn of the base would, and no \
             coordinate is measured"
                .into(),
        ),
        Unknown::Param(Param::S(0)) if !robot.constraints.is_empty() => Some(
            "a shift along axis 1 moves every tool point as a shift of the base would, and no \
             coordinate is measured"
                .into(),
        ),
        Unknown::Param(p) => geometry_reason(p, &robot.robot, data),
        Unknown::Effect { .. }
        | Unknown::Point { .. }
        | Unknown::Plane { .. }
        | Unknown::Session { .. } => None,
    }
    .or_else(|| {
        names
            .iter()
            .take_while(|x| x.0 >= 0.1 * top && x.0 > 0.0)
            .take(3)
            .any(|(_, u)| matches!(u, Unknown::Point { .. } | Unknown::Plane { .. }))
            .then(|| {
                "it moves every tool point alike, and the unknown fixed points move with it \
                 (a motion of the frame they are found in)"
                    .to_owned()
            })
    });
    if let Some(geometry) = geometry {
        reason.push_str(": ");
        reason.push_str(&geometry);
    }
    reason
}

/// The geometric reason for a dependence, where one is recognised: consecutive
/// parallel joint axes, or the first joint axis parallel to the measurement frame's z.
pub(super) fn geometry_reason(param: Param, robot: &Robot<f64>, data: Rows<'_>) -> Option<String> {
    let chain = robot.chain(&data.first()?.q).ok()?;
    let parallel = |a: &Vector3<f64>, b: &Vector3<f64>| a.cross(b).norm() < 1e-9;
    let m = match param {
        Param::Theta(m) | Param::S(m) => m,
        _ => return None,
    };
    if m > 0 && parallel(&chain.axes[m].w, &chain.axes[m - 1].w) {
        return Some(format!("axes {} and {} parallel", m, m + 1));
    }
    if m == 0 && parallel(&chain.axes[0].w, &Vector3::z()) {
        return Some("axis 1 parallel to the measurement frame's z".into());
    }
    None
}
