//! armcal
fn main() {}
