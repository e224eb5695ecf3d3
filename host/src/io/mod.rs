//! Input and output: the files armcal reads and writes, and the vendors' formats.
//!
//! Everything that turns bytes into SI values (or back) is here, and nothing
//! else: a module of this layer refuses a bad file with file, line and column,
//! and knows no calibration.

pub mod arrays;
pub mod builtin;
pub mod calibration_file;
pub mod input_error;
pub mod measurements;
pub mod model_file;
pub mod output;
pub mod sockets;
pub mod ur;
pub mod urdf;
