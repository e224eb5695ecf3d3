//! Using a calibration: the calibrated robot's tool point, corrected joint
//! commands, and the link that loads the calibration into the controller.

pub mod compensate;
pub mod link;
pub mod predict;
