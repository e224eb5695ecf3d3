//! What `armcal serve` counts while it runs, printed at its end (and on
//! `SIGUSR1`): cycles, late answers, refused datagrams, the set-points
//! outside the identified ranges, the largest correction, and the
//! distribution of the time from a datagram in to its answer out.
//!
//! Latency: measured from the moment the receive call returns the datagram
//! to the moment the send call of its answer returns (the decoding, the
//! correction and the encoding, and the kernel's send), with
//! [`std::time::Instant`]; the time the datagram waited in the socket
//! before that is not seen from user space. Kept in a histogram of 1 µs
//! bins up to 100 ms (the largest exactly), so that a run of any length
//! holds 800 KB: p50 and p99 to the microsecond.

use std::fmt::Write as _;
use std::time::Duration;

use armcal_shared::ranges::Outside;

use crate::apply::link::outside_text;

/// The histogram's range, µs: a longer answer counts in its last bin.
const BINS: usize = 100_000;

/// The distribution of the times from a datagram in to its answer out.
#[derive(Clone, Debug)]
pub struct Latency {
    bins: Vec<u64>,
    count: u64,
    max: Duration,
}

impl Default for Latency {
    fn default() -> Self {
        Self {
            bins: vec![0; BINS],
            count: 0,
            max: Duration::ZERO,
        }
    }
}

impl Latency {
    /// Counts one answer that took `d`.
    pub fn record(&mut self, d: Duration) {
        let us = usize::try_from(d.as_micros()).unwrap_or(usize::MAX);
        self.bins[us.min(BINS - 1)] += 1;
        self.count += 1;
        self.max = self.max.max(d);
    }

    /// Answers counted.
    pub fn count(&self) -> u64 {
        self.count
    }

    /// The largest.
    pub fn max(&self) -> Duration {
        self.max
    }

    /// The `p` quantile (0 < p ≤ 1), to the microsecond above: the least
    /// bin's upper end with at least `p` of the answers at or below it;
    /// zero when none was counted.
    pub fn quantile(&self, p: f64) -> Duration {
        if self.count == 0 {
            return Duration::ZERO;
        }
        let want = (p * self.count as f64).ceil().max(1.0) as u64;
        let mut seen = 0;
        for (us, &n) in self.bins.iter().enumerate() {
            seen += n;
            if seen >= want {
                return Duration::from_micros(us as u64 + 1).min(self.max);
            }
        }
        self.max
    }
}

/// The counts of a run (see [the module](self)).
#[derive(Clone, Debug, Default)]
pub struct Stats {
    /// Set-points corrected: datagrams in order, each answered with a new
    /// correction (during the ramp at the end too).
    pub cycles: u64,
    /// Answers sent later than the cycle after their datagram came in.
    pub late: u64,
    /// Datagrams refused (not the protocol's message, damaged, oversized,
    /// a DOCTYPE or entity, a value that is no finite number, another axis
    /// count): answered with the held correction when their stamp could be
    /// read.
    pub malformed: u64,
    /// Of those, larger than the protocol's largest datagram.
    pub oversized: u64,
    /// Of those, not answered: no stamp could be read (RSI: no IPOC).
    pub unanswered: u64,
    /// Datagrams whose stamp is not after the last one corrected
    /// (duplicated or reordered): answered with the held correction, the
    /// stream not ticked.
    pub repeated: u64,
    /// Cycles whose sent correction was held to the step per cycle.
    pub ramped: u64,
    /// Set-points the stream could not compute (a non-finite value): the
    /// correction ramps towards none.
    pub not_computable: u64,
    /// Set-points whose pose the correction misses (near a singularity, out
    /// of reach): the best correction found is sent, bounded.
    pub missed: u64,
    /// Set-points whose correction the stream bounded (its size, or its
    /// change per tick).
    pub limited: u64,
    /// Set-points outside the identified ranges.
    pub outside: u64,
    /// Which values were outside, over the run.
    pub outside_which: Outside,
    /// Whether the calibration records its ranges.
    pub ranges_known: bool,
    /// The largest correction sent, degrees, and its joint (from 1).
    pub largest: (f64, usize),
    /// EGM: cycles after the trajectory's last row (its reference held).
    pub held_at_end: u64,
    /// RSI: the controller's own count of late answers (`Delay`), as last sent.
    pub controller_delay: Option<u64>,
    /// Datagram in to answer out.
    pub latency: Latency,
}

