//! The ranges a calibration was identified on, and where a pose lies outside
//! them.
//!
//! A calibration is a fit to the poses of one session: each joint swept an
//! interval, and the session had a temperature and a payload (the `temp` and
//! `load` columns, when it had them). Inside those intervals the identified
//! errors and effects were tested by the data; outside them they are an
//! extrapolation (a gear harmonic, a compliance, a thermal coefficient carried
//! beyond what was seen), which can be worse than the nominal model. [`Ranges`]
//! records the intervals in the calibration file (format version 4), and
//! [`Ranges::outside`] says which of a pose's values lie beyond them.
//!
//! Units: SI like the rest of this crate: each joint in rad (revolute) or m
//! (prismatic), in the model's joint order; the temperature in °C; the payload
//! in kg. A value on an interval's bound is inside.

use heapless::Vec;
use serde::{Deserialize, Serialize};

use crate::{MAX_JOINTS, Real};

/// A closed interval `[min, max]` of one quantity.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Interval<T> {
    /// The smallest value seen.
    pub min: T,
    /// The largest value seen.
    pub max: T,
}

impl<T: Real> Interval<T> {
    /// The interval of one value.
    pub fn at(x: T) -> Self {
        Self { min: x, max: x }
    }

    /// Widens the interval to hold `x`.
    pub fn include(&mut self, x: T) {
        self.min = self.min.min(x);
        self.max = self.max.max(x);
    }

    /// True if `x` is below `min` or above `max` (NaN is neither).
    pub fn excludes(&self, x: T) -> bool {
        x < self.min || x > self.max
    }

    /// How far `x` lies beyond the interval: `min − x` below it, `x − max`
    /// above it, 0 inside.
    pub fn excess(&self, x: T) -> T {
        (self.min - x).max(x - self.max).max(T::zero())
    }

    /// Both bounds finite and `min ≤ max`.
    pub fn is_valid(&self) -> bool {
        self.min.is_finite() && self.max.is_finite() && self.min <= self.max
    }

    /// The same interval in another scalar type.
    pub fn cast<U: Real>(&self) -> Interval<U> {
        Interval {
            min: U::lit(self.min.to_f64()),
            max: U::lit(self.max.to_f64()),
        }
    }
}

/// Where a calibration was identified: each joint's interval, and the
/// temperature's and payload's when the session had them (see [the module](self)).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Ranges<T> {
    /// One interval per joint, in the model's joint order, rad or m.
    pub joints: Vec<Interval<T>, MAX_JOINTS>,
    /// The temperatures of the session, °C; `None` when it had none.
    pub temperature: Option<Interval<T>>,
    /// The payloads of the session, kg; `None` when it had none.
    pub load: Option<Interval<T>>,
}

/// Which of a pose's values lie outside the [`Ranges`]: a set, empty when the
/// pose is inside them all.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Outside {
    /// Bit `m` set: joint `m + 1` (0-based `m`) is outside its interval.
    pub joints: u16,
    /// The temperature is outside the session's.
    pub temperature: bool,
    /// The payload is outside the session's.
    pub load: bool,
}

impl Outside {
    /// True if any value is outside.
    pub fn any(&self) -> bool {
        self.joints != 0 || self.temperature || self.load
    }

    /// True if joint `m` (0-based) is outside.
    pub fn joint(&self, m: usize) -> bool {
        m < 16 && self.joints & (1 << m) != 0
    }

    /// Both sets together.
    pub fn union(self, other: Self) -> Self {
        Self {
            joints: self.joints | other.joints,
            temperature: self.temperature || other.temperature,
            load: self.load || other.load,
        }
    }
}

impl<T: Real> Ranges<T> {
    /// No pose seen yet.
    pub fn new() -> Self {
        Self {
            joints: Vec::new(),
            temperature: None,
            load: None,
        }
    }

    /// Widens the ranges to hold one pose: its joint values `q` (the first pose
    /// sets the joint count; extra values of a later pose are ignored), and its
    /// temperature and payload when known.
    pub fn include(&mut self, q: &[T], temperature: Option<T>, load: Option<T>) {
        if self.joints.is_empty() {
            self.joints = q.iter().map(|&x| Interval::at(x)).collect();
        } else {
            for (r, &x) in self.joints.iter_mut().zip(q) {
                r.include(x);
            }
        }
        for (range, value) in [(&mut self.temperature, temperature), (&mut self.load, load)] {
            if let Some(x) = value {
                match range {
                    Some(r) => r.include(x),
                    None => *range = Some(Interval::at(x)),
                }
            }
        }
    }

