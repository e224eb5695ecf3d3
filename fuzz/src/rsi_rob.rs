//! `rsi_rob`: the reader of KUKA RSI's `<Rob>` datagram
//! (`armcal::apply::serve::rsi::parse`, `scan_ipoc`) and the writer of the
//! answer (`write_sen`).
//!
//! The input is one datagram as the socket delivers it. Asserts: no panic;
//! and for a datagram that is read: at most `MAX_DATAGRAM` bytes, 1 to
//! `MAX_AXES` set-point axes, every one finite; the answer written for its
//! set-points (as corrections) carries the IPOC, read back by `scan_ipoc`,
//! and one `A`n attribute per axis.

use armcal::apply::serve::rsi::{self, MAX_AXES, MAX_DATAGRAM};

/// The harness; see [the module](self). Returns whether the datagram was read.
pub fn run(data: &[u8]) -> bool {
    let _ = rsi::scan_ipoc(data);
    let Ok(rob) = rsi::parse(data) else {
        return false;
    };
    assert!(data.len() <= MAX_DATAGRAM);
    assert!((1..=MAX_AXES).contains(&rob.aspos.len()), "{rob:?}");
    assert!(rob.aspos.iter().all(|v| v.is_finite()), "{rob:?}");
    let mut sen = String::new();
    rsi::write_sen(&mut sen, "ImFree", &rob.aspos, rob.ipoc);
    assert_eq!(rsi::scan_ipoc(sen.as_bytes()), Some(rob.ipoc), "{sen}");
    assert_eq!(sen.matches(" A").count(), rob.aspos.len(), "{sen}");
    true
}