impl Stats {
    /// Counts one corrected cycle: its step and the correction sent (rad).
    pub fn corrected(&mut self, step: &super::cycle::Step, offset: &[f64]) {
        use armcal_shared::compensation::Fault;
        self.cycles += 1;
        self.ramped += u64::from(step.ramped);
        match step.fault {
            Some(Fault::NonFinite | Fault::JointCount) => self.not_computable += 1,
            Some(Fault::NotConverged) if step.missed => self.missed += 1,
            Some(Fault::Limited) => self.limited += 1,
            _ => {}
        }
        if step.outside.any() {
            self.outside += 1;
            self.outside_which = self.outside_which.union(step.outside);
        }
        for (m, x) in offset.iter().enumerate() {
            let deg = x.abs().to_degrees();
            if deg > self.largest.0 {
                self.largest = (deg, m + 1);
            }
        }
    }

    /// Counts one refused datagram: `oversized` or not, `answered` (with
    /// the held correction) or not.
    pub fn refused(&mut self, oversized: bool, answered: bool) {
        self.malformed += 1;
        self.oversized += u64::from(oversized);
        self.unanswered += u64::from(!answered);
    }

    /// The statistics for standard error, one `name value` per line after
    /// `heading`; `cycle` is the controller's cycle.
    pub fn text(&self, heading: &str, cycle: Duration) -> String {
        let mut out = format!("armcal: {heading}\n");
        let us = |d: Duration| d.as_micros();
        let l = &self.latency;
        let mut line = |s: String| {
            let _ = writeln!(out, "  {s}");
        };
        line(format!("cycles {}", self.cycles));
        line(format!(
            "late {} (answered later than the {} ms cycle)",
            self.late,
            cycle.as_secs_f64() * 1e3
        ));
        line(format!(
            "malformed {} ({} oversized, {} without a readable stamp, not answered)",
            self.malformed, self.oversized, self.unanswered
        ));
        line(format!(
            "repeated {} (duplicated or reordered: the held correction)",
            self.repeated
        ));
        line(format!(
            "ramped {} (the correction's change held to the step)",
            self.ramped
        ));
        line(format!(
            "not computable {}, missed {}, bounded {}",
            self.not_computable, self.missed, self.limited
        ));
        let outside = if self.ranges_known {
            outside_text(self.outside, self.outside_which, "cycles")
        } else {
            "cycles outside the identified ranges not judged (the calibration does not record them)"
                .to_owned()
        };
        line(format!("outside {outside}"));
        line(format!(
            "largest correction {:.6} deg (joint {})",
            self.largest.0, self.largest.1
        ));
        if self.held_at_end > 0 {
            line(format!(
                "held at end {} (cycles after the trajectory's last row)",
                self.held_at_end
            ));
        }
        if let Some(d) = self.controller_delay {
            line(format!(
                "controller delay {d} (its own count of late answers)"
            ));
        }
        line(format!(
            "latency p50 {} us, p99 {} us, max {} us (datagram in to answer out, {} answers)",
            us(l.quantile(0.5)),
            us(l.quantile(0.99)),
            us(l.max()),
            l.count()
        ));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The quantiles of a known distribution: 1..=1000 µs, one each.
    #[test]
    fn quantiles_of_a_known_distribution() {
        let mut l = Latency::default();
        for us in (1..=1000).rev() {
            l.record(Duration::from_micros(us));
        }
        assert_eq!(l.count(), 1000);
        // 500 answers took at most 500 µs: its bin [500, 501) ends at 501.
        assert_eq!(l.quantile(0.5), Duration::from_micros(501));
        assert_eq!(l.quantile(0.99), Duration::from_micros(991));
        assert_eq!(l.max(), Duration::from_micros(1000));
        assert_eq!(l.quantile(1.0), Duration::from_micros(1000));
        // One beyond the histogram: its max exact, its bin the last.
        l.record(Duration::from_secs(1));
        assert_eq!(l.max(), Duration::from_secs(1));
        assert_eq!(Latency::default().quantile(0.5), Duration::ZERO);
    }
}