    /// The ranges of a sequence of poses `(q, temperature, load)`.
    pub fn of<'a>(poses: impl IntoIterator<Item = (&'a [T], Option<T>, Option<T>)>) -> Self
    where
        T: 'a,
    {
        let mut ranges = Self::new();
        for (q, temperature, load) in poses {
            ranges.include(q, temperature, load);
        }
        ranges
    }

    /// Which values of a pose lie outside: each joint of `q` against its
    /// interval, the temperature and payload (when given) against the session's
    /// (when it had them). Cheap enough for every servo tick: two comparisons
    /// per value, no arithmetic.
    pub fn outside(&self, q: &[T], temperature: Option<T>, load: Option<T>) -> Outside {
        let mut joints = 0u16;
        for (m, (r, &x)) in self.joints.iter().zip(q).enumerate() {
            if r.excludes(x) {
                joints |= 1 << m;
            }
        }
        let beyond = |range: &Option<Interval<T>>, value: Option<T>| match (range, value) {
            (Some(r), Some(x)) => r.excludes(x),
            _ => false,
        };
        Outside {
            joints,
            temperature: beyond(&self.temperature, temperature),
            load: beyond(&self.load, load),
        }
    }

    /// One interval per joint of a `dof`-joint model, every one finite with
    /// `min ≤ max`.
    pub fn is_valid(&self, dof: usize) -> bool {
        self.joints.len() == dof
            && self
                .joints
                .iter()
                .chain(&self.temperature)
                .chain(&self.load)
                .all(Interval::is_valid)
    }

    /// The same ranges in another scalar type (the controller's `f32`).
    pub fn cast<U: Real>(&self) -> Ranges<U> {
        Ranges {
            joints: self.joints.iter().map(Interval::cast).collect(),
            temperature: self.temperature.as_ref().map(Interval::cast),
            load: self.load.as_ref().map(Interval::cast),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The intervals of a few poses are their extremes; a pose beyond them is
    /// named by joint, temperature and load, one on a bound is inside.
    #[test]
    fn ranges_of_poses_and_what_lies_outside() {
        let poses: [([f64; 3], Option<f64>, Option<f64>); 3] = [
            ([0.1, -0.5, 0.02], Some(21.0), None),
            ([-0.3, 0.5, 0.05], None, Some(2.0)),
            ([0.2, 0.0, 0.03], Some(28.5), Some(5.0)),
        ];
        let r = Ranges::of(poses.iter().map(|(q, t, l)| (&q[..], *t, *l)));
        assert_eq!(
            r.joints.as_slice(),
            &[
                Interval {
                    min: -0.3,
                    max: 0.2
                },
                Interval {
                    min: -0.5,
                    max: 0.5
                },
                Interval {
                    min: 0.02,
                    max: 0.05
                }
            ]
        );
        assert_eq!(
            r.temperature,
            Some(Interval {
                min: 21.0,
                max: 28.5
            })
        );
        assert_eq!(r.load, Some(Interval { min: 2.0, max: 5.0 }));
        assert!(r.is_valid(3) && !r.is_valid(2));
        let inside = r.outside(&[0.2, -0.5, 0.04], Some(21.0), None);
        assert!(!inside.any(), "on the bounds is inside: {inside:?}");
        let o = r.outside(&[0.2, 1.5, 0.04], Some(140.0), Some(4000.0));
        assert_eq!(
            o,
            Outside {
                joints: 0b010,
                temperature: true,
                load: true
            }
        );
        assert!(o.joint(1) && !o.joint(0) && !o.joint(15));
        assert_eq!(r.joints[1].excess(1.5), 1.0);
        assert_eq!(r.joints[0].excess(-0.8), 0.5);
        assert_eq!(r.joints[0].excess(0.0), 0.0);
        // No temperature in the session: a tick's temperature is not judged.
        let cold = Ranges::of([(&[0.0f64][..], None, None)]);
        assert!(!cold.outside(&[0.0], Some(140.0), None).any());
        // In f32, as the controller holds them: the same verdicts.
        let f = r.cast::<f32>();
        assert_eq!(f.outside(&[0.2, 1.5, 0.04], Some(140.0), Some(4000.0)), o);
    }

    /// Non-finite or reversed intervals are invalid.
    #[test]
    fn invalid_intervals() {
        let mut r = Ranges::of([(&[0.0f64, 1.0][..], Some(20.0), None)]);
        assert!(r.is_valid(2));
        r.joints[1].max = f64::NAN;
        assert!(!r.is_valid(2));
        r.joints[1] = Interval { min: 1.0, max: 0.0 };
        assert!(!r.is_valid(2));
        r.joints[1] = Interval { min: 0.0, max: 1.0 };
        r.temperature = Some(Interval {
            min: f64::NEG_INFINITY,
            max: 0.0,
        });
        assert!(!r.is_valid(2));
    }
}
