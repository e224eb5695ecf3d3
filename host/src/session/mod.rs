//! The session: what a calibration is made from, as the files give it and
//! the science reads it — the measured rows and their channels, the joint
//! rows, the constraints of a session without a tracker, the configurations
//! its rows repeat, the prior on the geometry, and the checks that the rows
//! can carry a calibration (`require_*`), the robot model they are read
//! against, and the refusal every layer gives for an input it cannot take.
//!
//! [`crate::io`] parses files into these types and [`crate::calibration`]
//! reads them; nothing here computes a calibration or reads a file. The
//! session is the ground floor: it imports no other module of armcal (the
//! test `layers::no_import_runs_back_up` checks every floor).
//!
//! | module | idea |
//! | --- | --- |
//! | [`observation`] | one measured row ([`observation::Observation`]): joint readings, what its tool point is held to, orientation, context |
//! | [`rows`] | rows of a session borrowed, all or those an index set names ([`rows::Rows`]): a subset without copies |
//! | [`measurements`] | the session of rows ([`measurements::Measurements`]) and its `require_*` checks |
//! | [`joints`] | rows of joint readings alone ([`joints::JointRows`]) |
//! | [`constraints`] | unknown fixed points and planes, known distances |
//! | [`distinct`] | one session given once among several ([`distinct::require_distinct`]) |
//! | [`configurations`] | the distinct configurations the rows repeat, and the pure error of the repeats |
//! | [`channel`] | the kinds of measurement row, each with its own noise |
//! | [`prior`] | the prior scale of the D-H parameter errors |
//! | [`registration`] | several sessions in one calibration: each session's own base and tool frames |
//! | [`model`] | the robot model: identity, units, the nominal robot in SI, its prior |
//! | [`input_error`] | why an input was refused, and where ([`input_error::InputError`]) |

pub mod channel;
pub mod configurations;
pub mod constraints;
pub mod distinct;
pub mod input_error;
pub mod joints;
pub mod measurements;
pub mod model;
pub mod observation;
pub mod prior;
pub mod registration;
pub mod rows;
