//! The channels of a session: each kind of measurement row (a measured
//! position, a measured orientation, a tool point at an unknown fixed point,
//! a tool point on an unknown plane), which has its own noise, and a value
//! per channel ([`PerChannel`]). The noise itself is estimated by
//! [`crate::calibration::fit::noise`].

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

/// A kind of row whose weight a calibration may take down from what its
/// noise gives it: every kind but the measured positions, by which the tool
/// point is judged (see
/// [`crate::calibration::identify::channel_weight`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Weighed {
    /// The measured orientations.
    Orientation,
    /// The tool point at unknown fixed points (a ball in a socket).
    Point,
    /// The tool point on unknown planes (a probe on a plate).
    Plane,
}

impl Weighed {
    /// Every kind, in the order of the reports.
    pub const ALL: [Self; 3] = [Self::Orientation, Self::Point, Self::Plane];

    /// Its name in the reports (plural: the rows of the kind).
    pub fn name(self) -> &'static str {
        match self {
            Self::Orientation => "orientations",
            Self::Point => "point contacts",
            Self::Plane => "plane contacts",
        }
    }

    /// Its key in the JSON report and its option's stem
    /// (`--orientation-weight`, `--point-weight`, `--plane-weight`).
    pub fn key(self) -> &'static str {
        match self {
            Self::Orientation => "orientation",
            Self::Point => "point",
            Self::Plane => "plane",
        }
    }

    /// The channel of its rows.
    pub fn channel(self) -> Channel {
        match self {
            Self::Orientation => Channel::Orientation,
            Self::Point => Channel::Point,
            Self::Plane => Channel::Plane,
        }
    }
}

/// One value per [`Weighed`] kind of row, indexed by it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PerWeighed<T>(pub [T; 3]);

impl<T> PerWeighed<T> {
    /// The value of each kind from `f`.
    pub fn from_fn(mut f: impl FnMut(Weighed) -> T) -> Self {
        Self(Weighed::ALL.map(&mut f))
    }
}

impl<T> Index<Weighed> for PerWeighed<T> {
    type Output = T;
    fn index(&self, w: Weighed) -> &T {
        &self.0[w as usize]
    }
}

impl<T> IndexMut<Weighed> for PerWeighed<T> {
    fn index_mut(&mut self, w: Weighed) -> &mut T {
        &mut self.0[w as usize]
    }
}

/// The factor on each weighed kind's rows' weight (`1/σ²`), relative to
/// what its noise gives it: 1 as the noise says, 0 not used.
pub type WeightFactors = PerWeighed<f64>;

impl WeightFactors {
    /// Every kind weighed by its noise.
    pub const NOISE: Self = Self([1.0; 3]);

    /// The factor on channel `c`'s rows (1 for the measured positions).
    pub fn of_channel(&self, c: Channel) -> f64 {
        match c {
            Channel::Position => 1.0,
            Channel::Orientation => self[Weighed::Orientation],
            Channel::Point => self[Weighed::Point],
            Channel::Plane => self[Weighed::Plane],
        }
    }

    /// The factor channel `c`'s rows are fitted at ([`Self::fitted`]; 1 for
    /// the measured positions).
    pub fn fitted_channel(&self, c: Channel) -> f64 {
        match c {
            Channel::Position => 1.0,
            Channel::Orientation => self.fitted(Weighed::Orientation),
            Channel::Point => self.fitted(Weighed::Point),
            Channel::Plane => self.fitted(Weighed::Plane),
        }
    }

    /// The factor kind `w`'s rows are fitted at: as given, except that a
    /// contact not used is fitted at [`UNUSED`] of its weight — its limit:
    /// the fixed points and planes, which only their own rows see, still
    /// determined. (Orientations not used are fitted at 0: the tool's
    /// rotation is registered to them apart.)
    pub fn fitted(&self, w: Weighed) -> f64 {
        match w {
            Weighed::Orientation => self[w],
            Weighed::Point | Weighed::Plane => self[w].max(UNUSED),
        }
    }
}

/// The factor that stands for "not used" where a kind's rows must still
/// determine what only they see: its limit.
pub const UNUSED: f64 = 1e-9;
