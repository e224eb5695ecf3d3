//! The measurement order of a plan: a short path through its poses in joint
//! space, so that the robot spends its time measuring, not travelling.
//!
//! The distance between two poses is the Euclidean norm of their joint
//! differences (rad, m for a prismatic joint): the largest single joint move
//! bounds the travel time of a synchronised move, the norm weighs every
//! joint's wear alike. A nearest-neighbour tour from the pose nearest the
//! middle of the joint ranges, then 2-opt (reversing a stretch when it
//! shortens the path) until no reversal does; an open path, not a tour.

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
}
