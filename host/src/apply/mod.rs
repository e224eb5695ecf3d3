//! Using a calibration: the calibrated robot's tool point, corrected joint
//! commands, the link that loads the calibration into the controller, and the
//! warnings where a calibration is used outside the ranges it was identified on.

pub mod compensate;
pub mod link;
pub mod predict;
pub mod ranges;
