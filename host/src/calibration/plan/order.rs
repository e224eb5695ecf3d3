//! The measurement order of a plan: a short path through its poses in joint
//! space, so that the robot spends its time measuring, not travelling.
//!
//! The distance between two poses is the Euclidean norm of their joint
//! differences (rad, m for a prismatic joint): the largest single joint move
//! bounds the travel time of a synchronised move, the norm weighs every
//! joint's wear alike. A nearest-neighbour tour from the pose nearest the
//! middle of the joint ranges, then 2-opt (reversing a stretch when it
//! shortens the path) until no reversal does; an open path, not a tour.
//!
//! ## Both sides, for backlash
//! A joint's lost motion shows only in the difference between a pose
//! approached from below and from above ([`armcal_shared::effects::Approach`]:
//! the sign of a joint's last change in row order). [`both_sides`] measures
//! each planned pose twice, approached from below and from above in every
//! joint: the rows `q − δ, q, q + δ, q`, the via rows `q ∓ δ` measured too
//! (they are poses like any other). `δ` is 0.05 rad (5 mm for a prismatic
//! joint), well beyond any backlash, less where a limit is nearer, and halved
//! until the via's tool point keeps within the cell.

/// The distance between two poses (see the module header).
fn distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

/// The length of the path through `poses` in `order`.
pub fn length(poses: &[Vec<f64>], order: &[usize]) -> f64 {
    order
        .windows(2)
        .map(|w| distance(&poses[w[0]], &poses[w[1]]))
        .sum()
}

/// A short open path through `poses` (see the module header), starting
/// from the pose nearest `middle`: the indices in measurement order.
pub fn path(poses: &[Vec<f64>], middle: &[f64]) -> Vec<usize> {
    let n = poses.len();
    if n == 0 {
        return Vec::new();
    }
    let start = (0..n)
        .min_by(|&a, &b| distance(&poses[a], middle).total_cmp(&distance(&poses[b], middle)))
        .unwrap_or(0);
    let mut order = vec![start];
    let mut left: Vec<usize> = (0..n).filter(|&i| i != start).collect();
    while !left.is_empty() {
        let last = &poses[order[order.len() - 1]];
        let (k, _) = left
            .iter()
            .enumerate()
            .min_by(|x, y| distance(last, &poses[*x.1]).total_cmp(&distance(last, &poses[*y.1])))
            .expect("poses left");
        order.push(left.swap_remove(k));
    }
    // 2-opt on the open path: reverse order[i..=j] when it shortens it.
    let mut improved = true;
    while improved {
        improved = false;
        for i in 1..n.saturating_sub(1) {
            for j in i + 1..n {
                let (a, b) = (&poses[order[i - 1]], &poses[order[i]]);
                let c = &poses[order[j]];
                let before =
                    distance(a, b) + order.get(j + 1).map_or(0.0, |&e| distance(c, &poses[e]));
                let after =
                    distance(a, c) + order.get(j + 1).map_or(0.0, |&e| distance(b, &poses[e]));
                if after < before - 1e-12 {
                    order[i..=j].reverse();
                    improved = true;
                }
            }
        }
    }
    order
}

/// The step a via row takes off a planned pose, per joint: 0.05 rad, or 5
/// mm for a prismatic joint.
pub const VIA: [f64; 2] = [0.05, 0.005];

/// The rows measuring each of `poses` (in order) approached from both sides
/// (see the module header): `limits` each joint's range a via keeps within,
/// `prismatic` which joints are, `within` whether a configuration's tool
/// point keeps within the cell. Also how many poses could not be approached
/// from both sides in every joint (a via that leaves the cell even at a
/// sixteenth of the step).
pub fn both_sides(
    poses: &[Vec<f64>],
    limits: &[[f64; 2]],
    prismatic: &[bool],
    within: impl Fn(&[f64]) -> bool,
) -> (Vec<Vec<f64>>, usize) {
    let mut rows = Vec::with_capacity(4 * poses.len());
    let mut short = 0;
    for q in poses {
        let step: Vec<f64> = q
            .iter()
            .enumerate()
            .map(|(j, v)| {
                let [lo, hi] = limits[j];
                VIA[usize::from(prismatic[j])]
                    .min(v - lo)
                    .min(hi - v)
                    .max(0.0)
            })
            .collect();
        let via = |sign: f64| -> Option<Vec<f64>> {
            let mut scale = 1.0;
            for _ in 0..5 {
                let v: Vec<f64> = q
                    .iter()
                    .zip(&step)
                    .map(|(x, d)| x + sign * scale * d)
                    .collect();
                if within(&v) {
                    return Some(v);
                }
                scale *= 0.5;
            }
            None
        };
        let (below, above) = (via(-1.0), via(1.0));
        if below.is_none() || above.is_none() || step.iter().any(|d| *d <= 0.0) {
            short += 1;
        }
        for side in [below, above] {
            if let Some(v) = side {
                rows.push(v);
            }
            rows.push(q.clone());
        }
    }
    (rows, short)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Points on a line visited out of order come back in order, from the
    /// one nearest the middle to an end and on: no path through them is
    /// shorter than the line's length plus the way back to the far end.
    #[test]
    fn a_path_through_points_on_a_line_is_short() {
        let poses: Vec<Vec<f64>> = [5.0, 1.0, 9.0, 3.0, 7.0, 0.0, 8.0, 2.0, 6.0, 4.0]
            .iter()
            .map(|x| vec![*x, 0.0])
            .collect();
        let order = path(&poses, &[4.5, 0.0]);
        let mut seen = order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..10).collect::<Vec<_>>());
        // From 4 or 5 to one end (4 or 5) and on to the other (9): 13.
        assert!(length(&poses, &order) <= 13.0 + 1e-12, "{order:?}");
    }

    /// Each pose is measured after a row below it in every joint and after
    /// a row above it: the approach of every joint is −… then +… at its two
    /// measurements, the vias within the limits.
    #[test]
    fn both_sides_approaches_each_pose_from_below_and_above() {
        let poses = vec![vec![0.2, -1.0], vec![1.0, 0.03]];
        let limits = [[-1.0, 1.0], [-1.0, 1.0]];
        let (rows, short) = both_sides(&poses, &limits, &[false, false], |_| true);
        assert_eq!(rows.len(), 8);
        // A joint at its limit has no room: that pose is counted short.
        assert_eq!(short, 2);
        assert_eq!(rows[1], poses[0]);
        assert_eq!(rows[3], poses[0]);
        assert!(rows[0][0] < poses[0][0] && rows[2][0] > poses[0][0]);
        let (rows, short) = both_sides(&[vec![0.0, 0.0]], &limits, &[false, false], |_| true);
        assert_eq!((rows.len(), short), (4, 0));
        for (via, sign) in [(&rows[0], -1.0), (&rows[2], 1.0)] {
            assert!(
                via.iter().all(|v| (v - sign * VIA[0]).abs() < 1e-15),
                "{via:?}"
            );
        }
    }
}
