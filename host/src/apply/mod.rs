//! Using a calibration: the calibrated robot's tool point, corrected joint
//! commands, the link that loads the calibration into the controller, the
//! warnings where a calibration is used outside the ranges it was identified
//! on, what an export that cannot carry effects holds and how it reads back
//! as its target reads it, and the working tool that replaces the measured
//! one, and `armcal serve`, the online compensation through a controller's
//! real-time sensor interface (KUKA RSI, ABB EGM).

pub mod compensate;
pub mod export;
pub mod link;
pub mod predict;
pub mod ranges;
pub mod read_back;
pub mod serve;
pub mod working_tool;
