//! The channels of a session: each kind of measurement row (a measured
//! position, a measured orientation, a tool point at an unknown fixed point,
//! a tool point on an unknown plane), which has its own noise, and a value
//! per channel ([`PerChannel`]). The noise itself is estimated by
//! [`crate::calibration::identify::noise`].

use std::ops::{Index, IndexMut};

/// A kind of measurement row, with its own noise.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Channel {
    /// A measured position: 3 rows, m.
    Position,
    /// A measured orientation: 3 rows, rad.
    Orientation,
    /// A tool point at an unknown fixed point (`point` column): 3 rows, m.
    Point,
    /// A tool point on an unknown plane (`plane` column): 1 row, m.
    Plane,
}

impl Channel {
    /// Every channel, in the order of the reports.
    pub const ALL: [Self; 4] = [Self::Position, Self::Orientation, Self::Point, Self::Plane];

    /// Its name in the reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Position => "position",
            Self::Orientation => "orientation",
            Self::Point => "point contact",
            Self::Plane => "plane contact",
        }
    }

    /// Its place in a [`PerChannel`].
    fn index(self) -> usize {
        self as usize
    }
}

/// One value per [`Channel`], indexed by it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PerChannel<T>(pub [T; 4]);

impl<T> PerChannel<T> {
    /// The value of each channel from `f`.
    pub fn from_fn(mut f: impl FnMut(Channel) -> T) -> Self {
        Self(Channel::ALL.map(&mut f))
    }

    /// Each channel's value through `f`.
    pub fn map<U>(&self, mut f: impl FnMut(Channel, &T) -> U) -> PerChannel<U> {
        PerChannel::from_fn(|c| f(c, &self[c]))
    }
}

impl<T> Index<Channel> for PerChannel<T> {
    type Output = T;
    fn index(&self, c: Channel) -> &T {
        &self.0[c.index()]
    }
}

impl<T> IndexMut<Channel> for PerChannel<T> {
    fn index_mut(&mut self, c: Channel) -> &mut T {
        &mut self.0[c.index()]
    }
}
