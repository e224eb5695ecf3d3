//! Independent pieces of a computation spread over the machine's cores, the
//! results in the order of the pieces: the same answer on any number of cores.
//!
//! The pieces run on rayon's pool of threads, started once: handing two
//! pieces to it costs about 10 µs on this 2-core machine, where starting two
//! threads for them would cost 65 µs, as much as the cross-validation of a
//! candidate model.

/// The cores the calibration may use, asked of the system once (the answer
/// reads the process's CPU affinity and cgroup quota: tens of µs, as much as a
/// pass of a small fit).
pub fn cores() -> usize {
    static CORES: std::sync::OnceLock<usize> = std::sync::OnceLock::new();
    *CORES.get_or_init(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// The length of the pieces that share `n` items out one piece per core, at
/// least `least` items each (where a smaller piece costs more to hand over
/// than it saves).
pub fn piece_len(n: usize, least: usize) -> usize {
    n.div_ceil(cores()).max(least)
}

/// `f` of each item, on every core (each item a piece of its own), in the
/// order of `items`.
pub fn map<T: Sync, R: Send>(items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    use rayon::prelude::*;
    if cores() <= 1 || items.len() <= 1 {
        return items.iter().map(f).collect();
    }
    let f = &f;
    items.par_iter().with_max_len(1).map(f).collect()
}

/// [`map`] when `worth` it, the items one after the other otherwise: when
/// each piece takes far longer than handing it over. Handed to a worker that
/// is still looking for work, a piece costs about 10 µs; to one that went to
/// sleep, the interrupt that wakes its core costs 50–100 µs on a virtual
/// machine, as much as a candidate model's cross-validation on 100 poses.
pub fn map_if<T: Sync, R: Send>(worth: bool, items: &[T], f: impl Fn(&T) -> R + Sync) -> Vec<R> {
    if worth {
        map(items, f)
    } else {
        items.iter().map(f).collect()
    }
}

/// `f` of each item, on every core (each item a piece of its own), for what
/// it does to the item (a disjoint part of a result, say).
pub fn each<T: Send>(items: Vec<T>, f: impl Fn(T) + Sync) {
    use rayon::prelude::*;
    if cores() <= 1 || items.len() <= 1 {
        return items.into_iter().for_each(f);
    }
    let f = &f;
    items.into_par_iter().with_max_len(1).for_each(f);
}

#[cfg(test)]
mod tests {
    /// Results come back in the order of the items, whichever thread ran them.
    #[test]
    fn results_keep_the_order_of_the_items() {
        let items: Vec<u64> = (0..1000).collect();
        assert_eq!(
            super::map(&items, |x| x * x),
            items.iter().map(|x| x * x).collect::<Vec<_>>()
        );
        assert!(super::map(&[] as &[u64], |x| *x).is_empty());
    }
}
